// glint: command-line client of glintd. Commands: info, eval, preview (see kUsage below).
// Exit codes: 0 success, 1 failure at run time (server, files), 2 wrong command line.
#include <unistd.h>

#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "client/cli/normal_map_commands.h"
#include "client/lib/glint_client.h"
#include "client/lib/query_io.h"
#include "client/preview/image_io.h"
#include "client/preview/preview_scene.h"

namespace {

using glint::client::GlintClient;

constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;
constexpr int kExitUsage = 2;

constexpr const char *kUsage =
    R"(glint: command-line client of glintd, the glint BRDF evaluation service

usage: glint <command> [options]

commands:
  info      print the server's capabilities; exit 0 only when it reports SERVING
  eval      evaluate a CSV of shading queries; write radiance as CSV, NPY or EXR
  preview   render a sphere or plane preview of a material under lights (EXR + PNG)
  upload    upload a normal map (EXR / PNG) and print its digest
  normal-map  generate a normal map: bumpy, flakes, brushed or scratches

Run 'glint <command> --help' for the options of a command.
)";

constexpr const char *kInfoUsage = R"(usage: glint info --server ADDR [--timeout-ms MS]

Waits until the server's grpc.health.v1 status is SERVING (at most --timeout-ms, default 5000),
then prints its capabilities (device, limits, supported models). Exits 1 and says why when the
server is unreachable or not SERVING in time.

  --server ADDR     gRPC target, e.g. 127.0.0.1:50051 or dns:///glint:50051
  --timeout-ms MS   how long to wait for SERVING (default 5000)
)";

constexpr const char *kEvalUsage =
    R"(usage: glint eval --server ADDR --material M.json [--lights L.json] --queries Q.csv
                  --out OUT.{csv,npy,exr} [--precision fp32|fp64] [--seed N] [--width W] [--half]
                  [--area-method ltc|reference|lecocq|lecocq-pearson|mc] [--samples N]

Evaluates every query of Q.csv and writes the reflected radiance (RGB per query, in input
order). Batches larger than the server's limits are streamed in chunks automatically.

  --server ADDR       gRPC target, e.g. 127.0.0.1:50051
  --material M.json   glint.v1.Material in proto3 JSON, e.g.
                      {"model": "SMOOTH", "ndf": "GGX", "alpha_x": 0.3, "alpha_y": 0.1,
                       "schlick": {"f0": [0.9, 0.6, 0.3]}}
  --lights L.json     glint.v1.LightList: {"lights": [{"directional": {...}}, {"point": {...}}]}
                      (omit for BRDF probes, i.e. queries with wix,wiy,wiz)
  --queries Q.csv     header of column names, any order:
                        u,v (default 0)   dudx,dvdx,dudy,dvdy (default 0)
                        wox,woy,woz (all or none; none = 0,0,1)   wix,wiy,wiz (all or none)
                        px,py,pz,nx,ny,nz,tx,ty,tz (world-space frame: all or none)
  --out PATH          .csv (header r,g,b), .npy (float32, shape (N, 3)) or .exr (RGB image)
  --precision P       fp32 (default) or fp64
  --seed N            seed of the stochastic glint models (default 0)
  --area-method M     polygon lights: ltc (default), lecocq, lecocq-pearson (Lecocq et al.
                      peak fits), mc (Monte Carlo, seeded) or reference (quadrature)
  --samples N         reference: quadrature nodes per dimension per triangle; mc: samples
                      per query and light (default 64)
  --width W           .exr only: image width; rows follow query order, the tail is black
                      (default: all queries in one row)
  --half              .exr only: store half floats instead of float32
  --normal-map FILE   NORMAL_MAP model: use FILE (EXR / PNG) as material.normal_map.digest,
                      uploading it when the server does not hold it

A progress bar is drawn on stderr when it is a terminal; a one-line summary goes to stdout.
)";

