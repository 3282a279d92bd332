#include "client/lib/glint_client.h"

#include <grpc/grpc.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <utility>

#include "client/lib/chunk_encoding.h"
#include "client/lib/server_list.h"
#include "grpc/health/v1/health.grpc.pb.h"
#include "proto/wire/chunk_result.h"

namespace glint::client {
namespace {

using glint::v1::QueryBatch;

// gRPC's default receive limit, assumed when a server does not advertise its own.
constexpr uint64_t kGrpcDefaultMessageBytes = 4u << 20;
// Serialized bytes per query of the response: 3 packed floats.
constexpr size_t kResponseBytesPerQuery = 3 * sizeof(float);
// Room for message framing, tags, stats and the chunk envelope on top of the payload.
constexpr size_t kEnvelopeBytes = 4096;

// One SoA array of QueryBatch with its number of floats per query.
struct ArrayRef {
  const char *name;
  int components;
  const google::protobuf::RepeatedField<float> &(QueryBatch::*get)() const;
  google::protobuf::RepeatedField<float> *(QueryBatch::*mutable_get)();
};

// Every array of QueryBatch. A field added to the wire contract must be added here too, or
// streamed batches would silently drop it; the unit tests compare against the descriptor.
constexpr ArrayRef kArrays[] = {
    {"uv", 2, &QueryBatch::uv, &QueryBatch::mutable_uv},
    {"footprint", 4, &QueryBatch::footprint, &QueryBatch::mutable_footprint},
    {"wo", 3, &QueryBatch::wo, &QueryBatch::mutable_wo},
    {"wi", 3, &QueryBatch::wi, &QueryBatch::mutable_wi},
    {"position", 3, &QueryBatch::position, &QueryBatch::mutable_position},
    {"normal", 3, &QueryBatch::normal, &QueryBatch::mutable_normal},
    {"tangent", 3, &QueryBatch::tangent, &QueryBatch::mutable_tangent},
};

// Empty or components x count: the only shapes that can be sliced. Returns "" when fine.
std::string CheckShapes(const QueryBatch &batch) {
  for (const ArrayRef &a : kArrays) {
    const auto &field = (batch.*a.get)();
    const uint64_t expected = uint64_t{batch.count()} * static_cast<uint64_t>(a.components);
    if (!field.empty() && static_cast<uint64_t>(field.size()) != expected) {
      return "queries." + std::string(a.name) + " has " + std::to_string(field.size()) +
             " floats; expected 0 or " + std::to_string(a.components) +
             " x count = " + std::to_string(expected);
    }
  }
  return "";
}

}  // namespace

namespace {

std::string ReadWholeFile(const std::string &option, const std::string &path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(option + " " + path + ": cannot read the file");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string ReadPem(const std::string &option, const std::string &path) {
  std::string pem = ReadWholeFile(option, path);
  if (pem.find("-----BEGIN ") == std::string::npos) {
    throw std::runtime_error(option + " " + path + ": no PEM block (-----BEGIN ...) in the file");
  }
  return pem;
}

std::string Trim(const std::string &s) {
  const size_t b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return "";
  return s.substr(b, s.find_last_not_of(" \t\r\n") - b + 1);
}

}  // namespace

ChannelSecurity LoadChannelSecurity(const std::string &tls_ca_file,
                                    const std::string &tls_cert_file,
                                    const std::string &tls_key_file,
                                    const std::string &token_file) {
  ChannelSecurity s;
  if (tls_cert_file.empty() != tls_key_file.empty()) {
    throw std::runtime_error("--tls-cert and --tls-key go together");
  }
  s.tls = !tls_ca_file.empty() || !tls_cert_file.empty();
  if (!tls_ca_file.empty()) s.tls_ca_pem = ReadPem("--tls-ca", tls_ca_file);
  if (!tls_cert_file.empty()) {
    s.tls_cert_pem = ReadPem("--tls-cert", tls_cert_file);
    s.tls_key_pem = ReadPem("--tls-key", tls_key_file);
  }
  if (!token_file.empty()) {
    // The first non-blank line; the rest of the file is ignored.
    std::istringstream lines(ReadWholeFile("--token-file", token_file));
    for (std::string line; std::getline(lines, line) && s.token.empty();) s.token = Trim(line);
    if (s.token.empty()) throw std::runtime_error("--token-file " + token_file + ": no token");
  } else if (const char *env = std::getenv("GLINT_TOKEN")) {
    s.token = Trim(env);
  }
  return s;
}

std::shared_ptr<grpc::Channel> MakeChannel(const std::string &address, int max_message_bytes,
                                           const ChannelSecurity &security) {
  grpc::ChannelArguments args;
  // Replies may be kReplyOverheadBytes over the server's (= our) limit; int arithmetic clamped.
  args.SetMaxReceiveMessageSize(max_message_bytes >
                                        std::numeric_limits<int>::max() - kReplyOverheadBytes
                                    ? std::numeric_limits<int>::max()
                                    : max_message_bytes + kReplyOverheadBytes);
  args.SetMaxSendMessageSize(max_message_bytes);
  // gRPC backs off up to 120 s between connection attempts by default; an interactive tool that
  // waits for a starting server wants to notice it within a second or so.
  // Not GRPC_ARG_MIN_RECONNECT_BACKOFF_MS: despite its name, gRPC C-core takes it as the minimum
  // connect timeout (subchannel.cc, ParseArgsForBackoffValues: min_connect_timeout, 20 s by
  // default), so at 100 ms every connection attempt that took longer to connect and handshake
  // was shut down. On a loaded machine that failed calls to SERVING servers with "UNAVAILABLE:
  // failed to connect to all addresses; ... tcp handshaker shutdown" (glint eval, glint info,
  // GlintClient in cli_e2e, render_e2e, ops.security, nginx_failover, kserve.tritonclient, at
  // load ~19). A refused connection (a server not yet listening) still fails at once.
  args.SetInt(GRPC_ARG_INITIAL_RECONNECT_BACKOFF_MS, 100);
  args.SetInt(GRPC_ARG_MAX_RECONNECT_BACKOFF_MS, 1000);
  // A --server list: one subchannel per replica, each call to the next ready one.
  const ServerTarget target = ParseServerList(address);
  if (target.round_robin) args.SetLoadBalancingPolicyName("round_robin");
  std::shared_ptr<grpc::ChannelCredentials> credentials = grpc::InsecureChannelCredentials();
  if (security.tls) {
    grpc::SslCredentialsOptions ssl;
    ssl.pem_root_certs = security.tls_ca_pem;
    ssl.pem_cert_chain = security.tls_cert_pem;
    ssl.pem_private_key = security.tls_key_pem;
    credentials = grpc::SslCredentials(ssl);
  }
  return grpc::CreateCustomChannel(target.target, credentials, args);
}

QueryBatch SliceQueries(const QueryBatch &batch, uint32_t begin, uint32_t end) {
  if (begin > end || end > batch.count()) {
    throw std::out_of_range("SliceQueries: range [" + std::to_string(begin) + ", " +
                            std::to_string(end) + ") outside a batch of " +
                            std::to_string(batch.count()) + " queries");
  }
  if (std::string problem = CheckShapes(batch); !problem.empty()) {
    throw std::invalid_argument("SliceQueries: " + problem);
  }
  QueryBatch out;
  out.set_count(end - begin);
  for (const ArrayRef &a : kArrays) {
    const auto &src = (batch.*a.get)();
    if (src.empty()) continue;  // optional array absent: stays absent in every slice
    auto *dst = (out.*a.mutable_get)();
    const int first = static_cast<int>(begin) * a.components;
    const int n = static_cast<int>(end - begin) * a.components;
    dst->Reserve(n);
    dst->Add(src.begin() + first, src.begin() + first + n);
  }
  return out;
}

size_t BytesPerQuery(const QueryBatch &batch) {
  size_t bytes = 0;
  for (const ArrayRef &a : kArrays) {
    if (!(batch.*a.get)().empty()) bytes += static_cast<size_t>(a.components) * sizeof(float);
  }
  return bytes;
}

uint32_t SampleQueriesPerCall(const glint::v1::Capabilities &caps, int client_max_message_bytes,
                              uint32_t samples_per_query, size_t query_bytes, size_t settings_bytes,
                              uint32_t count) {
  const uint64_t k = std::max<uint32_t>(1, samples_per_query);
  uint64_t limit = caps.max_message_bytes() ? caps.max_message_bytes() : kGrpcDefaultMessageBytes;
  limit = std::min<uint64_t>(limit, uint64_t(std::max(client_max_message_bytes, 0)));
  // Half the limit, as Evaluate's messages (framing estimates never matter), less the fields
  // that do not grow with the queries.
  const uint64_t budget = limit / 2;
  const uint64_t overhead = settings_bytes + kEnvelopeBytes;
  const uint64_t room = budget > overhead ? budget - overhead : 0;
  // Per query: its arrays in the request, K samples of wi (3), pdf (1), weight (3) in the reply.
  const uint64_t per_query = std::max<uint64_t>({query_bytes, k * kSampleReplyBytesPerSample, 1});
  const uint64_t by_bytes = std::max<uint64_t>(1, room / per_query);
  const uint64_t by_batch =
      std::max<uint64_t>(1, (caps.max_batch() ? caps.max_batch() : UINT32_MAX) / k);
  return static_cast<uint32_t>(
      std::max<uint64_t>(1, std::min<uint64_t>({by_batch, by_bytes, uint64_t{count}})));
}

const char *StatusCodeName(grpc::StatusCode code) {
  switch (code) {
    case grpc::StatusCode::OK:
      return "OK";
    case grpc::StatusCode::CANCELLED:
      return "CANCELLED";
    case grpc::StatusCode::UNKNOWN:
      return "UNKNOWN";
    case grpc::StatusCode::INVALID_ARGUMENT:
      return "INVALID_ARGUMENT";
    case grpc::StatusCode::DEADLINE_EXCEEDED:
      return "DEADLINE_EXCEEDED";
    case grpc::StatusCode::NOT_FOUND:
      return "NOT_FOUND";
    case grpc::StatusCode::ALREADY_EXISTS:
      return "ALREADY_EXISTS";
    case grpc::StatusCode::PERMISSION_DENIED:
      return "PERMISSION_DENIED";
    case grpc::StatusCode::UNAUTHENTICATED:
      return "UNAUTHENTICATED";
    case grpc::StatusCode::RESOURCE_EXHAUSTED:
      return "RESOURCE_EXHAUSTED";
    case grpc::StatusCode::FAILED_PRECONDITION:
      return "FAILED_PRECONDITION";
    case grpc::StatusCode::ABORTED:
      return "ABORTED";
    case grpc::StatusCode::OUT_OF_RANGE:
      return "OUT_OF_RANGE";
    case grpc::StatusCode::UNIMPLEMENTED:
      return "UNIMPLEMENTED";
    case grpc::StatusCode::INTERNAL:
      return "INTERNAL";
    case grpc::StatusCode::UNAVAILABLE:
      return "UNAVAILABLE";
    case grpc::StatusCode::DATA_LOSS:
      return "DATA_LOSS";
    default:
      return "UNKNOWN_STATUS_CODE";
  }
}

std::string FormatStatus(const grpc::Status &status) {
  std::string out = StatusCodeName(status.error_code());
  if (!status.error_message().empty()) out += ": " + status.error_message();
  return out;
}

GlintClient::GlintClient(const std::string &address, ClientOptions options)
    : address_(address),
      options_(options),
      channel_(MakeChannel(address, options.max_message_bytes, options.security)),
      stub_(glint::v1::GlintService::NewStub(channel_)),
      servers_(ParseServerList(address).servers) {}

GlintClient::GlintClient(std::shared_ptr<grpc::Channel> channel, ClientOptions options)
    : address_("(channel)"),
      options_(options),
      channel_(std::move(channel)),
      stub_(glint::v1::GlintService::NewStub(channel_)) {}

void GlintClient::PrepareContext(grpc::ClientContext *context) const {
  // Sent as plain call metadata rather than call credentials: gRPC refuses to attach call
  // credentials to a plaintext channel, and a token on a loopback port is a valid setup.
  if (!options_.security.token.empty()) {
    context->AddMetadata("authorization", "Bearer " + options_.security.token);
  }
}

namespace {

// The steady-clock deadline of the retry loop and the system-clock one gRPC takes, for the
// same instant; max() stays max() (no deadline).
Clock::time_point SteadyDeadline(std::chrono::system_clock::time_point deadline) {
  if (deadline == std::chrono::system_clock::time_point::max()) return Clock::time_point::max();
  return Clock::now() +
         std::chrono::duration_cast<Clock::duration>(deadline - std::chrono::system_clock::now());
}

void SetDeadline(grpc::ClientContext *context, std::chrono::system_clock::time_point deadline) {
  if (deadline != std::chrono::system_clock::time_point::max()) context->set_deadline(deadline);
}

// The call's query count (a stream's total) and model as call metadata, so that glintd can
// refuse an over-limit or overloaded call before parsing (unary) or reading (stream) its body
// (server/metadata_admission.h, which names the same keys).
void AddAdmissionMetadata(const glint::v1::EvaluateRequest &request, grpc::ClientContext *context) {
  context->AddMetadata("glint-query-count", std::to_string(request.queries().count()));
  if (glint::v1::Model_IsValid(request.material().model()))
    context->AddMetadata("glint-model", glint::v1::Model_Name(request.material().model()));
}

}  // namespace

grpc::Status GlintClient::GetCapabilities(glint::v1::Capabilities *capabilities) {
  const auto deadline = std::chrono::system_clock::now() + options_.rpc_timeout;
  return CallWithRetries(options_.retry, SteadyDeadline(deadline),
                         [&](RetryHint *) { return FetchCapabilities(capabilities, deadline); });
}

grpc::Status GlintClient::FetchCapabilities(glint::v1::Capabilities *capabilities,
                                            std::chrono::system_clock::time_point deadline) {
  grpc::ClientContext context;
  PrepareContext(&context);
  SetDeadline(&context, deadline);
  glint::v1::Capabilities caps;
  grpc::Status status =
      stub_->GetCapabilities(&context, glint::v1::GetCapabilitiesRequest(), &caps);
  if (!status.ok()) return status;
  {
    std::lock_guard<std::mutex> lock(caps_mutex_);
    caps_ = caps;
  }
  if (capabilities != nullptr) *capabilities = std::move(caps);
  return grpc::Status::OK;
}

grpc::Status GlintClient::CachedCapabilities(glint::v1::Capabilities *capabilities,
                                             std::chrono::system_clock::time_point deadline) {
  {
    std::lock_guard<std::mutex> lock(caps_mutex_);
    if (caps_) {
      *capabilities = *caps_;
      return grpc::Status::OK;
    }
  }
  // Within Evaluate's deadline, or the cheap-RPC timeout when that is sooner.
  return FetchCapabilities(
      capabilities, std::min(deadline, std::chrono::system_clock::now() + options_.rpc_timeout));
}

bool GlintClient::WaitUntilServing(std::chrono::milliseconds timeout, std::string *why) {
  using grpc::health::v1::HealthCheckResponse;
  auto health = grpc::health::v1::Health::NewStub(channel_);
  const auto end = std::chrono::steady_clock::now() + timeout;
  static const std::string kNoCheck = "no health check attempted";
  std::string last = kNoCheck;
  for (;;) {
    const auto now = std::chrono::steady_clock::now();
    if (now >= end) break;
    grpc::ClientContext context;
    PrepareContext(&context);
    // Fail fast (no wait_for_ready): a refused connection then reports its real reason
    // instead of a bare DEADLINE_EXCEEDED, and the loop below does the waiting.
    context.set_deadline(
        std::chrono::system_clock::now() +
        std::min<std::chrono::steady_clock::duration>(end - now, std::chrono::seconds(1)));
    grpc::health::v1::HealthCheckRequest request;
    request.set_service("");  // the server as a whole
    HealthCheckResponse response;
    grpc::Status status = health->Check(&context, request, &response);
    if (status.ok()) {
      if (response.status() == HealthCheckResponse::SERVING) return true;
      last = "health status " + HealthCheckResponse::ServingStatus_Name(response.status());
    } else if (status.error_code() == grpc::StatusCode::UNIMPLEMENTED) {
      // Retrying cannot help: the server has no grpc.health.v1 service at all.
      if (why)
        *why = "server does not implement grpc.health.v1.Health (" + FormatStatus(status) + ")";
      return false;
    } else if (status.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED && last != kNoCheck &&
               std::chrono::steady_clock::now() >= end) {
      // A check cut short by this wait's own end (its deadline is at most what was left, a few
      // ms on the last round of a loaded machine): the earlier answer says more than a bare
      // DEADLINE_EXCEEDED would.
    } else {
      last = FormatStatus(status);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  if (why) *why = "not SERVING after " + std::to_string(timeout.count()) + " ms: " + last;
  return false;
}

grpc::Status GlintClient::Evaluate(const glint::v1::EvaluateRequest &request,
                                   std::vector<float> *radiance, ProgressFn progress,
                                   EvaluateInfo *info) {
  if (radiance == nullptr) {
    return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, "Evaluate: radiance is null");
  }
  EvaluateInfo local_info;
  if (info == nullptr) info = &local_info;
  const auto deadline = options_.evaluate_timeout.count() > 0
                            ? std::chrono::system_clock::now() + options_.evaluate_timeout
                            : std::chrono::system_clock::time_point::max();
  int attempts = 0;
  grpc::Status status = CallWithRetries(
      options_.retry, SteadyDeadline(deadline),
      [&](RetryHint *hint) {
        *info = EvaluateInfo();
        return EvaluateOnce(request, radiance, progress, info, deadline, hint);
      },
      &attempts);
  info->attempts = attempts;
  return status;
}

grpc::Status GlintClient::EvaluateOnce(const glint::v1::EvaluateRequest &request,
                                       std::vector<float> *radiance, const ProgressFn &progress,
                                       EvaluateInfo *info,
                                       std::chrono::system_clock::time_point deadline,
                                       RetryHint *hint) {
  glint::v1::Capabilities caps;
  if (grpc::Status status = CachedCapabilities(&caps, deadline); !status.ok()) return status;

  // The smaller of the server's and our own message limit, and of the server's batch limit and
  // our optional chunk cap. 0 from the server means "not reported".
  uint64_t message_limit =
      caps.max_message_bytes() ? caps.max_message_bytes() : kGrpcDefaultMessageBytes;
  message_limit =
      std::min<uint64_t>(message_limit, static_cast<uint64_t>(options_.max_message_bytes));
  uint32_t max_batch = caps.max_batch() ? caps.max_batch() : UINT32_MAX;
  if (options_.max_chunk_queries) max_batch = std::min(max_batch, options_.max_chunk_queries);
  // One message, unary or chunk, stays "comfortably below" the limit (half of it, so framing
  // estimates never matter) and under max_chunk_bytes (a few MiB: progress, memory, latency).
  const uint64_t budget = std::min<uint64_t>(message_limit / 2, options_.max_chunk_bytes);

  const QueryBatch &queries = request.queries();
  const uint32_t count = queries.count();
  const uint64_t request_bytes = request.ByteSizeLong();
  const uint64_t response_bytes = uint64_t{count} * kResponseBytesPerQuery + kEnvelopeBytes;
  // A server list spreads a batch of at least kSpreadMinQueries per server over them.
  constexpr uint32_t kSpreadMinQueries = 4096;
  const bool spread = servers_ > 1 && count >= kSpreadMinQueries * servers_;
  if (!spread && count <= max_batch && request_bytes <= budget && response_bytes <= budget) {
    grpc::Status status = EvaluateUnary(request, radiance, info, deadline, hint);
    if (status.ok() && progress) progress(count, count);
    return status;
  }

  // Stream: the shape check is ours here because slicing a malformed array would mis-assign
  // values to queries; the server reports everything else.
  if (std::string problem = CheckShapes(queries); !problem.empty()) {
    return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, problem);
  }
  // The first chunk also carries the settings; sizing every chunk for them keeps one rule.
  size_t settings_bytes = request.material().ByteSizeLong();
  for (const auto &light : request.lights()) settings_bytes += light.ByteSizeLong() + 8;
  const auto chunk_budget_total = static_cast<size_t>(budget);
  const size_t overhead = settings_bytes + kEnvelopeBytes;
  if (chunk_budget_total <= overhead) {
    return grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                        "material and lights alone (" + std::to_string(settings_bytes) +
                            " bytes) exceed the chunk size budget of " +
                            std::to_string(chunk_budget_total) + " bytes");
  }
  const size_t per_query = std::max(BytesPerQuery(queries), kResponseBytesPerQuery);
  const uint64_t by_bytes = std::max<uint64_t>(1, (chunk_budget_total - overhead) / per_query);
  auto chunk_queries = static_cast<uint32_t>(std::min<uint64_t>(by_bytes, max_batch));
  if (spread) {
    // At least two chunks per server, so a faster one can take more of them.
    const uint64_t even = (uint64_t{count} + 2 * servers_ - 1) / (2 * servers_);
    chunk_queries = static_cast<uint32_t>(
        std::max<uint64_t>(kSpreadMinQueries / 2, std::min<uint64_t>(chunk_queries, even)));
    return EvaluateSpread(request, chunk_queries, radiance, progress, info, deadline);
  }
  return EvaluateStreamed(request, chunk_queries, radiance, progress, info, deadline, hint);
}

grpc::Status GlintClient::EvaluateUnary(const glint::v1::EvaluateRequest &request,
                                        std::vector<float> *radiance, EvaluateInfo *info,
                                        std::chrono::system_clock::time_point deadline,
                                        RetryHint *hint) {
  grpc::ClientContext context;
  PrepareContext(&context);
  SetDeadline(&context, deadline);
  AddAdmissionMetadata(request, &context);
  glint::v1::EvaluateResponse response;
  grpc::Status status = stub_->Evaluate(&context, request, &response);
  if (!status.ok()) {
    hint->ReadFrom(context);
    return status;
  }
  const uint64_t expected = uint64_t{request.queries().count()} * 3;
  if (static_cast<uint64_t>(response.radiance_size()) != expected) {
    return grpc::Status(grpc::StatusCode::INTERNAL,
                        "server returned " + std::to_string(response.radiance_size()) +
                            " radiance floats for " + std::to_string(request.queries().count()) +
                            " queries");
  }
  radiance->assign(response.radiance().begin(), response.radiance().end());
  info->streamed = false;
  info->chunks = 1;
  info->chunk_queries = request.queries().count();
  info->device = response.stats().device();
  return grpc::Status::OK;
}

grpc::Status GlintClient::EvaluateSpread(const glint::v1::EvaluateRequest &request,
                                         uint32_t chunk_queries, std::vector<float> *radiance,
                                         const ProgressFn &progress, EvaluateInfo *info,
                                         std::chrono::system_clock::time_point deadline) {
  const uint32_t count = request.queries().count();
  const uint64_t chunks = (uint64_t{count} + chunk_queries - 1) / chunk_queries;
  info->streamed = false;
  info->chunks = chunks;
  info->chunk_queries = chunk_queries;
  info->servers = servers_;
  // Every chunk is a whole request: the settings, then its slice of the queries.
  glint::v1::EvaluateRequest settings;
  *settings.mutable_material() = request.material();
  *settings.mutable_lights() = request.lights();
  settings.set_precision(request.precision());
  settings.set_seed(request.seed());
  settings.set_area_method(request.area_method());
  settings.set_area_samples(request.area_samples());

  std::vector<float> out(uint64_t{count} * 3);
  std::mutex mutex;
  std::condition_variable changed;
  uint64_t next = 0, finished = 0, done_queries = 0;
  int running = 0;
  grpc::Status failure;
  std::string device;
  // Two calls in flight per server: one computing while the next one's bytes travel.
  const int threads = static_cast<int>(std::min<uint64_t>(chunks, 2 * servers_));
  auto work = [&] {
    for (;;) {
      uint64_t k = 0;
      {
        std::lock_guard<std::mutex> lock(mutex);
        if (!failure.ok() || next >= chunks) break;
        k = next++;
      }
      const auto begin = static_cast<uint32_t>(k * chunk_queries);
      const auto end =
          static_cast<uint32_t>(std::min<uint64_t>(uint64_t{begin} + chunk_queries, count));
      glint::v1::EvaluateRequest part = settings;
      grpc::Status status;
      try {
        *part.mutable_queries() = SliceQueries(request.queries(), begin, end);
      } catch (const std::exception &e) {
        status = grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, e.what());
      }
      glint::v1::EvaluateResponse response;
      // Each chunk retried on its own: a replica that goes away costs only its chunks, which
      // round_robin then sends to the others.
      if (status.ok())
        status = CallWithRetries(options_.retry, SteadyDeadline(deadline), [&](RetryHint *hint) {
          grpc::ClientContext context;
          PrepareContext(&context);
          SetDeadline(&context, deadline);
          response.Clear();
          const grpc::Status s = stub_->Evaluate(&context, part, &response);
          if (!s.ok()) hint->ReadFrom(context);
          return s;
        });
      if (status.ok() &&
          static_cast<uint64_t>(response.radiance_size()) != uint64_t{end - begin} * 3)
        status = grpc::Status(grpc::StatusCode::INTERNAL,
                              "server returned " + std::to_string(response.radiance_size()) +
                                  " radiance floats for the " + std::to_string(end - begin) +
                                  " queries of chunk " + std::to_string(k));
      if (status.ok())
        std::copy(response.radiance().begin(), response.radiance().end(),
                  out.begin() + static_cast<std::ptrdiff_t>(uint64_t{begin} * 3));
      std::lock_guard<std::mutex> lock(mutex);
      if (!status.ok()) {
        if (failure.ok()) failure = status;
      } else {
        ++finished;
        done_queries += end - begin;
        if (device.empty()) device = response.stats().device();
      }
      changed.notify_all();
    }
    std::lock_guard<std::mutex> lock(mutex);
    --running;
    changed.notify_all();
  };
  std::vector<std::thread> pool;
  running = threads;
  for (int t = 0; t < threads; ++t) pool.emplace_back(work);
  // Progress on the calling thread, as results arrive.
  {
    std::unique_lock<std::mutex> lock(mutex);
    uint64_t reported = 0;
    while (running > 0) {
      changed.wait(lock);
      if (progress && done_queries != reported) {
        reported = done_queries;
        lock.unlock();
        progress(reported, count);
        lock.lock();
      }
    }
  }
  for (std::thread &t : pool) t.join();
  if (!failure.ok()) return failure;
  if (finished != chunks) {
    return grpc::Status(
        grpc::StatusCode::DATA_LOSS,
        std::to_string(finished) + " of " + std::to_string(chunks) + " chunks answered");
  }
  info->device = device;
  *radiance = std::move(out);
  return grpc::Status::OK;
}

