// glintd's operations features, kept out of main.cpp: their flags, the /metrics endpoint and
// the gRPC server hooks they need. main.cpp parses the flags with ParseOpsFlag, builds one Ops,
// and calls Configure on the ServerBuilder and Start once the server runs.
#pragma once

#include <grpcpp/grpcpp.h>

#include <memory>
#include <string>
#include <vector>

#include "server/auth.h"
#include "server/metrics.h"
#include "server/metrics_http.h"

namespace glint {

class DeviceEngine;
class Scheduler;

struct OpsFlags {
  std::string metrics_listen;     // HOST:PORT of the Prometheus endpoint; "" = none
  std::string tls_cert, tls_key;  // PEM files: serve TLS instead of plaintext
  std::string tls_client_ca;      // PEM roots: require client certificates (mutual TLS)
  std::string auth_tokens;        // token file: require `authorization: Bearer <token>`
};

// Warnings for a listen address reachable beyond loopback without TLS or tokens; empty for
// loopback (127.0.0.0/8, ::1, localhost) and unix: sockets, where plaintext without tokens
// is the zero-configuration default.
std::vector<std::string> ExposureWarnings(const std::string &listen, bool tls,
                                          bool client_certificates, bool tokens);

// The usage lines of the flags below, appended to glintd --help.
extern const char kOpsUsage[];

// If argv[*i] is one of the ops flags, consumes it (and its value, advancing *i) into `flags`
// and returns true. A flag without its value exits with status 2, as glintd's other flags do.
bool ParseOpsFlag(int argc, char **argv, int *i, OpsFlags *flags);

class Ops {
 public:
  explicit Ops(OpsFlags flags);
  ~Ops();

  // Reads the TLS files and the token file. False with `error` naming the flag and file.
  bool Init(std::string *error);

  // Plaintext, or TLS (mutual with --tls-client-ca) from the files Init read.
  std::shared_ptr<grpc::ServerCredentials> ServerCredentials() const;
  // Null without --auth-tokens: the service then lets every call through.
  const TokenAuth *auth() const { return auth_.get(); }
  // Logs ExposureWarnings for `listen` to stderr.
  void WarnIfExposed(const std::string &listen) const;

  // Null when --metrics-listen is not given: the service then skips its metric hooks.
  Metrics *metrics() { return metrics_.get(); }

  // Before BuildAndStart: interceptors (metrics); reads the scheduler's depth and the engine's
  // program cache (engine may be null: --device host) when scraped.
  void Configure(grpc::ServerBuilder *builder, const Scheduler *scheduler, DeviceEngine *engine);

  // After the server is up: starts the metrics endpoint. False with `error` on failure.
  bool Start(std::string *error);

 private:
  OpsFlags flags_;
  std::unique_ptr<Metrics> metrics_;
  std::unique_ptr<MetricsHttpServer> metrics_http_;
  std::string cert_pem_, key_pem_, client_ca_pem_;
  std::unique_ptr<TokenAuth> auth_;
};

}  // namespace glint