constexpr const char *kPreviewUsage =
    R"(usage: glint preview --server ADDR --material M.json --lights L.json --out IMG.exr
                     [--scene sphere|plane] [--size WxH] [--exposure STOPS]
                     [--precision fp32|fp64] [--seed N] [--half]
                     [--area-method ltc|reference|lecocq|lecocq-pearson|mc] [--samples N]

Renders the material on a unit sphere or a ground plane seen by a fixed pinhole camera (one
query per covered pixel, with ray-differential footprints) under world-space lights. Writes
IMG.exr (linear radiance) and IMG.png next to it (tone-mapped sRGB) and prints both paths.

  --server ADDR       gRPC target, e.g. 127.0.0.1:50051
  --material M.json   glint.v1.Material in proto3 JSON
  --lights L.json     glint.v1.LightList in proto3 JSON (world space, +z up)
  --out IMG.exr       output EXR; the PNG gets the same name with .png
  --scene S           sphere (default) or plane
  --size WxH          image size in pixels (default 512x512)
  --exposure STOPS    PNG exposure in stops, scale 2^STOPS (default 0)
  --precision P       fp32 (default) or fp64
  --seed N            seed of the stochastic glint models (default 0)
  --area-method M     polygon lights: ltc (default), lecocq, lecocq-pearson (Lecocq et al.
                      peak fits), mc (Monte Carlo, seeded) or reference (quadrature)
  --samples N         reference: quadrature nodes per dimension per triangle; mc: samples
                      per query and light (default 64)
  --half              store half floats in the EXR instead of float32
  --normal-map FILE   NORMAL_MAP model: use FILE (EXR / PNG) as material.normal_map.digest,
                      uploading it when the server does not hold it
)";

// A command-line mistake: printed with the command's usage, exit 2.
struct UsageError {
  std::string message;
};

// --name value, --name=value, or a bare --flag. Only the options a command declares exist.
class Options {
 public:
  Options(int argc, char **argv, const std::vector<std::string> &with_value,
          const std::vector<std::string> &flags) {
    for (int i = 0; i < argc; ++i) {
      std::string arg = argv[i];
      if (arg == "--help" || arg == "-h") {
        help_ = true;
        continue;
      }
      if (arg.rfind("--", 0) != 0) throw UsageError{"unexpected argument '" + arg + "'"};
      std::string name = arg.substr(2);
      std::optional<std::string> inline_value;
      if (const size_t eq = name.find('='); eq != std::string::npos) {
        inline_value = name.substr(eq + 1);
        name = name.substr(0, eq);
      }
      const bool takes_value = Contains(with_value, name);
      if (!takes_value && !Contains(flags, name)) throw UsageError{"unknown option --" + name};
      if (values_.count(name)) throw UsageError{"option --" + name + " given twice"};
      if (!takes_value) {
        if (inline_value) throw UsageError{"option --" + name + " takes no value"};
        values_[name] = "";
        continue;
      }
      if (inline_value) {
        values_[name] = *inline_value;
      } else if (i + 1 < argc) {
        values_[name] = argv[++i];
      } else {
        throw UsageError{"option --" + name + " needs a value"};
      }
    }
  }

  bool help() const { return help_; }
  bool Has(const std::string &name) const { return values_.count(name) != 0; }
  std::string Required(const std::string &name) const {
    auto it = values_.find(name);
    if (it == values_.end() || it->second.empty()) throw UsageError{"missing --" + name};
    return it->second;
  }
  std::string Get(const std::string &name, const std::string &fallback) const {
    auto it = values_.find(name);
    return it == values_.end() ? fallback : it->second;
  }

 private:
  static bool Contains(const std::vector<std::string> &v, const std::string &s) {
    for (const auto &x : v) {
      if (x == s) return true;
    }
    return false;
  }
  bool help_ = false;
  std::map<std::string, std::string> values_;
};

template <typename T>
T ParseNumber(const std::string &option, const std::string &text) {
  T value{};
  const char *end = text.data() + text.size();
  auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (ec != std::errc() || ptr != end || text.empty()) {
    throw UsageError{"--" + option + ": '" + text + "' is not a valid number"};
  }
  return value;
}