// The first stream chunk's settings: every field of `request` but its queries, without copying
// the queries. The fields are copied one by one; a field this list does not know yet (one added
// to the proto later) makes it fall back to a whole copy with the queries cleared, so no setting
// is ever dropped from a streamed request (it happened once to area_method).
static std::string StreamSettings(const glint::v1::EvaluateRequest &request) {
  using R = glint::v1::EvaluateRequest;
  static const std::set<int> kCopied = {
      R::kMaterialFieldNumber,    R::kLightsFieldNumber,
      R::kQueriesFieldNumber,     R::kPrecisionFieldNumber,
      R::kSeedFieldNumber,        R::kAreaMethodFieldNumber,
      R::kAreaSamplesFieldNumber, R::kMaxRelativeErrorFieldNumber};
  std::vector<const google::protobuf::FieldDescriptor *> present;
  request.GetReflection()->ListFields(request, &present);
  for (const auto *field : present) {
    if (kCopied.count(field->number()) == 0) {
      R whole = request;
      whole.clear_queries();
      return whole.SerializeAsString();
    }
  }
  R first;
  *first.mutable_material() = request.material();
  *first.mutable_lights() = request.lights();
  first.set_precision(request.precision());
  first.set_seed(request.seed());
  first.set_area_method(request.area_method());
  first.set_area_samples(request.area_samples());
  first.set_max_relative_error(request.max_relative_error());
  return first.SerializeAsString();
}

