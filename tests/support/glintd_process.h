// Test support: temporary directories, child processes that die with the
// test (PR_SET_PDEATHSIG), and a glintd on a free loopback port. Shared by
// the service tests, the CLI tests and the benchmarks.
#pragma once

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <stdlib.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace glint::test {

namespace fs = std::filesystem;

// GLINTD_UNDER_TEST runs a test against another glintd binary (e.g. an older build, to see it
// fail there); otherwise against `built`, the one built with the test. Glintd::Launch (and so
// Glintd::Start) applies it to every glintd it starts, so a test need not call this itself
// (calling it too is harmless: the result does not depend on its argument once the variable is
// set). Before, only the tests that remembered to call it honoured the variable.
inline std::string GlintdUnderTest(const std::string &built) {
  const char *path = std::getenv("GLINTD_UNDER_TEST");
  return path && *path ? path : built;
}

// How long glintd may take to compile and warm its kernels before it reports SERVING (PoCL
// compiles on first use when the kernel cache is cold). Derived from what it must do: the
// --warm common set costs ~35 s of CPU cold (warmup_test's measurement), so wall time is about
// that times load/2 on the 2-core machine: ~350 s at load 20, where 240 s was too short.
// 600 s, as tests/python/conftest.py and scripts/demo.sh wait; the ctest TIMEOUT of every test
// that starts a warming glintd (900 s) leaves room for the test after it. A bound on a wait
// for the port file, not a speed check: a warm start returns in about a second.
inline constexpr auto kServerStartTimeout = std::chrono::seconds(600);

inline std::string ReadFile(const std::string &path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

class TempDir {
 public:
  explicit TempDir(const std::string &prefix = "glint_test") {
    std::string tmpl = (fs::temp_directory_path() / (prefix + "_XXXXXX")).string();
    path_ = mkdtemp(tmpl.data());
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  std::string File(const std::string &name) const { return (fs::path(path_) / name).string(); }

 private:
  std::string path_;
};

// fork + exec with stdout/stderr to files; the child dies with us (PR_SET_PDEATHSIG) so that a
// crashing test never leaves a server behind.
inline pid_t Spawn(const std::vector<std::string> &args, const std::string &out_path,
                   const std::string &err_path) {
  std::vector<char *> argv;
  for (const auto &a : args) argv.push_back(const_cast<char *>(a.c_str()));
  argv.push_back(nullptr);
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid == 0) {
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (getppid() != parent) _exit(127);  // the parent died before prctl took effect
    const int out = open(out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int err = open(err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int null = open("/dev/null", O_RDONLY);
    if (out < 0 || err < 0 || null < 0) _exit(127);
    dup2(null, STDIN_FILENO);
    dup2(out, STDOUT_FILENO);
    dup2(err, STDERR_FILENO);
    execv(argv[0], argv.data());
    _exit(127);
  }
  return pid;
}

// "exit status N" or "killed by signal N (name)" for a waitpid status.
inline std::string DescribeWaitStatus(int status) {
  if (WIFEXITED(status)) return "exit status " + std::to_string(WEXITSTATUS(status));
  if (WIFSIGNALED(status))
    return "killed by signal " + std::to_string(WTERMSIG(status)) + " (" +
           strsignal(WTERMSIG(status)) + ")";
  return "wait status " + std::to_string(status);
}

// The last `max_lines` lines of a log file (a crash's message is at its end).
inline std::string LogTail(const std::string &path, size_t max_lines = 40) {
  const std::string text = ReadFile(path);
  size_t at = text.size();
  for (size_t lines = 0; at > 0 && lines < max_lines;)
    if (text[--at] == '\n' && at + 1 < text.size()) ++lines;
  if (at > 0) return "[...]\n" + text.substr(at + 1);
  return text;
}

// Waits for `port_file` (written by glintd once SERVING) of the child `pid`, whose stderr goes to
// `err_path`. Ends at once when the child exits first (a crash, a refused flag): false with its
// exit status and stderr tail in `error`, the child reaped (`*reaped` set). The
// kServerStartTimeout bound only ends a start that hangs.
inline bool WaitForPortFile(pid_t pid, const std::string &port_file, const std::string &err_path,
                            std::string *error, bool *reaped) {
  *reaped = false;
  const auto deadline = std::chrono::steady_clock::now() + kServerStartTimeout;
  while (std::chrono::steady_clock::now() < deadline) {
    if (!ReadFile(port_file).empty()) return true;
    int status = 0;
    if (waitpid(pid, &status, WNOHANG) == pid) {
      *reaped = true;
      *error = "glintd exited before SERVING (" + DescribeWaitStatus(status) + "); its stderr:\n" +
               LogTail(err_path);
      return false;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  *error = "glintd did not write its port file within " +
           std::to_string(kServerStartTimeout.count()) + " s; its stderr:\n" + LogTail(err_path);
  return false;
}

// A loopback port that was free a moment ago (bound to port 0, read back, closed), for a test
// that must know the port before glintd writes its port file. Another process may take it in
// between; Glintd::Launch callers see that as glintd exiting with "could not listen".
inline int FreeLoopbackPort() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return 0;
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = 0;
  socklen_t len = sizeof addr;
  int port = 0;
  if (bind(fd, reinterpret_cast<sockaddr *>(&addr), sizeof addr) == 0 &&
      getsockname(fd, reinterpret_cast<sockaddr *>(&addr), &len) == 0) {
    port = ntohs(addr.sin_port);
  }
  close(fd);
  return port;
}

// A loopback port bound and held but never listening, for tests of an unreachable server:
// connections to it are refused for as long as this object lives, and no other process (a
// glintd of a test running at the same time, listening on port 0) can take it meanwhile, as
// it could a port from FreeLoopbackPort.
class RefusingLoopbackPort {
 public:
  RefusingLoopbackPort() {
    fd_ = socket(AF_INET, SOCK_STREAM, 0);
    if (fd_ < 0) return;
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof addr;
    if (bind(fd_, reinterpret_cast<sockaddr *>(&addr), sizeof addr) == 0 &&
        getsockname(fd_, reinterpret_cast<sockaddr *>(&addr), &len) == 0) {
      port_ = ntohs(addr.sin_port);
    }
  }
  ~RefusingLoopbackPort() {
    if (fd_ >= 0) close(fd_);
  }
  RefusingLoopbackPort(const RefusingLoopbackPort &) = delete;
  RefusingLoopbackPort &operator=(const RefusingLoopbackPort &) = delete;
  int port() const { return port_; }  // 0 if the bind failed

 private:
  int fd_ = -1;
  int port_ = 0;
};

// One glintd process on a loopback port; stopped (SIGTERM, then SIGKILL) on destruction.
class Glintd {
 public:
  // Starts glintd on a free port and waits until it reports SERVING (writes its port file).
  static std::unique_ptr<Glintd> Start(const std::string &glintd_path, const TempDir &dir,
                                       const std::string &name,
                                       const std::vector<std::string> &extra, std::string *error) {
    auto server = Launch(glintd_path, dir, name, 0, extra);
    if (!server->WaitUntilServing(error)) return nullptr;  // the destructor kills it
    return server;
  }

  // Starts glintd on `port` (0: a free one, known only once SERVING) and returns at once.
  // `glintd_path` is the glintd built with the test; GLINTD_UNDER_TEST, when set, replaces it
  // (GlintdUnderTest).
  static std::unique_ptr<Glintd> Launch(const std::string &glintd_path, const TempDir &dir,
                                        const std::string &name, int port,
                                        const std::vector<std::string> &extra) {
    auto server = std::unique_ptr<Glintd>(new Glintd);
    server->port_file_ = dir.File(name + ".port");
    server->log_ = dir.File(name + ".log");
    const std::string listen = "127.0.0.1:" + std::to_string(port);
    if (port > 0) server->address_ = listen;
    std::vector<std::string> args = {
        GlintdUnderTest(glintd_path), "--listen", listen, "--port-file",
        server->port_file_,           "--quiet"};
    args.insert(args.end(), extra.begin(), extra.end());
    server->pid_ = Spawn(args, server->log_, server->log_ + ".err");
    return server;
  }

  // Waits for the port file, which glintd writes once it reports SERVING; ends at once with
  // glintd's exit status and stderr tail if it exits first (WaitForPortFile).
  bool WaitUntilServing(std::string *error) {
    if (pid_ <= 0) {
      *error = "glintd is not running";
      return false;
    }
    bool reaped = false;
    const bool serving = WaitForPortFile(pid_, port_file_, log_ + ".err", error, &reaped);
    if (reaped) pid_ = -1;  // never signal a pid that may have been reused
    if (!serving) return false;
    address_ = "127.0.0.1:" + std::to_string(PortFromFile());
    return true;
  }

  // The port glintd wrote to its port file, 0 while there is none.
  int PortFromFile() const {
    const std::string port = ReadFile(port_file_);
    return port.empty() ? 0 : std::atoi(port.c_str());
  }

  ~Glintd() {
    if (pid_ <= 0) return;
    kill(pid_, SIGTERM);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    int status = 0;
    while (waitpid(pid_, &status, WNOHANG) == 0) {
      if (std::chrono::steady_clock::now() > deadline) {
        kill(pid_, SIGKILL);
        waitpid(pid_, &status, 0);
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }

  // The port of /metrics of a glintd started with `--metrics-listen 127.0.0.1:0`: glintd binds a
  // free port itself and prints "glintd: metrics on http://HOST:PORT/metrics" on stderr before it
  // reports SERVING, so after Start (or WaitUntilServing) this reads it; 0 when absent. Better
  // than a port picked by the test (FreeLoopbackPort) and bound by glintd later, which another
  // test's server, started at the same time under ctest -j, can take in between.
  int MetricsPort() const {
    const std::string err = Stderr();
    const std::string key = "glintd: metrics on http://";
    const size_t at = err.find(key);
    if (at == std::string::npos) return 0;
    const size_t end = err.find("/metrics", at + key.size());
    const size_t colon = err.rfind(':', end);
    if (end == std::string::npos || colon == std::string::npos || colon < at) return 0;
    return std::atoi(err.c_str() + colon + 1);
  }

  const std::string &address() const { return address_; }
  pid_t pid() const { return pid_; }  // for signals other than the destructor's SIGTERM
  std::string Stderr() const { return ReadFile(log_ + ".err"); }
  // Sends `sig` to the server (graceful-shutdown tests).
  void Signal(int sig) {
    if (pid_ > 0) kill(pid_, sig);
  }
  // Waits up to `timeout` for the server to exit; true with its wait status if it did.
  bool WaitExit(std::chrono::milliseconds timeout, int *wait_status) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (pid_ > 0) {
      const pid_t r = waitpid(pid_, wait_status, WNOHANG);
      if (r == pid_) {
        pid_ = -1;
        return true;
      }
      if (std::chrono::steady_clock::now() > deadline) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return false;
  }
  bool Alive() {
    if (pid_ <= 0) return false;
    if (waitpid(pid_, nullptr, WNOHANG) == 0) return true;
    pid_ = -1;  // reaped: never signal a pid that may have been reused
    return false;
  }

 private:
  Glintd() = default;
  pid_t pid_ = -1;
  std::string log_;
  std::string port_file_;
  std::string address_;
};

}  // namespace glint::test