glint::v1::Precision ParsePrecision(const std::string &text) {
  if (text == "fp32") return glint::v1::FP32;
  if (text == "fp64") return glint::v1::FP64;
  throw UsageError{"--precision: '" + text + "' is neither fp32 nor fp64"};
}

glint::v1::AreaMethod ParseAreaMethod(const std::string &text) {
  if (text == "ltc") return glint::v1::LTC;
  if (text == "reference") return glint::v1::REFERENCE;
  if (text == "lecocq") return glint::v1::LECOCQ;
  if (text == "lecocq-pearson") return glint::v1::LECOCQ_PEARSON;
  if (text == "mc") return glint::v1::MONTE_CARLO;
  throw UsageError{"--area-method: '" + text +
                   "' is not one of ltc, reference, lecocq, lecocq-pearson, mc"};
}

// Draws "[=====>     ]  45%  450000/1000000 queries" on stderr, only when stderr is a
// terminal: logs and pipes must not fill up with carriage returns.
class ProgressBar {
 public:
  ProgressBar() : enabled_(isatty(STDERR_FILENO) == 1) {}
  ~ProgressBar() { Finish(); }

  void Update(uint64_t done, uint64_t total) {
    if (!enabled_ || total == 0) return;
    const auto now = std::chrono::steady_clock::now();
    // Redrawing more often than ~10 Hz costs time and shows nothing new.
    if (done < total && drawn_ && now - last_ < std::chrono::milliseconds(100)) return;
    last_ = now;
    drawn_ = true;
    constexpr int kWidth = 40;
    const double fraction = static_cast<double>(done) / static_cast<double>(total);
    const int filled = static_cast<int>(fraction * kWidth);
    std::string bar(static_cast<size_t>(kWidth), ' ');
    for (int i = 0; i < filled; ++i) bar[static_cast<size_t>(i)] = '=';
    if (filled < kWidth) bar[static_cast<size_t>(filled)] = '>';
    std::fprintf(stderr, "\r[%s] %3d%%  %llu/%llu queries", bar.c_str(),
                 static_cast<int>(fraction * 100.0), static_cast<unsigned long long>(done),
                 static_cast<unsigned long long>(total));
    std::fflush(stderr);
  }

  void Finish() {
    if (enabled_ && drawn_) std::fputc('\n', stderr);
    drawn_ = false;
  }

 private:
  bool enabled_;
  bool drawn_ = false;
  std::chrono::steady_clock::time_point last_{};
};

// "glint: <what>: UNAVAILABLE: ..." plus a hint where the code has an obvious cause.
int ReportRpcError(const std::string &what, const grpc::Status &status, const std::string &server) {
  std::fprintf(stderr, "glint: %s: %s\n", what.c_str(),
               glint::client::FormatStatus(status).c_str());
  if (status.error_code() == grpc::StatusCode::UNAVAILABLE) {
    std::fprintf(stderr, "glint: is glintd running and listening on %s?\n", server.c_str());
  }
  return kExitFailure;
}

std::string Join(const google::protobuf::RepeatedPtrField<std::string> &items) {
  std::string out;
  for (const auto &s : items) {
    if (!out.empty()) out += ", ";
    out += s;
  }
  return out.empty() ? "(none reported)" : out;
}

std::string Bytes(uint64_t n) {
  char buf[64];
  if (n >= (1u << 20) && n % (1u << 20) == 0) {
    std::snprintf(buf, sizeof buf, "%llu MiB", static_cast<unsigned long long>(n >> 20));
  } else {
    std::snprintf(buf, sizeof buf, "%llu bytes", static_cast<unsigned long long>(n));
  }
  return buf;
}