grpc::Status GlintClient::EvaluateStreamed(const glint::v1::EvaluateRequest &request,
                                           uint32_t chunk_queries, std::vector<float> *radiance,
                                           const ProgressFn &progress, EvaluateInfo *info,
                                           std::chrono::system_clock::time_point deadline,
                                           RetryHint *hint) {
  const uint32_t count = request.queries().count();
  const uint64_t chunks = (uint64_t{count} + chunk_queries - 1) / chunk_queries;
  info->streamed = true;
  info->chunks = chunks;
  info->chunk_queries = chunk_queries;

  // Results are decoded into an array kept from the previous call (its pages already mapped) and
  // swapped into `radiance` on success; `radiance` is untouched on failure.
  std::vector<float> out;
  {
    std::lock_guard<std::mutex> lock(output_mutex_);
    out.swap(spare_output_);
  }
  out.resize(uint64_t{count} * 3);
  auto keep_spare = [&] {
    std::lock_guard<std::mutex> lock(output_mutex_);
    if (out.capacity() > spare_output_.capacity()) spare_output_.swap(out);
  };
  grpc::ClientContext context;
  PrepareContext(&context);
  SetDeadline(&context, deadline);
  AddAdmissionMetadata(request, &context);
  // Chunks reference the request's arrays in place (client/lib/chunk_encoding.h: no copy of the
  // queries before the socket's own).
  std::unique_ptr<RawChunkStream> stream = OpenRawChunkStream(channel_.get(), &context);
  const std::string settings = StreamSettings(request);

  // Writer and reader run concurrently: with both sides' HTTP/2 windows full, a client that only
  // reads after writing everything would wait for a server that waits for it. Chunks are built
  // lazily so only a few slices exist at once.
  std::atomic<bool> writer_failed{false};
  std::string writer_error;
  std::thread writer([&] {
    try {
      static const std::string kNoSettings;
      for (uint64_t k = 0; k < chunks; ++k) {
        const auto begin = static_cast<uint32_t>(k * chunk_queries);
        const auto end =
            static_cast<uint32_t>(std::min<uint64_t>(uint64_t{begin} + chunk_queries, count));
        // The first chunk carries every setting; the others only queries.
        // The chunk's slices reference `request`'s rows, alive until after Finish() below.
        const grpc::ByteBuffer chunk = EncodeChunkReferencing(k, k == 0 ? settings : kNoSettings,
                                                              request.queries(), begin, end);
        // false: the call is over (server error or our own cancel); Finish says why.
        if (!stream->Write(chunk)) return;
      }
      stream->WritesDone();
    } catch (const std::exception &e) {
      writer_error = e.what();
      writer_failed = true;
      context.TryCancel();
    }
  });

  grpc::Status protocol_error;
  uint64_t received = 0;
  uint64_t done = 0;
  grpc::ByteBuffer raw;
  while (stream->Read(&raw)) {
    const uint64_t first = received * chunk_queries;
    const uint64_t n = std::min<uint64_t>(chunk_queries, count - std::min<uint64_t>(first, count));
    // Decoded straight into this chunk's rows (glint::wire::DecodeChunkResult: one copy).
    glint::wire::DecodedChunkResult result;
    std::string problem = glint::wire::DecodeChunkResult(
        &raw, out.data() + std::min<uint64_t>(first, count) * 3, n * 3, &result);
    if (problem.empty())
      problem = ChunkResultProblem(result.chunk_index, result.first_query, result.radiance_floats,
                                   received, chunks, first, n);
    if (!problem.empty()) {
      protocol_error = grpc::Status(grpc::StatusCode::INTERNAL, problem);
      context.TryCancel();
      break;
    }
    if (info->device.empty()) info->device = result.stats.device();
    ++received;
    done += n;
    if (progress) progress(done, count);
  }
  if (!protocol_error.ok()) {
    // Drain so that Finish does not wait on unread messages of a call we cancelled.
    while (stream->Read(&raw)) {
    }
  }
  writer.join();
  grpc::Status status = stream->Finish();
  if (!status.ok()) hint->ReadFrom(context);
  if (status.ok() && received != chunks) {
    status = grpc::Status(grpc::StatusCode::DATA_LOSS,
                          "stream ended after " + std::to_string(received) + " of " +
                              std::to_string(chunks) + " chunk results");
  }
  if (writer_failed) status = grpc::Status(grpc::StatusCode::INTERNAL, writer_error);
  if (!protocol_error.ok() && !writer_failed) status = protocol_error;
  if (status.ok()) radiance->swap(out);  // the caller's old array becomes the next call's spare
  keep_spare();
  return status;
}

