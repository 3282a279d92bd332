// glint sample: importance sampling through the Sample RPC (proto glint.v1.SampleRequest).
// Reads a material and a CSV of queries, asks for K incident directions per query and writes
// OUT.csv with the header query,wix,wiy,wiz,pdf,r,g,b: K rows per query, in query order.
#include "client/cli/sample_command.h"

#include <grpcpp/grpcpp.h>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cstdio>
#include <exception>
#include <map>
#include <string>
#include <vector>

#include "client/cli/normal_map_commands.h"
#include "client/lib/glint_client.h"
#include "client/lib/query_io.h"

namespace glint::client {
namespace {

constexpr const char *kSampleUsage =
    R"(usage: glint sample --server ADDR --material M.json --queries Q.csv --samples K
                    --out OUT.csv [--seed N] [--precision fp32|fp64]

Importance-samples the material's BRDF: for each query of Q.csv, K incident directions wi with
their pdf (solid angle) and the weight f(wi, wo) cos_i / pdf (RGB). The mean weight over a
query's samples estimates its directional albedo. SMOOTH, KEMPPINEN, CHERMAIN and NORMAL_MAP
can be sampled; BINOMIAL is refused. Samples depend on (seed, the query's inputs, sample index) only.

  --server ADDR       gRPC target, e.g. 127.0.0.1:50051
  --material M.json   glint.v1.Material in proto3 JSON
  --queries Q.csv     as for 'glint eval' (u,v  dudx,dvdx,dudy,dvdy  wox,woy,woz  frame), no wi
  --samples K         samples per query, 1 to 65536
  --out OUT.csv       header query,wix,wiy,wiz,pdf,r,g,b; K rows per query in query order; a
                      sample without a direction is 0,0,0 with pdf 0 and weight 0
  --seed N            seed (default 0)
  --precision P       fp32 (default) or fp64
  --normal-map FILE   NORMAL_MAP materials: use FILE (EXR / PNG) as material.normal_map.digest,
                      uploading it when the server does not hold it
  --tls-ca, --tls-cert, --tls-key, --token-file   TLS and bearer token, as for every
                      command ('glint info --help')
)";

constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;
constexpr int kExitUsage = 2;

struct UsageError {
  std::string message;
};

std::map<std::string, std::string> ParseArgs(int argc, char **argv, bool *help) {
  const std::vector<std::string> known = {"server",   "material", "queries",    "samples",
                                          "out",      "seed",     "precision",  "tls-ca",
                                          "tls-cert", "tls-key",  "token-file", "normal-map"};
  std::map<std::string, std::string> values;
  for (int i = 0; i < argc; ++i) {
    std::string arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      *help = true;
      continue;
    }
    if (arg.rfind("--", 0) != 0) throw UsageError{"unexpected argument '" + arg + "'"};
    std::string name = arg.substr(2), value;
    const size_t eq = name.find('=');
    if (eq != std::string::npos) {
      value = name.substr(eq + 1);
      name = name.substr(0, eq);
    } else {
      if (i + 1 >= argc) throw UsageError{"--" + name + " needs a value"};
      value = argv[++i];
    }
    if (std::find(known.begin(), known.end(), name) == known.end())
      throw UsageError{"unknown option --" + name};
    values[name] = value;
  }
  return values;
}

template <class T>
T Number(const std::string &name, const std::string &text) {
  T v{};
  const char *end = text.data() + text.size();
  auto [ptr, ec] = std::from_chars(text.data(), end, v);
  if (text.empty() || ec != std::errc() || ptr != end)
    throw UsageError{"--" + name + ": '" + text + "' is not a valid number"};
  return v;
}

int Run(const std::map<std::string, std::string> &args) {
  auto required = [&](const std::string &name) {
    auto it = args.find(name);
    if (it == args.end()) throw UsageError{"--" + name + " is required"};
    return it->second;
  };
  const std::string server = required("server");
  const std::string out_path = required("out");
  const auto k = Number<uint32_t>("samples", required("samples"));
  if (k == 0 || k > 65536) throw UsageError{"--samples must be in [1, 65536]"};
  glint::v1::SampleRequest base;
  base.set_samples_per_query(k);
  base.set_seed(args.count("seed") ? Number<uint64_t>("seed", args.at("seed")) : 0);
  const std::string precision = args.count("precision") ? args.at("precision") : "fp32";
  if (precision != "fp32" && precision != "fp64")
    throw UsageError{"--precision must be fp32 or fp64"};
  base.set_precision(precision == "fp64" ? glint::v1::FP64 : glint::v1::FP32);
  *base.mutable_material() = ReadMaterialJson(required("material"));
  const std::string queries_path = required("queries");
  const glint::v1::QueryBatch queries = ReadQueriesCsv(queries_path);
  if (queries.count() == 0) {
    std::fprintf(stderr, "glint: %s has a header but no queries\n", queries_path.c_str());
    return kExitFailure;
  }

  // One channel for the capabilities (max_batch) and the Sample calls.
  ClientOptions options;
  auto get = [&](const std::string &name) { return args.count(name) ? args.at(name) : ""; };
  options.security = glint::client::LoadChannelSecurity(get("tls-ca"), get("tls-cert"),
                                                        get("tls-key"), get("token-file"));
  auto channel = glint::client::MakeChannel(server, options.max_message_bytes, options.security);
  GlintClient client(channel, options);
  if (args.count("normal-map"))
    glint::cli::AttachNormalMap(server, options, args.at("normal-map"), base.mutable_material());
  glint::v1::Capabilities caps;
  if (grpc::Status s = client.GetCapabilities(&caps); !s.ok()) {
    std::fprintf(stderr, "glint: GetCapabilities: %s\n", FormatStatus(s).c_str());
    return kExitFailure;
  }
  // Queries per call: count * K <= max_batch, and the request and the response within half the
  // server's and our message limit. Samples depend only on each query's own inputs, so the split
  // does not change them.
  const uint32_t per_call =
      SampleQueriesPerCall(caps, options.max_message_bytes, k, BytesPerQuery(queries),
                           base.ByteSizeLong(), queries.count());

  auto stub = glint::v1::GlintService::NewStub(channel);
  std::FILE *out = std::fopen(out_path.c_str(), "w");
  if (!out) {
    std::fprintf(stderr, "glint: %s: cannot open for writing\n", out_path.c_str());
    return kExitFailure;
  }
  std::fputs("query,wix,wiy,wiz,pdf,r,g,b\n", out);
  const auto start = std::chrono::steady_clock::now();
  uint64_t nonzero = 0;
  for (uint32_t first = 0; first < queries.count(); first += per_call) {
    const uint32_t n = std::min(per_call, queries.count() - first);
    glint::v1::SampleRequest request = base;
    *request.mutable_queries() = SliceQueries(queries, first, first + n);
    glint::v1::SampleResponse response;
    grpc::ClientContext ctx;
    client.PrepareContext(&ctx);  // the bearer token, when one is configured
    grpc::Status s = stub->Sample(&ctx, request, &response);
    if (!s.ok()) {
      std::fclose(out);
      std::fprintf(stderr, "glint: Sample (queries %u..%u): %s\n", first, first + n - 1,
                   FormatStatus(s).c_str());
      return kExitFailure;
    }
    for (uint32_t j = 0; j < n * k; ++j) {
      const int i = int(j);
      nonzero += response.pdf(i) > 0.0f;
      std::fprintf(out, "%u,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g\n", first + j / k,
                   response.wi(3 * i), response.wi(3 * i + 1), response.wi(3 * i + 2),
                   response.pdf(i), response.weight(3 * i), response.weight(3 * i + 1),
                   response.weight(3 * i + 2));
    }
  }
  if (std::fclose(out) != 0) {
    std::fprintf(stderr, "glint: %s: write failed\n", out_path.c_str());
    return kExitFailure;
  }
  const std::chrono::duration<double> t = std::chrono::steady_clock::now() - start;
  std::printf("glint sample: %u queries x %u samples (%llu with a direction) in %.3f s -> %s\n",
              queries.count(), k, static_cast<unsigned long long>(nonzero), t.count(),
              out_path.c_str());
  return kExitOk;
}

}  // namespace

int RunSampleCommand(int argc, char **argv) {
  try {
    bool help = false;
    const auto args = ParseArgs(argc, argv, &help);
    if (help) {
      std::fputs(kSampleUsage, stdout);
      return kExitOk;
    }
    return Run(args);
  } catch (const UsageError &e) {
    std::fprintf(stderr, "glint sample: %s\n\n%s", e.message.c_str(), kSampleUsage);
    return kExitUsage;
  } catch (const std::exception &e) {
    std::fprintf(stderr, "glint: %s\n", e.what());
    return kExitFailure;
  }
}

}  // namespace glint::client
