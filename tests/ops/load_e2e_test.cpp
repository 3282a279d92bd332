// glint load as a user runs it, against a real glintd on loopback (--device host: no kernel
// warm-up, so the server is up at once): two concurrency levels of ~1 s each, then the CSV is
// parsed and checked (header, one row per level, answers and no errors, the columns agree).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "client/lib/load_runner.h"
#include "glintd_process.h"

namespace {

using glint::test::Glintd;
using glint::test::ReadFile;
using glint::test::Spawn;
using glint::test::TempDir;

std::vector<std::string> Split(const std::string &line, char sep) {
  std::vector<std::string> out;
  std::stringstream s(line);
  std::string item;
  while (std::getline(s, item, sep)) out.push_back(item);
  return out;
}

int RunGlint(const TempDir &dir, const std::vector<std::string> &args, std::string *out,
             std::string *err) {
  const pid_t pid = Spawn(args, dir.File("glint.out"), dir.File("glint.err"));
  int status = 0;
  waitpid(pid, &status, 0);
  *out = ReadFile(dir.File("glint.out"));
  *err = ReadFile(dir.File("glint.err"));
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

TEST(LoadEndToEnd, CsvHasOneAnsweredRowPerLevel) {
  TempDir dir("glint_load");
  std::string error;
  auto server = Glintd::Start(GLINTD_PATH, dir, "glintd", {"--device", "host"}, &error);
  ASSERT_NE(server, nullptr) << error;
  for (const bool stream : {false, true}) {
    SCOPED_TRACE(stream ? "stream" : "unary");
    const std::string csv = dir.File(stream ? "stream.csv" : "unary.csv");
    std::vector<std::string> args = {GLINT_CLI_PATH,  "load", "--server", server->address(),
                                     "--concurrency", "1,3",  "--batch",  "64",
                                     "--duration",    "0.5",  "--csv",    csv};
    if (stream) args.push_back("--stream");
    std::string out, err;
    ASSERT_EQ(RunGlint(dir, args, &out, &err), 0) << out << err;
    EXPECT_NE(out.find("Request concurrency: 3"), std::string::npos) << out;

    const std::vector<std::string> lines = Split(ReadFile(csv), '\n');
    ASSERT_EQ(lines.size(), 3u) << ReadFile(csv);
    EXPECT_EQ(lines[0],
              "concurrency,requests_per_s,queries_per_s,p50_ms,p90_ms,p99_ms,ok,"
              "refused,errors");
    const int levels[] = {1, 3};
    for (int row = 0; row < 2; ++row) {
      const std::vector<std::string> f = Split(lines[static_cast<size_t>(row) + 1], ',');
      ASSERT_EQ(f.size(), 9u) << lines[static_cast<size_t>(row) + 1];
      EXPECT_EQ(std::stoi(f[0]), levels[row]);
      const double rps = std::stod(f[1]), qps = std::stod(f[2]);
      const double p50 = std::stod(f[3]), p90 = std::stod(f[4]), p99 = std::stod(f[5]);
      const long ok = std::stol(f[6]), refused = std::stol(f[7]), errors = std::stol(f[8]);
      EXPECT_GT(ok, 0);
      EXPECT_EQ(errors, 0);
      // 3 clients against the default --max-pending 16 can never fill the queue.
      EXPECT_EQ(refused, 0);
      // queries/s is requests/s times the batch; both are printed with 6 significant digits.
      EXPECT_NEAR(qps, rps * 64, 1e-5 * qps);
      // ok answers in >= 0.5 s: requests/s cannot exceed ok / 0.5.
      EXPECT_LE(rps, static_cast<double>(ok) / 0.5 * (1 + 1e-5));
      EXPECT_GT(p50, 0.0);
      EXPECT_LE(p50, p90);
      EXPECT_LE(p90, p99);
    }
  }
}

// A closed address: every request fails (UNAVAILABLE), the tool says so and exits 1 instead
// of reporting throughput; it gives up within its time bound.
TEST(LoadEndToEnd, UnreachableServerFailsWithinTheBound) {
  TempDir dir("glint_load");
  const glint::test::RefusingLoopbackPort closed;  // held: no server can take it meanwhile
  const int port = closed.port();
  ASSERT_GT(port, 0);
  std::string out, err;
  EXPECT_EQ(RunGlint(dir,
                     {GLINT_CLI_PATH, "load", "--server", "127.0.0.1:" + std::to_string(port),
                      "--duration", "0.2", "--wait-ms", "300"},
                     &out, &err),
            1);
  EXPECT_NE(err.find("UNAVAILABLE"), std::string::npos) << err;
}

}  // namespace

// An unwritable --csv is refused before any request is sent, naming the path: before, every
// level ran to its end first (a TD lost the whole run to a typo in the directory). The server
// address is closed, so a tool that still ran the levels would fail with UNAVAILABLE instead.
TEST(LoadEndToEnd, UnwritableCsvIsRefusedBeforeTheRun) {
  TempDir dir("glint_load");
  const glint::test::RefusingLoopbackPort closed;  // held: no server can take it meanwhile
  const int port = closed.port();
  ASSERT_GT(port, 0);
  const std::string csv = dir.File("no-such-dir") + "/load.csv";
  std::string out, err;
  EXPECT_EQ(RunGlint(dir,
                     {GLINT_CLI_PATH, "load", "--server", "127.0.0.1:" + std::to_string(port),
                      "--duration", "0.2", "--wait-ms", "300", "--csv", csv},
                     &out, &err),
            1);
  EXPECT_NE(err.find("cannot write " + csv), std::string::npos) << err;
  EXPECT_EQ(err.find("UNAVAILABLE"), std::string::npos) << err;
  EXPECT_EQ(out.find("Request concurrency"), std::string::npos) << out;
}

// A run that fails before it has anything to write (here: no server) leaves an existing --csv
// file as it was and creates none: the early writability check must not truncate. It did: the
// check opened the path for writing before the run, so a mistyped --server emptied the CSV of the
// previous run (and left an empty file where there was none).
TEST(LoadEndToEnd, FailedRunLeavesTheCsvAsItWas) {
  TempDir dir("glint_load");
  const glint::test::RefusingLoopbackPort closed;  // held: no server can take it meanwhile
  const int port = closed.port();
  ASSERT_GT(port, 0);
  const std::string old_csv = dir.File("old.csv"), new_csv = dir.File("new.csv");
  const std::string previous = "concurrency,ok\n1,42\n";
  std::ofstream(old_csv, std::ios::binary) << previous;
  for (const std::string &csv : {old_csv, new_csv}) {
    std::string out, err;
    EXPECT_EQ(RunGlint(dir,
                       {GLINT_CLI_PATH, "load", "--server", "127.0.0.1:" + std::to_string(port),
                        "--duration", "0.2", "--wait-ms", "300", "--csv", csv},
                       &out, &err),
              1);
    EXPECT_NE(err.find("UNAVAILABLE"), std::string::npos) << err;
  }
  EXPECT_EQ(ReadFile(old_csv), previous);
  EXPECT_NE(access(new_csv.c_str(), F_OK), 0) << new_csv << " was created by a failed run";
}