int RunInfo(const Options &options) {
  const std::string server = options.Required("server");
  const auto timeout_ms = ParseNumber<int64_t>("timeout-ms", options.Get("timeout-ms", "5000"));
  if (timeout_ms < 0) throw UsageError{"--timeout-ms must not be negative"};
  GlintClient client(server);
  std::string why;
  if (!client.WaitUntilServing(std::chrono::milliseconds(timeout_ms), &why)) {
    std::fprintf(stderr, "glint: server %s: %s\n", server.c_str(), why.c_str());
    return kExitFailure;
  }
  glint::v1::Capabilities caps;
  if (grpc::Status status = client.GetCapabilities(&caps); !status.ok()) {
    return ReportRpcError("GetCapabilities", status, server);
  }
  std::printf("server           %s (SERVING)\n", server.c_str());
  std::printf("server version   %s\n", caps.server_version().c_str());
  std::printf("device           %s (%s), %u compute units\n", caps.device_name().c_str(),
              caps.device_vendor().c_str(), caps.compute_units());
  std::printf("opencl           %s; driver %s; platform %s\n", caps.device_opencl_version().c_str(),
              caps.driver_version().c_str(), caps.platform_name().c_str());
  std::printf("fp64             %s\n", caps.fp64() ? "yes" : "no");
  std::printf("models           %s\n", Join(caps.models()).c_str());
  std::printf("ndfs             %s\n", Join(caps.ndfs()).c_str());
  std::printf("fresnel kinds    %s\n", Join(caps.fresnel_kinds()).c_str());
  std::printf("light kinds      %s\n", Join(caps.light_kinds()).c_str());
  std::printf("max batch        %u queries per call or stream chunk\n", caps.max_batch());
  std::printf("max message      %s\n", Bytes(caps.max_message_bytes()).c_str());
  std::printf("max lights       %u\n", caps.max_lights());
  std::printf("max pending      %u requests (beyond: RESOURCE_EXHAUSTED)\n",
              caps.max_pending_requests());
  std::printf("unit tolerance   %g\n", caps.unit_vector_tolerance());
  if (caps.normal_map_budget_bytes() > 0)
    std::printf("normal maps      uploads <= %s, <= %llu texels, budget %s (LRU)\n",
                Bytes(caps.max_normal_map_upload_bytes()).c_str(),
                static_cast<unsigned long long>(caps.max_normal_map_texels()),
                Bytes(caps.normal_map_budget_bytes()).c_str());
  return kExitOk;
}

// Fills the settings every evaluating command shares.
void FillSettings(const Options &options, glint::v1::EvaluateRequest *request) {
  request->set_precision(ParsePrecision(options.Get("precision", "fp32")));
  request->set_seed(ParseNumber<uint64_t>("seed", options.Get("seed", "0")));
  request->set_area_method(ParseAreaMethod(options.Get("area-method", "ltc")));
  if (options.Has("samples"))
    request->set_area_samples(ParseNumber<uint32_t>("samples", options.Get("samples", "")));
}

// Evaluates with a progress bar and returns the wall time in seconds, or nullopt after
// reporting an RPC error.
std::optional<double> EvaluateWithProgress(GlintClient &client,
                                           const glint::v1::EvaluateRequest &request,
                                           std::vector<float> *rgb,
                                           glint::client::EvaluateInfo *info,
                                           const std::string &server) {
  ProgressBar bar;
  const auto start = std::chrono::steady_clock::now();
  grpc::Status status = client.Evaluate(
      request, rgb, [&](uint64_t done, uint64_t total) { bar.Update(done, total); }, info);
  const std::chrono::duration<double> elapsed = std::chrono::steady_clock::now() - start;
  bar.Finish();
  if (!status.ok()) {
    ReportRpcError("evaluation failed", status, server);
    return std::nullopt;
  }
  return elapsed.count();
}

std::string Transport(const glint::client::EvaluateInfo &info) {
  if (!info.streamed) return "unary";
  return "stream (" + std::to_string(info.chunks) +
         " chunks of <= " + std::to_string(info.chunk_queries) + " queries)";
}

