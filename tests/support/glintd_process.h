// Test support: temporary directories, child processes that die with the
// test (PR_SET_PDEATHSIG), and a glintd on a free loopback port. Shared by
// the service tests, the CLI tests and the benchmarks.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <stdlib.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace glint::test {

namespace fs = std::filesystem;

// How long glintd may take to compile and warm its kernels before it reports SERVING (PoCL
// compiles on first use when the kernel cache is cold).
inline constexpr auto kServerStartTimeout = std::chrono::seconds(240);

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

// One glintd process on a free loopback port; stopped (SIGTERM, then SIGKILL) on destruction.
class Glintd {
 public:
  static std::unique_ptr<Glintd> Start(const std::string &glintd_path, const TempDir &dir,
                                       const std::string &name,
                                       const std::vector<std::string> &extra, std::string *error) {
    auto server = std::unique_ptr<Glintd>(new Glintd);
    const std::string port_file = dir.File(name + ".port");
    server->log_ = dir.File(name + ".log");
    std::vector<std::string> args = {glintd_path,   "--listen", "127.0.0.1:0",
                                     "--port-file", port_file,  "--quiet"};
    args.insert(args.end(), extra.begin(), extra.end());
    server->pid_ = Spawn(args, server->log_, server->log_ + ".err");
    const auto deadline = std::chrono::steady_clock::now() + kServerStartTimeout;
    while (std::chrono::steady_clock::now() < deadline) {
      int status = 0;
      if (waitpid(server->pid_, &status, WNOHANG) == server->pid_) {
        server->pid_ = -1;
        *error = "glintd exited before SERVING:\n" + ReadFile(server->log_ + ".err");
        return nullptr;
      }
      const std::string port = ReadFile(port_file);
      if (!port.empty() && std::atoi(port.c_str()) > 0) {
        server->address_ = "127.0.0.1:" + std::to_string(std::atoi(port.c_str()));
        return server;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    *error = "glintd did not write its port file within the timeout:\n" +
             ReadFile(server->log_ + ".err");
    return nullptr;  // the destructor kills it
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

  const std::string &address() const { return address_; }
  bool Alive() const { return pid_ > 0 && waitpid(pid_, nullptr, WNOHANG) == 0; }

 private:
  Glintd() = default;
  pid_t pid_ = -1;
  std::string log_;
  std::string address_;
};

}  // namespace glint::test
