#include "server/ops.h"

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <utility>

#include "server/bounded_status_message.h"
#include "server/device_engine.h"
#include "server/metrics_interceptor.h"
#include "server/scheduler.h"
#include "server/unparsed_body_interceptor.h"

namespace glint {

const char kOpsUsage[] =
    "  --metrics-listen ADDR  serve Prometheus metrics at http://ADDR/metrics (HOST:PORT)\n"
    "  --tls-cert PEM       serve TLS with this certificate chain (needs --tls-key)\n"
    "  --tls-key PEM        the certificate's private key\n"
    "  --tls-client-ca PEM  mutual TLS: require client certificates signed by these roots\n"
    "  --auth-tokens FILE   require 'authorization: Bearer <token>' on every RPC except\n"
    "                       health, tokens one per line; re-read on SIGHUP; disables reflection\n";

bool ParseOpsFlag(int argc, char **argv, int *i, OpsFlags *flags) {
  const std::string a = argv[*i];
  std::string *target = nullptr;
  if (a == "--metrics-listen") target = &flags->metrics_listen;
  if (a == "--tls-cert") target = &flags->tls_cert;
  if (a == "--tls-key") target = &flags->tls_key;
  if (a == "--tls-client-ca") target = &flags->tls_client_ca;
  if (a == "--auth-tokens") target = &flags->auth_tokens;
  if (target == nullptr) return false;
  if (*i + 1 >= argc) {
    std::fprintf(stderr, "glintd: %s needs a value\n", a.c_str());
    std::exit(2);
  }
  *target = argv[++*i];
  return true;
}

Ops::Ops(OpsFlags flags) : flags_(std::move(flags)) {
  if (!flags_.metrics_listen.empty()) metrics_ = std::make_unique<Metrics>();
}

Ops::~Ops() = default;

namespace {

bool ReadPem(const char *flag, const std::string &path, std::string *out, std::string *error) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  if (in) text << in.rdbuf();
  *out = text.str();
  if (!in || out->find("-----BEGIN ") == std::string::npos) {
    *error = std::string(flag) + " " + path + ": " +
             (in ? "no PEM block (-----BEGIN ...) in the file" : "cannot read the file");
    return false;
  }
  return true;
}

bool IsLoopback(const std::string &listen) {
  if (listen.rfind("unix:", 0) == 0 || listen.rfind("unix-abstract:", 0) == 0) return true;
  std::string host = listen.substr(0, listen.rfind(':'));
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') {
    host = host.substr(1, host.size() - 2);
  }
  return host.rfind("127.", 0) == 0 || host == "::1" || host == "localhost";
}

}  // namespace

std::vector<std::string> ExposureWarnings(const std::string &listen, bool tls,
                                          bool client_certificates, bool tokens) {
  std::vector<std::string> out;
  if (IsLoopback(listen)) return out;
  if (!tls && !tokens) {
    out.push_back("listening on " + listen +
                  " beyond loopback without TLS or tokens: anyone who can reach the port can "
                  "use the service and read its traffic (--tls-cert/--tls-key, --auth-tokens)");
  } else if (!tls) {
    out.push_back("listening on " + listen +
                  " beyond loopback without TLS: bearer tokens and data cross the network in "
                  "clear text (--tls-cert/--tls-key)");
  } else if (!tokens && !client_certificates) {
    out.push_back("listening on " + listen +
                  " with TLS but neither tokens nor client certificates: any client that "
                  "reaches the port can use the service (--auth-tokens or --tls-client-ca)");
  }
  return out;
}

bool Ops::Init(std::string *error) {
  const OpsFlags &f = flags_;
  if (f.tls_cert.empty() != f.tls_key.empty()) {
    *error = "--tls-cert and --tls-key go together";
    return false;
  }
  if (!f.tls_client_ca.empty() && f.tls_cert.empty()) {
    *error = "--tls-client-ca needs --tls-cert and --tls-key (mutual TLS is TLS first)";
    return false;
  }
  if (!f.tls_cert.empty() && (!ReadPem("--tls-cert", f.tls_cert, &cert_pem_, error) ||
                              !ReadPem("--tls-key", f.tls_key, &key_pem_, error))) {
    return false;
  }
  if (!f.tls_client_ca.empty() &&
      !ReadPem("--tls-client-ca", f.tls_client_ca, &client_ca_pem_, error)) {
    return false;
  }
  if (!f.auth_tokens.empty()) {
    auth_ = TokenAuth::Load(f.auth_tokens, error);
    if (!auth_) return false;
    auth_->ReloadOnSighup();
    std::fprintf(stderr, "glintd: %zu tokens loaded from %s (SIGHUP re-reads it)\n", auth_->size(),
                 f.auth_tokens.c_str());
  }
  return true;
}

std::shared_ptr<grpc::ServerCredentials> Ops::ServerCredentials() const {
  if (cert_pem_.empty()) return grpc::InsecureServerCredentials();
  grpc::SslServerCredentialsOptions options(
      client_ca_pem_.empty() ? GRPC_SSL_DONT_REQUEST_CLIENT_CERTIFICATE
                             : GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY);
  options.pem_root_certs = client_ca_pem_;
  options.pem_key_cert_pairs.push_back({key_pem_, cert_pem_});
  return grpc::SslServerCredentials(options);
}

void Ops::WarnIfExposed(const std::string &listen) const {
  for (const std::string &w :
       ExposureWarnings(listen, !cert_pem_.empty(), !client_ca_pem_.empty(), auth_ != nullptr)) {
    std::fprintf(stderr, "glintd: WARNING: %s\n", w.c_str());
  }
}

void Ops::Configure(grpc::ServerBuilder *builder, const Scheduler *scheduler,
                    DeviceEngine *engine) {
  std::vector<std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>> creators;
  // First, so that the metrics interceptor after it counts the status the client gets.
  creators.push_back(std::make_unique<UnparsedBodyInterceptorFactory>(auth_.get()));
  creators.push_back(std::make_unique<BoundedStatusMessageInterceptorFactory>());
  if (metrics_) creators.push_back(std::make_unique<MetricsInterceptorFactory>(metrics_.get()));
  builder->experimental().SetInterceptorCreators(std::move(creators));
  if (!metrics_) return;
  metrics_->SetQueueDepthSource([scheduler] { return double(scheduler->pending()); },
                                double(scheduler->max_pending()));
  if (engine) {
    metrics_->SetProgramCacheSource([engine] {
      const ClRuntime &r = engine->runtime();
      ProgramCacheCounts c;
      c.memory_hits = uint64_t(r.programs_memory_hits());
      c.disk_hits = uint64_t(r.programs_loaded_from_disk());
      c.compiled = uint64_t(r.programs_compiled());
      return c;
    });
  }
}

bool Ops::Start(std::string *error) {
  if (!metrics_) return true;
  metrics_http_ = std::make_unique<MetricsHttpServer>();
  int port = 0;
  if (!metrics_http_->Start(flags_.metrics_listen, metrics_.get(), &port, error)) return false;
  const std::string host = flags_.metrics_listen.substr(0, flags_.metrics_listen.rfind(':'));
  std::fprintf(stderr, "glintd: metrics on http://%s:%d/metrics\n", host.c_str(), port);
  return true;
}

}  // namespace glint
