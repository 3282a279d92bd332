// glint: command-line client of glintd. Commands: info, eval, preview, render, load (see kUsage
// below). Exit codes: 0 success, 1 failure at run time (server, files), 2 wrong command line.
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

#include "client/cli/cli_common.h"
#include "client/cli/load.h"
#include "client/cli/normal_map_commands.h"
#include "client/cli/preview_command.h"
#include "client/cli/render_command.h"
#include "client/cli/sample_command.h"
#include "client/lib/glint_client.h"
#include "client/lib/query_io.h"
#include "client/lib/rate_format.h"
#include "client/preview/image_io.h"
#include "client/preview/preview_scene.h"

namespace {

using glint::client::GlintClient;
using namespace glint::cli;  // Options, UsageError, exit codes, settings, progress (cli_common.h)

constexpr const char *kUsage =
    R"(glint: command-line client of glintd, the glint BRDF evaluation service

usage: glint <command> [options]

commands:
  info      print the server's capabilities; exit 0 only when it reports SERVING
  eval      evaluate a CSV of shading queries; write radiance as CSV, NPY or EXR
  preview   render a sphere or plane preview of a material under lights (EXR + PNG), or a
            batch of materials with a contact sheet
  render    shade a renderer's G-buffer EXR (P, N, uv, ...) with a material: beauty EXR
  load      load-test a server: throughput and latency percentiles per concurrency level
  sample    importance-sample a material's BRDF: K directions, pdf and weight per query (CSV)
  upload    upload a normal map (EXR / PNG) and print its digest
  normal-map  generate a normal map: bumpy, flakes, brushed or scratches
  normal-maps list or delete the normal maps a server holds

Run 'glint <command> --help' for the options of a command.
)";

constexpr const char *kInfoUsage = R"(usage: glint info --server ADDR [--timeout-ms MS]

Waits until the server's grpc.health.v1 status is SERVING (at most --timeout-ms, default 5000),
then prints its capabilities (device, limits, supported models). Exits 1 and says why when the
server is unreachable or not SERVING in time.

  --server ADDR     gRPC target, e.g. 127.0.0.1:50051 or dns:///glint:50051, or a list a:1,b:2
  --timeout-ms MS   how long to wait for SERVING (default 5000)
)";

constexpr const char *kEvalUsage =
    R"(usage: glint eval --server ADDR --material M.json [--lights L.json] --queries Q.csv
                  --out OUT.{csv,npy,exr} [--precision fp32|fp64] [--seed N] [--width W] [--half]
                  [--area-method ltc|reference|lecocq|lecocq-pearson|mc|auto] [--samples N]
                  [--max-error E] [--transport auto|tcp|shm]

Evaluates every query of Q.csv and writes the reflected radiance (RGB per query, in input
order). Batches larger than the server's limits are streamed in chunks automatically.

  --server ADDR       gRPC target, e.g. 127.0.0.1:50051, or replicas a:1,b:2 (chunks round robin)
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
                      peak fits), mc (Monte Carlo, seeded), reference (quadrature) or
                      auto (the cheapest meeting --max-error)
  --samples N         reference: quadrature nodes per dimension per triangle; mc: samples
                      per query and light (default 64)
  --max-error E       --area-method auto: the relative error allowed per query and light
                      (e.g. 0.05); the server picks the cheapest method predicted to meet it
  --width W           .exr only: image width; rows follow query order, the tail is black
                      (default: all queries in one row)
  --half              .exr only: store half floats instead of float32
  --normal-map FILE   NORMAL_MAP model: use FILE (EXR / PNG) as material.normal_map.digest,
                      uploading it when the server does not hold it
  --transport T       tcp: query and radiance arrays over the connection; shm: through a
                      POSIX shared-memory region the server maps (same host only); auto
                      (default): shm when --server is loopback or unix: and the server
                      accepts the region, else tcp

