#include "client/cli/cli_common.h"

#include <unistd.h>

#include <cstdio>

namespace glint::cli {
namespace {

bool Contains(const std::vector<std::string> &v, const std::string &s) {
  for (const auto &x : v) {
    if (x == s) return true;
  }
  return false;
}

}  // namespace

Options::Options(int argc, char **argv, const std::vector<std::string> &with_value,
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
    if (!takes_value) {
      if (values_.count(name)) throw UsageError{"option --" + name + " given twice"};
      if (inline_value) throw UsageError{"option --" + name + " takes no value"};
      values_[name].push_back("");
      continue;
    }
    if (inline_value) {
      values_[name].push_back(*inline_value);
    } else if (i + 1 < argc) {
      values_[name].push_back(argv[++i]);
    } else {
      throw UsageError{"option --" + name + " needs a value"};
    }
  }
}

std::string Options::Required(const std::string &name) const {
  auto it = values_.find(name);
  if (it == values_.end() || it->second.front().empty()) throw UsageError{"missing --" + name};
  if (it->second.size() > 1) throw UsageError{"option --" + name + " given twice"};
  return it->second.front();
}

std::string Options::Get(const std::string &name, const std::string &fallback) const {
  auto it = values_.find(name);
  if (it == values_.end()) return fallback;
  if (it->second.size() > 1) throw UsageError{"option --" + name + " given twice"};
  return it->second.front();
}

std::vector<std::string> Options::GetAll(const std::string &name) const {
  auto it = values_.find(name);
  return it == values_.end() ? std::vector<std::string>{} : it->second;
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
  if (text == "auto") return glint::v1::AUTO;
  throw UsageError{"--area-method: '" + text +
                   "' is not one of ltc, reference, lecocq, lecocq-pearson, mc, auto"};
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

ProgressBar::ProgressBar() : enabled_(isatty(STDERR_FILENO) == 1) {}

void ProgressBar::Update(uint64_t done, uint64_t total) {
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

void ProgressBar::Finish() {
  if (enabled_ && drawn_) std::fputc('\n', stderr);
  drawn_ = false;
}

const std::vector<std::string> kConnectionOptions = {"tls-ca", "tls-cert", "tls-key", "token-file"};
const char *const kConnectionUsage = R"(
connection (every command):
  --tls-ca PEM        connect with TLS, verifying the server against these roots
                      (--tls-cert alone: TLS with the system roots)
  --tls-cert PEM      client certificate chain for mutual TLS (with --tls-key)
  --tls-key PEM       its private key
  --token-file FILE   send 'authorization: Bearer <first line of FILE>' on every call;
                      without it the token comes from $GLINT_TOKEN when that is set
)";

glint::client::ClientOptions ConnectionOptions(const Options &options) {
  glint::client::ClientOptions client;
  client.security =
      glint::client::LoadChannelSecurity(options.Get("tls-ca", ""), options.Get("tls-cert", ""),
                                         options.Get("tls-key", ""), options.Get("token-file", ""));
  return client;
}

int ReportRpcError(const std::string &what, const grpc::Status &status, const std::string &server) {
  std::fprintf(stderr, "glint: %s: %s\n", what.c_str(),
               glint::client::FormatStatus(status).c_str());
  if (status.error_code() == grpc::StatusCode::UNAVAILABLE) {
    std::fprintf(stderr, "glint: is glintd running and listening on %s?\n", server.c_str());
  }
  return kExitFailure;
}

void FillSettings(const Options &options, glint::v1::EvaluateRequest *request) {
  request->set_precision(ParsePrecision(options.Get("precision", "fp32")));
  request->set_seed(ParseNumber<uint64_t>("seed", options.Get("seed", "0")));
  request->set_area_method(ParseAreaMethod(options.Get("area-method", "ltc")));
  if (options.Has("samples"))
    request->set_area_samples(ParseNumber<uint32_t>("samples", options.Get("samples", "")));
  // --area-method auto's budget; the server refuses AUTO without it and it without AUTO.
  if (options.Has("max-error"))
    request->set_max_relative_error(ParseNumber<float>("max-error", options.Get("max-error", "")));
}

std::optional<double> EvaluateWithProgress(glint::client::GlintClient &client,
                                           const glint::v1::EvaluateRequest &request,
                                           std::vector<float> *rgb,
                                           glint::client::EvaluateInfo *info,
                                           const std::string &server,
                                           glint::client::Transport transport, std::string *used) {
  ProgressBar bar;
  const auto start = std::chrono::steady_clock::now();
  grpc::Status status = glint::client::EvaluateWithTransport(
      client, transport, request, rgb,
      [&](uint64_t done, uint64_t total) { bar.Update(done, total); }, info, used);
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

}  // namespace glint::cli