int RunEval(const Options &options) {
  const std::string server = options.Required("server");
  const std::string material_path = options.Required("material");
  const std::string queries_path = options.Required("queries");
  const std::string out = options.Required("out");
  const glint::client::OutputFormat format = glint::client::OutputFormatFromPath(out);
  if (format == glint::client::OutputFormat::kUnknown) {
    throw UsageError{"--out " + out + ": the extension must be .csv, .npy or .exr"};
  }
  const bool exr = format == glint::client::OutputFormat::kExr;
  if (!exr && (options.Has("width") || options.Has("half"))) {
    throw UsageError{"--width and --half apply to .exr output only"};
  }
  int width = 0;
  if (options.Has("width")) {
    width = ParseNumber<int>("width", options.Required("width"));
    if (width <= 0) throw UsageError{"--width must be positive"};
  }

  glint::v1::EvaluateRequest request;
  FillSettings(options, &request);
  *request.mutable_material() = glint::client::ReadMaterialJson(material_path);
  if (options.Has("normal-map"))
    glint::cli::AttachNormalMap(server, options.Required("normal-map"), request.mutable_material());
  if (options.Has("lights")) {
    for (auto &light : glint::client::ReadLightsJson(options.Required("lights"))) {
      *request.add_lights() = std::move(light);
    }
  }
  *request.mutable_queries() = glint::client::ReadQueriesCsv(queries_path);
  const uint32_t count = request.queries().count();
  if (count == 0) {
    std::fprintf(stderr, "glint: %s has a header but no queries\n", queries_path.c_str());
    return kExitFailure;
  }

  GlintClient client(server);
  std::vector<float> rgb;
  glint::client::EvaluateInfo info;
  const std::optional<double> seconds = EvaluateWithProgress(client, request, &rgb, &info, server);
  if (!seconds) return kExitFailure;

  switch (format) {
    case glint::client::OutputFormat::kCsv:
      glint::client::WriteRadianceCsv(out, rgb);
      break;
    case glint::client::OutputFormat::kNpy:
      glint::client::WriteRadianceNpy(out, rgb, count);
      break;
    case glint::client::OutputFormat::kExr: {
      const glint::client::RgbImage image = glint::client::QueriesToImage(rgb, width);
      glint::client::WriteExrRgb(out, image.width, image.height, image.rgb, options.Has("half"));
      break;
    }
    case glint::client::OutputFormat::kUnknown:
      break;  // rejected above
  }
  const double rate = *seconds > 0.0 ? static_cast<double>(count) / *seconds : 0.0;
  std::printf("glint eval: %u queries in %.3f s (%.0f queries/s) via %s -> %s\n", count, *seconds,
              rate, Transport(info).c_str(), out.c_str());
  return kExitOk;
}

bool ParseSize(const std::string &text, int *width, int *height) {
  const size_t x = text.find_first_of("xX");
  if (x == std::string::npos) return false;
  const std::string w = text.substr(0, x);
  const std::string h = text.substr(x + 1);
  auto parse = [](const std::string &s, int *v) {
    const char *end = s.data() + s.size();
    auto [ptr, ec] = std::from_chars(s.data(), end, *v);
    return !s.empty() && ec == std::errc() && ptr == end && *v > 0;
  };
  return parse(w, width) && parse(h, height);
}