A progress bar is drawn on stderr when it is a terminal; a one-line summary goes to stdout.
)";

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
  GlintClient client(server, ConnectionOptions(options));
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
  // Admission and scheduling (glintd --max-request-cost, --max-query-cost, --slice-ms,
  // --batch-max-queries, --batch-delay-us, --max-shm-regions, --max-shm-mb): what decides
  // whether a request is refused, how soon a cancel acts, and what a same-host client may map.
  if (caps.max_request_cost() > 0 || caps.max_query_cost() > 0)
    std::printf(
        "cost limits      %g per request, %g per query (smooth-BRDF evaluations; "
        "beyond: RESOURCE_EXHAUSTED)\n",
        caps.max_request_cost(), caps.max_query_cost());
  if (caps.slice_ms() > 0)
    std::printf("query slices     %g ms (cancellation, deadlines and shutdown act between them)\n",
                caps.slice_ms());
  if (caps.batch_max_queries() > 0)
    std::printf("batching         up to %u queries per launch, delay %u us\n",
                caps.batch_max_queries(), caps.batch_delay_us());
  else
    std::printf("batching         off\n");
  if (caps.max_shared_memory_regions() > 0)
    std::printf("shared memory    %u regions, %s per owner\n", caps.max_shared_memory_regions(),
                Bytes(caps.max_shared_memory_bytes()).c_str());
  else
    std::printf("shared memory    off\n");
  return kExitOk;
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
    glint::cli::AttachNormalMap(server, ConnectionOptions(options), options.Required("normal-map"),
                                request.mutable_material());
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

  GlintClient client(server, ConnectionOptions(options));
  std::vector<float> rgb;
  glint::client::EvaluateInfo info;
  glint::client::Transport transport;
  try {
    transport = glint::client::ParseTransport(options.Get("transport", "auto"));
  } catch (const std::invalid_argument &e) {
    throw UsageError{e.what()};
  }
  std::string used;
  const std::optional<double> seconds =
      EvaluateWithProgress(client, request, &rgb, &info, server, transport, &used);
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
  std::printf("glint eval: %u queries in %.3f s (%s queries/s) via %s -> %s\n", count, *seconds,
              glint::client::FormatRate(count, *seconds).c_str(),
              used == "shm" ? ("shared memory (" + std::to_string(info.chunks) +
                               " calls of <= " + std::to_string(info.chunk_queries) + " queries)")
                                  .c_str()
                            : Transport(info).c_str(),
              out.c_str());
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
        "area-method", "samples", "normal-map", "transport", "max-error"},
       {"half"},
       RunEval},
      {"preview", kPreviewUsage, kPreviewOptions, {"half"}, RunPreview},
      {"render", kRenderUsage, kRenderOptions, {"half", "png"}, RunRender},
  };
  if (argc < 2) {
    std::fputs(kUsage, stderr);
    return kExitUsage;
  }
  const std::string name = argv[1];
  if (name == "load") return glint::cli::RunLoad(argc - 2, argv + 2);
  if (name == "upload") return glint::cli::RunUpload(argc - 2, argv + 2);
  if (name == "normal-map") return glint::cli::RunNormalMap(argc - 2, argv + 2);
  if (name == "normal-maps") return glint::cli::RunNormalMaps(argc - 2, argv + 2);
  if (name == "sample") return glint::client::RunSampleCommand(argc - 2, argv + 2);
  if (name == "--help" || name == "-h" || name == "help") {
    std::fputs(kUsage, stdout);
    return kExitOk;
  }
  for (const Command &command : commands) {
    if (name != command.name) continue;
    try {
      std::vector<std::string> with_value = command.with_value;
      with_value.insert(with_value.end(), kConnectionOptions.begin(), kConnectionOptions.end());
      const Options options(argc - 2, argv + 2, with_value, command.flags);
      if (options.help()) {
        std::fputs(command.usage, stdout);
        std::fputs(kConnectionUsage, stdout);
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
