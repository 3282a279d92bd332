#include "server/auth.h"

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>

namespace glint {
namespace {

constexpr char kBearer[] = "Bearer ";

// The write end of the self-pipe of the one TokenAuth that reloads on SIGHUP.
volatile sig_atomic_t g_sighup_fd = -1;

void OnSighup(int) {
  const int saved = errno;
  const int fd = g_sighup_fd;
  if (fd >= 0) {
    const char c = 'h';
    [[maybe_unused]] ssize_t n = write(fd, &c, 1);  // async-signal-safe; a full pipe is fine
  }
  errno = saved;
}

std::string Trim(const std::string &s) {
  const size_t b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return "";
  const size_t e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

// Equal in time independent of where the strings first differ, so response timing does not
// reveal a token's prefix.
bool ConstantTimeEqual(const std::string &a, const std::string &b) {
  if (a.size() != b.size()) return false;
  unsigned char diff = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    diff = static_cast<unsigned char>(
        diff | (static_cast<unsigned char>(a[i]) ^ static_cast<unsigned char>(b[i])));
  }
  return diff == 0;
}

}  // namespace

bool TokenAuth::Read(const std::string &path, std::vector<std::string> *tokens,
                     std::string *error) {
  std::ifstream in(path);
  if (!in) {
    *error = "--auth-tokens " + path + ": cannot read the file";
    return false;
  }
  tokens->clear();
  std::string line;
  while (std::getline(in, line)) {
    line = Trim(line);
    if (line.empty() || line[0] == '#') continue;
    tokens->push_back(line);
  }
  if (tokens->empty()) {
    *error = "--auth-tokens " + path + ": no token in the file (one per line)";
    return false;
  }
  return true;
}

std::unique_ptr<TokenAuth> TokenAuth::Load(const std::string &path, std::string *error) {
  std::unique_ptr<TokenAuth> auth(new TokenAuth(path));
  if (!Read(path, &auth->tokens_, error)) return nullptr;
  return auth;
}

TokenAuth::~TokenAuth() {
  if (reload_thread_.joinable()) {
    signal(SIGHUP, SIG_IGN);
    g_sighup_fd = -1;
    close(wake_fd_[1]);  // the reload thread reads EOF and returns
    reload_thread_.join();
    close(wake_fd_[0]);
  }
}

size_t TokenAuth::Reload(std::string *error) {
  std::vector<std::string> tokens;
  if (!Read(path_, &tokens, error)) return 0;
  std::lock_guard<std::mutex> lock(mutex_);
  tokens_ = std::move(tokens);
  return tokens_.size();
}

void TokenAuth::ReloadOnSighup() {
  if (reload_thread_.joinable() || pipe2(wake_fd_, O_CLOEXEC) != 0) return;
  g_sighup_fd = wake_fd_[1];
  struct sigaction action {};
  action.sa_handler = OnSighup;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESTART;
  sigaction(SIGHUP, &action, nullptr);
  reload_thread_ = std::thread([this] {
    char c = 0;
    while (read(wake_fd_[0], &c, 1) == 1) {
      std::string error;
      const size_t n = Reload(&error);
      if (n > 0) {
        std::fprintf(stderr, "glintd: SIGHUP: %zu tokens loaded from %s\n", n, path_.c_str());
      } else {
        std::fprintf(stderr, "glintd: SIGHUP: %s; keeping the %zu tokens loaded before\n",
                     error.c_str(), size());
      }
    }
  });
}

bool TokenAuth::Accepts(const std::string &header) const {
  if (header.rfind(kBearer, 0) != 0) return false;
  const std::string token = Trim(header.substr(sizeof kBearer - 1));
  std::lock_guard<std::mutex> lock(mutex_);
  bool found = false;
  for (const std::string &t : tokens_) found |= ConstantTimeEqual(t, token);  // no early exit
  return found && !token.empty();
}

size_t TokenAuth::size() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return tokens_.size();
}

grpc::Status CheckBearer(const TokenAuth *auth, const grpc::ServerContextBase &context) {
  if (auth == nullptr) return grpc::Status::OK;
  const auto &metadata = context.client_metadata();
  const auto it = metadata.find("authorization");
  if (it == metadata.end()) {
    return grpc::Status(grpc::StatusCode::UNAUTHENTICATED,
                        "this server requires 'authorization: Bearer <token>' metadata "
                        "(glint --token-file FILE or GLINT_TOKEN)");
  }
  if (!auth->Accepts(std::string(it->second.data(), it->second.size()))) {
    return grpc::Status(grpc::StatusCode::UNAUTHENTICATED,
                        "the bearer token is not accepted by this server");
  }
  return grpc::Status::OK;
}

}  // namespace glint
