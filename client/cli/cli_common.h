// Pieces every glint command shares: option parsing, the evaluation settings, the progress bar
// and the way RPC errors are reported. Commands live in their own files (main.cpp dispatches).
#ifndef GLINT_CLIENT_CLI_CLI_COMMON_H
#define GLINT_CLIENT_CLI_CLI_COMMON_H

#include <charconv>
#include <chrono>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "client/lib/glint_client.h"
#include "client/lib/shm_transport.h"

namespace glint::cli {

inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;
inline constexpr int kExitUsage = 2;

// A command-line mistake: printed with the command's usage, exit 2.
struct UsageError {
  std::string message;
};

// --name value, --name=value, or a bare --flag. Only the options a command declares exist.
// An option with a value may be given several times; GetAll returns every value in order, and
// Required / Get refuse an option given more than once (so only commands that read a list
// with GetAll accept repeats).
class Options {
 public:
  Options(int argc, char **argv, const std::vector<std::string> &with_value,
          const std::vector<std::string> &flags);

  bool help() const { return help_; }
  bool Has(const std::string &name) const { return values_.count(name) != 0; }
  std::string Required(const std::string &name) const;
  std::string Get(const std::string &name, const std::string &fallback) const;
  std::vector<std::string> GetAll(const std::string &name) const;

 private:
  bool help_ = false;
  std::map<std::string, std::vector<std::string>> values_;
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

glint::v1::Precision ParsePrecision(const std::string &text);
glint::v1::AreaMethod ParseAreaMethod(const std::string &text);
// "WIDTHxHEIGHT" with positive integers.
bool ParseSize(const std::string &text, int *width, int *height);

// Draws "[=====>     ]  45%  450000/1000000 queries" on stderr, only when stderr is a
// terminal: logs and pipes must not fill up with carriage returns.
class ProgressBar {
 public:
  ProgressBar();
  ~ProgressBar() { Finish(); }
  void Update(uint64_t done, uint64_t total);
  void Finish();

 private:
  bool enabled_;
  bool drawn_ = false;
  std::chrono::steady_clock::time_point last_{};
};

// Options every command that talks to a server takes (appended to each command's list), and
// their usage text.
extern const std::vector<std::string> kConnectionOptions;
extern const char *const kConnectionUsage;

// The channel settings of --tls-ca/--tls-cert/--tls-key/--token-file (or $GLINT_TOKEN).
glint::client::ClientOptions ConnectionOptions(const Options &options);

// "glint: <what>: UNAVAILABLE: ..." plus a hint where the code has an obvious cause.
int ReportRpcError(const std::string &what, const grpc::Status &status, const std::string &server);

// Fills the settings every evaluating command shares (--precision, --seed, --area-method,
// --samples).
void FillSettings(const Options &options, glint::v1::EvaluateRequest *request);

// Evaluates with a progress bar and returns the wall time in seconds, or nullopt after
// reporting an RPC error. `transport` (--transport, client/lib/shm_transport.h) picks arrays over
// the connection or same-host shared memory; `used` receives "tcp" or "shm".
std::optional<double> EvaluateWithProgress(
    glint::client::GlintClient &client, const glint::v1::EvaluateRequest &request,
    std::vector<float> *rgb, glint::client::EvaluateInfo *info, const std::string &server,
    glint::client::Transport transport = glint::client::Transport::kTcp,
    std::string *used = nullptr);

// "unary" or "stream (N chunks of <= M queries)".
std::string Transport(const glint::client::EvaluateInfo &info);

}  // namespace glint::cli

#endif  // GLINT_CLIENT_CLI_CLI_COMMON_H
