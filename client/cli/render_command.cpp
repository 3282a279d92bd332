// glint render: a renderer's G-buffer (client/preview/gbuffer.h) -> one query per covered pixel
// -> one Evaluate (unary, or one stream when large) -> beauty EXR at the G-buffer's size.
#include "client/cli/render_command.h"

#include <array>
#include <cmath>
#include <cstdio>
#include <optional>

#include "client/lib/query_io.h"
#include "client/lib/rate_format.h"
#include "client/preview/exr_layers.h"
#include "client/preview/gbuffer.h"
#include "client/preview/image_io.h"

namespace glint::cli {

const char *const kRenderUsage =
    R"(usage: glint render --server ADDR --gbuffer G.exr --material M.json --lights L.json
                    --out BEAUTY.exr [--camera X,Y,Z] [--channels KEY=LAYER,...] [--half] [--png]
                    [--precision fp32|fp64] [--seed N]
                    [--area-method ltc|reference|lecocq|lecocq-pearson|mc|auto] [--samples N]
                    [--max-error E]

Shades every covered pixel of a renderer's G-buffer with the material under world-space lights
and writes the beauty: channels R, G, B (float, or half with --half) at the G-buffer's data and
display windows, plus the G-buffer's alpha channel A when it has one. Background pixels (alpha
0, or a normal of (0, 0, 0) without alpha) are black. Each pixel is exactly what 'glint eval'
returns for that pixel's query.

G-buffer layers (single-part EXR; P, N, T, V channels .X/.Y/.Z or .R/.G/.B, uv channels .U/.V,
.X/.Y or .R/.G, upper or lower case):
  P         world-space position (required)
  N         world-space shading normal (required; normalised if not unit)
  uv        texture coordinates (required)
  T         tangent, direction of increasing u (optional; else derived from P and uv)
  V         unit vector from the surface to the eye (optional; else from --camera)
  dudx dvdx dudy dvdy   the pixel footprint (optional, all four; else central differences of
            neighbouring pixels' uv, one-sided at image edges, silhouettes and uv seams)
  A         alpha (optional; 0 = background)

  --server ADDR       gRPC target, e.g. 127.0.0.1:50051
  --gbuffer G.exr     the renderer's G-buffer
  --material M.json   glint.v1.Material in proto3 JSON
  --lights L.json     glint.v1.LightList in proto3 JSON (world space)
  --out BEAUTY.exr    output EXR
  --camera X,Y,Z      world-space camera position: wo = normalize(camera - P) per pixel
                      (required unless the G-buffer has a V layer; overrides V)
  --channels MAP      other layer names, e.g. for Blender Cycles
                      P=ViewLayer.Position,N=ViewLayer.Normal,uv=ViewLayer.UV,A=ViewLayer.Combined.A
                      keys: P, N, T, uv, V, A (a full channel name), footprint (a prefix)
  --half              store half floats instead of float32
  --png               also write BEAUTY.png beside the EXR (tone-mapped sRGB, as preview's)
  --precision P       fp32 (default) or fp64
  --seed N            seed of the stochastic glint models (default 0)
  --area-method M     polygon lights: ltc (default), lecocq, lecocq-pearson, mc, reference or auto
  --samples N         reference / mc samples (see 'glint eval --help')
  --max-error E       auto: the relative error allowed per query and light (e.g. 0.05)
)";

const std::vector<std::string> kRenderOptions = {"server", "gbuffer",     "material", "lights",
                                                 "out",    "camera",      "channels", "precision",
                                                 "seed",   "area-method", "samples",  "max-error"};

namespace {

std::array<double, 3> ParseCamera(const std::string &text) {
  std::array<double, 3> xyz{};
  size_t start = 0;
  for (int i = 0; i < 3; ++i) {
    const size_t comma = text.find(',', start);
    const bool last = i == 2;
    if (last != (comma == std::string::npos)) {
      throw UsageError{"--camera: '" + text + "' is not X,Y,Z"};
    }
    const std::string item = text.substr(start, last ? std::string::npos : comma - start);
    xyz[static_cast<size_t>(i)] = ParseNumber<double>("camera", item);
    if (!std::isfinite(xyz[static_cast<size_t>(i)])) {
      throw UsageError{"--camera: '" + text + "' has a non-finite coordinate"};
    }
    start = comma + 1;
  }
  return xyz;
}

}  // namespace

int RunRender(const Options &options) {
  const std::string server = options.Required("server");
  const std::string gbuffer_path = options.Required("gbuffer");
  const std::string material_path = options.Required("material");
  const std::string lights_path = options.Required("lights");
  const std::string out = options.Required("out");
  if (glint::client::OutputFormatFromPath(out) != glint::client::OutputFormat::kExr) {
    throw UsageError{"--out " + out + ": render writes an .exr"};
  }
  std::optional<std::array<double, 3>> camera;
  if (options.Has("camera")) camera = ParseCamera(options.Required("camera"));
  glint::client::GBufferLayers layers;
  if (options.Has("channels")) {
    std::string error;
    if (!glint::client::ParseLayerMapping(options.Required("channels"), &layers, &error)) {
      throw UsageError{"--channels: " + error};
    }
  }

  glint::v1::EvaluateRequest request;
  FillSettings(options, &request);
  *request.mutable_material() = glint::client::ReadMaterialJson(material_path);
  for (auto &light : glint::client::ReadLightsJson(lights_path)) {
    *request.add_lights() = std::move(light);
  }
  const glint::client::GBuffer gbuffer = glint::client::ReadGBuffer(gbuffer_path, layers);
  glint::client::PreviewQueries scene = glint::client::GBufferQueries(gbuffer, camera);
  *request.mutable_queries() = std::move(scene.queries);
  const uint32_t count = request.queries().count();

  glint::client::GlintClient client(server, ConnectionOptions(options));
  std::vector<float> rgb;
  glint::client::EvaluateInfo info;
  double seconds = 0.0;
  if (count > 0) {
    const std::optional<double> t = EvaluateWithProgress(client, request, &rgb, &info, server);
    if (!t) return kExitFailure;
    seconds = *t;
  }
  const std::vector<float> image = glint::client::ScatterToImage(scene, rgb);

  const size_t pixels = static_cast<size_t>(gbuffer.width) * static_cast<size_t>(gbuffer.height);
  std::vector<std::vector<float>> planes(3, std::vector<float>(pixels));
  for (size_t p = 0; p < pixels; ++p) {
    for (size_t c = 0; c < 3; ++c) planes[c][p] = image[3 * p + c];
  }
  std::vector<glint::client::ExrPlane> channels = {
      {"R", planes[0].data()}, {"G", planes[1].data()}, {"B", planes[2].data()}};
  if (!gbuffer.alpha.empty()) channels.push_back({"A", gbuffer.alpha.data()});
  glint::client::WriteExrChannels(out, gbuffer.data_window, gbuffer.display_window, channels,
                                  options.Has("half"));
  if (options.Has("png")) {
    const std::string png = out.substr(0, out.size() - 4) + ".png";
    glint::client::WritePngToneMapped(png, gbuffer.width, gbuffer.height, image);
    std::printf("%s\n", png.c_str());
  }
  std::printf("glint render: %dx%d, %u covered pixels in %.3f s (%s queries/s) via %s -> %s\n",
              gbuffer.width, gbuffer.height, count, seconds,
              glint::client::FormatRate(count, seconds).c_str(), Transport(info).c_str(),
              out.c_str());
  return kExitOk;
}

}  // namespace glint::cli
