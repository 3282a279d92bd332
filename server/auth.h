// Bearer-token authentication (glintd --auth-tokens FILE): every RPC of glint.v1.GlintService
// must carry the metadata `authorization: Bearer <token>` with a token listed in FILE, or it
// is answered UNAUTHENTICATED before any work. grpc.health.v1 is not ours and stays open (load
// balancers probe it without credentials). Tokens are never logged; the file is re-read on
// SIGHUP (an unreadable or empty file then keeps the old tokens and says so).
//
// The check runs in each handler (CheckBearer) rather than in gRPC's AuthMetadataProcessor,
// which only exists for TLS credentials: tokens must also work on a plaintext loopback port.
#pragma once

#include <grpcpp/grpcpp.h>

#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace glint {

class TokenAuth {
 public:
  // Reads `path`: one token per line; surrounding blanks trimmed; blank lines and lines
  // starting with '#' ignored. False with `error` (naming the file, never a token) when it
  // cannot be read or holds no token.
  static std::unique_ptr<TokenAuth> Load(const std::string &path, std::string *error);
  ~TokenAuth();

  // Re-reads the file; on failure keeps the current tokens. Returns the number loaded (0 on
  // failure, with `error`).
  size_t Reload(std::string *error);

  // Installs a SIGHUP handler that makes a background thread call Reload and log the outcome.
  void ReloadOnSighup();

  // True when `header` (the authorization metadata value) is "Bearer <t>" with a known t.
  bool Accepts(const std::string &header) const;

  size_t size() const;

 private:
  explicit TokenAuth(std::string path) : path_(std::move(path)) {}
  static bool Read(const std::string &path, std::vector<std::string> *tokens, std::string *error);

  std::string path_;
  mutable std::mutex mutex_;
  std::vector<std::string> tokens_;
  int wake_fd_[2] = {-1, -1};  // self-pipe: the signal handler writes, the reload thread reads
  std::thread reload_thread_;
};

// OK when `auth` is null or the call carries an accepted bearer token; UNAUTHENTICATED (with a
// message that names what is missing, never the token sent) otherwise.
grpc::Status CheckBearer(const TokenAuth *auth, const grpc::ServerContextBase &context);

// A bidi reactor that only answers `status`: how a refused stream is finished.
template <typename Request, typename Response>
class RefusedBidiReactor final : public grpc::ServerBidiReactor<Request, Response> {
 public:
  explicit RefusedBidiReactor(const grpc::Status &status) { this->Finish(status); }
  void OnDone() override { delete this; }
};

// A client-streaming reactor that only answers `status` (a refused upload).
template <typename Request>
class RefusedReadReactor final : public grpc::ServerReadReactor<Request> {
 public:
  explicit RefusedReadReactor(const grpc::Status &status) { this->Finish(status); }
  void OnDone() override { delete this; }
};

}  // namespace glint