std::string ChunkResultProblem(const glint::v1::EvaluateChunkResult &result, uint64_t received,
                               uint64_t chunks, uint64_t first, uint64_t n) {
  return ChunkResultProblem(result.chunk_index(), result.first_query(),
                            static_cast<uint64_t>(result.result().radiance_size()), received,
                            chunks, first, n);
}

std::string ChunkResultProblem(uint64_t chunk_index, uint64_t first_query, uint64_t radiance_floats,
                               uint64_t received, uint64_t chunks, uint64_t first, uint64_t n) {
  if (received >= chunks) {
    return "server sent a result for chunk " + std::to_string(chunk_index) + " after all " +
           std::to_string(chunks) + " chunks were answered";
  }
  if (chunk_index != received) {
    return "server answered chunk " + std::to_string(chunk_index) + " where chunk " +
           std::to_string(received) + " was expected";
  }
  if (first_query != first) {
    return "chunk " + std::to_string(received) + " reports first_query " +
           std::to_string(first_query) + ", expected " + std::to_string(first);
  }
  if (radiance_floats != n * 3) {
    return "chunk " + std::to_string(received) + " carries " + std::to_string(radiance_floats) +
           " radiance floats for " + std::to_string(n) + " queries";
  }
  return "";
}

}  // namespace glint::client