int RunPreview(const Options &options) {
  const std::string server = options.Required("server");
  const std::string material_path = options.Required("material");
  const std::string lights_path = options.Required("lights");
  const std::string out = options.Required("out");
  if (glint::client::OutputFormatFromPath(out) != glint::client::OutputFormat::kExr) {
    throw UsageError{"--out " + out + ": preview writes an .exr (and a .png beside it)"};
  }
  glint::client::PreviewShape shape;
  const std::string scene_name = options.Get("scene", "sphere");
  if (!glint::client::ParsePreviewShape(scene_name, &shape)) {
    throw UsageError{"--scene: '" + scene_name + "' is neither sphere nor plane"};
  }
  int width = 0;
  int height = 0;
  const std::string size = options.Get("size", "512x512");
  if (!ParseSize(size, &width, &height)) {
    throw UsageError{"--size: '" + size + "' is not WIDTHxHEIGHT with positive integers"};
  }
  const auto exposure = ParseNumber<float>("exposure", options.Get("exposure", "0"));
  if (!std::isfinite(exposure)) throw UsageError{"--exposure must be finite"};

  glint::v1::EvaluateRequest request;
  FillSettings(options, &request);
  *request.mutable_material() = glint::client::ReadMaterialJson(material_path);
  if (options.Has("normal-map"))
    glint::cli::AttachNormalMap(server, options.Required("normal-map"), request.mutable_material());
  for (auto &light : glint::client::ReadLightsJson(lights_path)) {
    *request.add_lights() = std::move(light);
  }
  glint::client::PreviewQueries scene = glint::client::BuildPreviewQueries(shape, width, height);
  *request.mutable_queries() = scene.queries;

  GlintClient client(server);
  std::vector<float> rgb;
  glint::client::EvaluateInfo info;
  double seconds = 0.0;
  if (request.queries().count() > 0) {
    const std::optional<double> t = EvaluateWithProgress(client, request, &rgb, &info, server);
    if (!t) return kExitFailure;
    seconds = *t;
  }
  const std::vector<float> image = glint::client::ScatterToImage(scene, rgb);
  glint::client::WriteExrRgb(out, width, height, image, options.Has("half"));
  const std::string png = out.substr(0, out.size() - 4) + ".png";
  glint::client::WritePngToneMapped(png, width, height, image, exposure);
  std::printf("glint preview: %s %dx%d, %u queries in %.3f s via %s\n", scene_name.c_str(), width,
              height, request.queries().count(), seconds, Transport(info).c_str());
  std::printf("%s\n%s\n", out.c_str(), png.c_str());
  return kExitOk;
}

struct Command {
  const char *name;
  const char *usage;
  std::vector<std::string> with_value;
  std::vector<std::string> flags;
  int (*run)(const Options &);
};

}  // namespace

int main(int argc, char **argv) {
  const std::vector<Command> commands = {
      {"info", kInfoUsage, {"server", "timeout-ms"}, {}, RunInfo},
      {"eval",
       kEvalUsage,
       {"server", "material", "lights", "queries", "out", "precision", "seed", "width",
        "area-method", "samples", "normal-map"},
       {"half"},
       RunEval},
      {"preview",
       kPreviewUsage,
       {"server", "material", "lights", "out", "scene", "size", "exposure", "precision", "seed",
        "area-method", "samples", "normal-map"},
       {"half"},
       RunPreview},
  };
  if (argc < 2) {
    std::fputs(kUsage, stderr);
    return kExitUsage;
  }
  const std::string name = argv[1];
  if (name == "upload") return glint::cli::RunUpload(argc - 2, argv + 2);
  if (name == "normal-map") return glint::cli::RunNormalMap(argc - 2, argv + 2);
  if (name == "--help" || name == "-h" || name == "help") {
    std::fputs(kUsage, stdout);
    return kExitOk;
  }
  for (const Command &command : commands) {
    if (name != command.name) continue;
    try {
      const Options options(argc - 2, argv + 2, command.with_value, command.flags);
      if (options.help()) {
        std::fputs(command.usage, stdout);
        return kExitOk;
      }
      return command.run(options);
    } catch (const UsageError &e) {
      std::fprintf(stderr, "glint %s: %s\n\n%s", command.name, e.message.c_str(), command.usage);
      return kExitUsage;
    } catch (const std::exception &e) {
      std::fprintf(stderr, "glint: %s\n", e.what());
      return kExitFailure;
    }
  }
  std::fprintf(stderr, "glint: unknown command '%s'\n\n%s", name.c_str(), kUsage);
  return kExitUsage;
}
