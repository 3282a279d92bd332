// The glint CLI as a user runs it. Cli.* needs only the glint binary (usage and local errors);
// CliEndToEnd.* starts real glintd processes on loopback ports: one with the default batch
// limit (small inputs go unary) and one with --max-batch 256 (the same inputs are streamed),
// and checks that CSV, NPY and EXR outputs agree and streamed equals unary bit for bit.
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "glintd_process.h"

#ifndef GLINT_CLI_PATH
#error "GLINT_CLI_PATH must name the glint executable"
#endif
#ifndef GLINTD_PATH
#define GLINTD_PATH ""
#endif

namespace {

namespace fs = std::filesystem;
using glint::test::Glintd;
using glint::test::ReadFile;
using glint::test::Spawn;
using glint::test::TempDir;

const std::string kGlint = GLINT_CLI_PATH;
const std::string kGlintd = GLINTD_PATH;

void WriteFile(const std::string &path, const std::string &contents) {
  std::ofstream(path, std::ios::binary) << contents;
}

bool BitEqual(const std::vector<float> &a, const std::vector<float> &b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

struct RunResult {
  int exit_code = -1;
  std::string out;
  std::string err;
};

RunResult RunProcess(const TempDir &dir, const std::vector<std::string> &args) {
  static int serial = 0;
  const std::string out = dir.File("run" + std::to_string(serial) + ".out");
  const std::string err = dir.File("run" + std::to_string(serial++) + ".err");
  const pid_t pid = Spawn(args, out, err);
  int status = 0;
  waitpid(pid, &status, 0);
  RunResult r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  r.out = ReadFile(out);
  r.err = ReadFile(err);
  return r;
}

std::string Describe(const RunResult &r) {
  return "exit " + std::to_string(r.exit_code) + "\nstdout:\n" + r.out + "\nstderr:\n" + r.err;
}

// ---- Output readers, independent of the library's writers -----------------------------------

std::vector<float> ReadRadianceCsv(const std::string &path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "r,g,b") << path;
  std::vector<float> out;
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) out.push_back(std::strtof(cell.c_str(), nullptr));
  }
  return out;
}

// Minimal .npy v1.0 reader for '<f4' (N, 3) arrays; checks the header on the way.
std::vector<float> ReadRadianceNpy(const std::string &path, uint64_t expected_rows) {
  const std::string bytes = ReadFile(path);
  EXPECT_EQ(bytes.substr(0, 8), std::string("\x93NUMPY\x01\x00", 8)) << path;
  if (bytes.size() < 10) return {};
  const size_t header_len =
      static_cast<uint8_t>(bytes[8]) | (static_cast<size_t>(static_cast<uint8_t>(bytes[9])) << 8);
  const std::string header = bytes.substr(10, header_len);
  EXPECT_NE(header.find("'descr': '<f4'"), std::string::npos) << header;
  EXPECT_NE(header.find("'fortran_order': False"), std::string::npos) << header;
  EXPECT_NE(header.find("'shape': (" + std::to_string(expected_rows) + ", 3)"), std::string::npos)
      << header;
  std::vector<float> out((bytes.size() - 10 - header_len) / 4);
  for (size_t i = 0; i < out.size(); ++i) {
    uint32_t bits = 0;
    for (int b = 0; b < 4; ++b) {
      bits |= static_cast<uint32_t>(static_cast<uint8_t>(bytes[10 + header_len + 4 * i + b]))
              << (8 * b);
    }
    std::memcpy(&out[i], &bits, sizeof bits);
  }
  return out;
}

// R, G, B of an EXR as float, read with OpenEXR directly (not glint_preview's reader).
std::vector<float> ReadExr(const std::string &path, int *width, int *height) {
  Imf::InputFile file(path.c_str());
  const Imath::Box2i dw = file.header().dataWindow();
  *width = dw.max.x - dw.min.x + 1;
  *height = dw.max.y - dw.min.y + 1;
  std::vector<float> rgb(static_cast<size_t>(*width) * static_cast<size_t>(*height) * 3);
  Imf::FrameBuffer fb;
  const size_t xs = 3 * sizeof(float);
  const size_t ys = xs * static_cast<size_t>(*width);
  char *base = reinterpret_cast<char *>(rgb.data()) -
               (static_cast<ptrdiff_t>(dw.min.x) * static_cast<ptrdiff_t>(xs)) -
               (static_cast<ptrdiff_t>(dw.min.y) * static_cast<ptrdiff_t>(ys));
  const char *names[3] = {"R", "G", "B"};
  for (int c = 0; c < 3; ++c) {
    EXPECT_NE(file.header().channels().findChannel(names[c]), nullptr) << path << " " << names[c];
    fb.insert(names[c], Imf::Slice(Imf::FLOAT, base + c * sizeof(float), xs, ys));
  }
  file.setFrameBuffer(fb);
  file.readPixels(dw.min.y, dw.max.y);
  return rgb;
}

// ---- Inputs ---------------------------------------------------------------------------------

struct Lcg {
  uint64_t state;
  double Next() {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<double>(state >> 11) / 9007199254740992.0;
  }
};

// A unit direction in the upper hemisphere, at least ~6 deg above the horizon.
void Direction(Lcg &rng, double out[3]) {
  const double cos_theta = 0.1 + 0.9 * rng.Next();
  const double phi = 6.283185307179586 * rng.Next();
  const double sin_theta = std::sqrt(1.0 - cos_theta * cos_theta);
  out[0] = sin_theta * std::cos(phi);
  out[1] = sin_theta * std::sin(phi);
  out[2] = cos_theta;
}

// `count` queries; BRDF probes (with wi) or lit queries (wo only). Columns in a deliberately
// unusual order. nan_at >= 0 puts NaN into that query's wox.
std::string QueriesCsv(int count, bool probes, uint64_t seed, int nan_at = -1) {
  Lcg rng{seed};
  std::string csv =
      probes ? "wiz,wix,wiy,u,v,dudx,dvdx,dudy,dvdy,wox,woy,woz\n" : "u,v,wox,woy,woz\n";
  char line[512];
  for (int i = 0; i < count; ++i) {
    double wo[3];
    double wi[3];
    Direction(rng, wo);
    Direction(rng, wi);
    const double u = rng.Next() * 10.0;
    const double v = rng.Next() * 10.0;
    char wox[32];
    std::snprintf(wox, sizeof wox, "%.9g", wo[0]);
    if (i == nan_at) std::snprintf(wox, sizeof wox, "nan");
    if (probes) {
      std::snprintf(line, sizeof line, "%.9g,%.9g,%.9g,%.9g,%.9g,1e-3,0,0,1e-3,%s,%.9g,%.9g\n",
                    wi[2], wi[0], wi[1], u, v, wox, wo[1], wo[2]);
    } else {
      std::snprintf(line, sizeof line, "%.9g,%.9g,%s,%.9g,%.9g\n", u, v, wox, wo[1], wo[2]);
    }
    csv += line;
  }
  return csv;
}

constexpr const char *kMaterial =
    R"({"model": "SMOOTH", "ndf": "GGX", "alpha_x": 0.3, "alpha_y": 0.1,
        "schlick": {"f0": [0.9, 0.6, 0.3]}})";
constexpr const char *kLights =
    R"({"lights": [{"directional": {"direction": [0, 0.5, 0.866], "irradiance": [1, 1, 1],
                                    "cone_half_angle_deg": 0.26}},
                   {"point": {"position": [0, 1, 2], "intensity": [5, 5, 5], "radius": 0}}]})";

// ---- CLI alone ------------------------------------------------------------------------------

class Cli : public ::testing::Test {
 protected:
  TempDir dir_;
};

TEST_F(Cli, HelpAndUsageErrors) {
  const RunResult help = RunProcess(dir_, {kGlint, "--help"});
  EXPECT_EQ(help.exit_code, 0);
  for (const char *command : {"info", "eval", "preview"}) {
    EXPECT_NE(help.out.find(command), std::string::npos) << help.out;
  }
  const RunResult eval_help = RunProcess(dir_, {kGlint, "eval", "--help"});
  EXPECT_EQ(eval_help.exit_code, 0);
  EXPECT_NE(eval_help.out.find("--queries"), std::string::npos) << eval_help.out;

  const RunResult none = RunProcess(dir_, {kGlint});
  EXPECT_EQ(none.exit_code, 2);
  const RunResult unknown = RunProcess(dir_, {kGlint, "frobnicate"});
  EXPECT_EQ(unknown.exit_code, 2);
  EXPECT_NE(unknown.err.find("unknown command 'frobnicate'"), std::string::npos) << unknown.err;
  const RunResult bad_option = RunProcess(dir_, {kGlint, "info", "--server", "x", "--colour"});
  EXPECT_EQ(bad_option.exit_code, 2);
  EXPECT_NE(bad_option.err.find("--colour"), std::string::npos) << bad_option.err;
  const RunResult missing = RunProcess(dir_, {kGlint, "eval", "--server", "127.0.0.1:1"});
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.err.find("missing --material"), std::string::npos) << missing.err;
}

TEST_F(Cli, LocalInputErrorsNameFileLineAndColumn) {
  WriteFile(dir_.File("m.json"), kMaterial);
  WriteFile(dir_.File("q.csv"), "wox,woy,woz\n0,0,1\n0,zero,1\n");
  const RunResult r = RunProcess(
      dir_, {kGlint, "eval", "--server", "127.0.0.1:1", "--material", dir_.File("m.json"),
             "--queries", dir_.File("q.csv"), "--out", dir_.File("o.csv")});
  EXPECT_EQ(r.exit_code, 1) << Describe(r);
  EXPECT_NE(r.err.find(dir_.File("q.csv") + ":3, column 'woy'"), std::string::npos) << r.err;

  WriteFile(dir_.File("bad.json"), R"({"model": "SMOOTH", "alpha": 1})");
  const RunResult j = RunProcess(
      dir_, {kGlint, "eval", "--server", "127.0.0.1:1", "--material", dir_.File("bad.json"),
             "--queries", dir_.File("q.csv"), "--out", dir_.File("o.csv")});
  EXPECT_EQ(j.exit_code, 1) << Describe(j);
  EXPECT_NE(j.err.find(dir_.File("bad.json")), std::string::npos) << j.err;

  const RunResult ext = RunProcess(
      dir_, {kGlint, "eval", "--server", "127.0.0.1:1", "--material", dir_.File("m.json"),
             "--queries", dir_.File("q.csv"), "--out", dir_.File("o.txt")});
  EXPECT_EQ(ext.exit_code, 2) << Describe(ext);
  const RunResult width = RunProcess(
      dir_, {kGlint, "eval", "--server", "127.0.0.1:1", "--material", dir_.File("m.json"),
             "--queries", dir_.File("q.csv"), "--out", dir_.File("o.csv"), "--width", "4"});
  EXPECT_EQ(width.exit_code, 2) << Describe(width);
}

TEST_F(Cli, UnreachableServerFailsWithReason) {
  // Port 1 on loopback: nothing listens there in a test sandbox.
  const RunResult info =
      RunProcess(dir_, {kGlint, "info", "--server", "127.0.0.1:1", "--timeout-ms", "300"});
  EXPECT_EQ(info.exit_code, 1) << Describe(info);
  EXPECT_NE(info.err.find("UNAVAILABLE"), std::string::npos) << info.err;

  WriteFile(dir_.File("m.json"), kMaterial);
  WriteFile(dir_.File("q.csv"), "wox,woy,woz\n0,0,1\n");
  const RunResult eval = RunProcess(
      dir_, {kGlint, "eval", "--server", "127.0.0.1:1", "--material", dir_.File("m.json"),
             "--queries", dir_.File("q.csv"), "--out", dir_.File("o.csv")});
  EXPECT_EQ(eval.exit_code, 1) << Describe(eval);
  EXPECT_NE(eval.err.find("UNAVAILABLE"), std::string::npos) << eval.err;
  EXPECT_FALSE(fs::exists(dir_.File("o.csv")));
}

// ---- CLI against glintd ---------------------------------------------------------------------

class CliEndToEnd : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (kGlintd.empty() || !fs::exists(kGlintd)) return;  // SetUp reports it
    dir_ = new TempDir;
    std::string error;
    unary_server_ = Glintd::Start(kGlintd, *dir_, "default", {}, &error).release();
    if (unary_server_ != nullptr) {
      stream_server_ =
          Glintd::Start(kGlintd, *dir_, "small", {"--max-batch", "256"}, &error).release();
    }
    start_error_ = new std::string(error);
  }
  static void TearDownTestSuite() {
    // Servers first (their logs live in dir_).
    delete stream_server_;
    delete unary_server_;
    delete start_error_;
    delete dir_;
    stream_server_ = unary_server_ = nullptr;
    start_error_ = nullptr;
    dir_ = nullptr;
  }

  void SetUp() override {
    // Without a glintd target CMake does not register this suite with ctest at all; a direct run
    // says why. A target whose binary is missing is a failure, not a skip.
    if (kGlintd.empty()) GTEST_SKIP() << "glintd is not built (no target)";
    ASSERT_TRUE(fs::exists(kGlintd)) << kGlintd;
    ASSERT_NE(stream_server_, nullptr) << *start_error_;
  }

  // Runs glint eval and returns its result; common flags filled in.
  RunResult Eval(const Glintd &server, const std::string &queries, const std::string &out,
                 bool lights, std::vector<std::string> extra = {}) {
    WriteFile(dir_->File("m.json"), kMaterial);
    WriteFile(dir_->File("l.json"), kLights);
    if (lights) {
      extra.insert(extra.begin(), dir_->File("l.json"));
      extra.insert(extra.begin(), "--lights");
    }
    return EvalWith(server, dir_->File("m.json"), queries, out, extra);
  }

  // glint eval with a given material file; `extra` carries --lights and any other flags.
  RunResult EvalWith(const Glintd &server, const std::string &material, const std::string &queries,
                     const std::string &out, const std::vector<std::string> &extra) {
    std::vector<std::string> args = {kGlint,       "eval",   "--server",  server.address(),
                                     "--material", material, "--queries", queries,
                                     "--out",      out};
    args.insert(args.end(), extra.begin(), extra.end());
    // The arrays over the connection unless the test picks a transport (the summary lines
    // checked here name unary and stream transports; loopback would default to shared memory).
    if (std::find(extra.begin(), extra.end(), "--transport") == extra.end())
      args.insert(args.end(), {"--transport", "tcp"});
    return RunProcess(*dir_, args);
  }

  // Evaluates `csv` on both servers into CSV, NPY and EXR; checks everything agrees and
  // returns the radiance.
  std::vector<float> EvaluateEverywhere(const std::string &name, const std::string &csv, int count,
                                        bool lights) {
    const std::string queries = dir_->File(name + ".csv");
    WriteFile(queries, csv);
    std::vector<float> reference;
    for (const Glintd *server : {unary_server_, stream_server_}) {
      const bool streamed = server == stream_server_;
      const std::string stem = dir_->File(name + (streamed ? "_stream" : "_unary"));
      std::vector<std::vector<float>> outputs;
      for (const char *ext : {".csv", ".npy", ".exr"}) {
        const RunResult r = Eval(*server, queries, stem + ext, lights);
        EXPECT_EQ(r.exit_code, 0) << Describe(r);
        // Summary line: the count, and the transport the library chose.
        EXPECT_NE(r.out.find(std::to_string(count) + " queries"), std::string::npos) << r.out;
        EXPECT_NE(r.out.find(streamed ? "via stream" : "via unary"), std::string::npos) << r.out;
        EXPECT_NE(r.out.find(stem + ext), std::string::npos) << r.out;
        EXPECT_TRUE(r.err.empty()) << "stderr is not a terminal: no progress bar\n" << r.err;
      }
      outputs.push_back(ReadRadianceCsv(stem + ".csv"));
      outputs.push_back(ReadRadianceNpy(stem + ".npy", static_cast<uint64_t>(count)));
      int w = 0;
      int h = 0;
      outputs.push_back(ReadExr(stem + ".exr", &w, &h));
      EXPECT_EQ(w, count);
      EXPECT_EQ(h, 1);
      EXPECT_EQ(outputs[0].size(), static_cast<size_t>(count) * 3);
      EXPECT_TRUE(BitEqual(outputs[0], outputs[1])) << "CSV and NPY differ for " << stem;
      EXPECT_TRUE(BitEqual(outputs[0], outputs[2])) << "CSV and EXR differ for " << stem;
      if (reference.empty()) {
        reference = outputs[0];
      } else {
        // Determinism contract: chunking must not change a single bit.
        EXPECT_TRUE(BitEqual(reference, outputs[0])) << "streamed result differs from unary";
      }
    }
    // Sanity: finite, non-negative and not trivially zero.
    size_t non_zero = 0;
    for (float v : reference) {
      EXPECT_TRUE(std::isfinite(v) && v >= 0.0f) << v;
      non_zero += v > 0.0f;
    }
    EXPECT_GT(non_zero, reference.size() / 4);
    return reference;
  }

  static TempDir *dir_;
  static Glintd *unary_server_;
  static Glintd *stream_server_;
  static std::string *start_error_;
};

TempDir *CliEndToEnd::dir_ = nullptr;
Glintd *CliEndToEnd::unary_server_ = nullptr;
Glintd *CliEndToEnd::stream_server_ = nullptr;
std::string *CliEndToEnd::start_error_ = nullptr;

// --transport shm and auto on a loopback server: the shared-memory path (client/lib/
// shm_transport.h), several calls on the small server, bit-identical to the arrays over TCP.
TEST_F(CliEndToEnd, SharedMemoryTransportMatchesTcp) {
  const int count = 600;  // 3 calls of 256 on the small server
  WriteFile(dir_->File("shm.csv"), QueriesCsv(count, true, 4));
  std::vector<std::vector<float>> results;
  for (const char *transport : {"tcp", "shm", "auto"}) {
    const std::string out = dir_->File(std::string("shm_") + transport + ".npy");
    const RunResult r =
        Eval(*stream_server_, dir_->File("shm.csv"), out, false, {"--transport", transport});
    ASSERT_EQ(r.exit_code, 0) << Describe(r);
    if (std::string(transport) != "tcp") {
      EXPECT_NE(r.out.find("via shared memory (3 calls of <= 256 queries)"), std::string::npos)
          << r.out;
    }
    results.push_back(ReadRadianceNpy(out, count));
  }
  EXPECT_TRUE(BitEqual(results[0], results[1])) << "shared memory differs from tcp";
  EXPECT_TRUE(BitEqual(results[0], results[2]));
  const RunResult bad = Eval(*stream_server_, dir_->File("shm.csv"), dir_->File("x.npy"), false,
                             {"--transport", "udp"});
  EXPECT_EQ(bad.exit_code, 2) << Describe(bad);
  EXPECT_NE(bad.err.find("--transport udp"), std::string::npos) << bad.err;
}

TEST_F(CliEndToEnd, InfoReportsServingAndLimits) {
  const RunResult r = RunProcess(*dir_, {kGlint, "info", "--server", stream_server_->address()});
  EXPECT_EQ(r.exit_code, 0) << Describe(r);
  EXPECT_NE(r.out.find("SERVING"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("max batch        256 "), std::string::npos) << r.out;
  // The admission settings GetCapabilities reports (glintd's defaults on this server); they
  // were documented as shown by `glint info` but not printed.
  EXPECT_NE(r.out.find("cost limits      1e+11 per request, 1e+07 per query"), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("query slices     50 ms"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("batching         off"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("shared memory    16 regions, 4096 MiB per owner"), std::string::npos)
      << r.out;
}

TEST_F(CliEndToEnd, ProbesAgreeAcrossFormatsAndTransports) {
  const int count = 3000;  // 12 chunks of 256 on the small server
  const std::vector<float> rgb =
      EvaluateEverywhere("probes", QueriesCsv(count, true, 1), count, false);

  // A unary-sized prefix on the small server gives the same values as inside the big batch.
  const std::string full = QueriesCsv(count, true, 1);
  size_t end = 0;
  for (int lines = 0; lines < 1 + 100; ++lines) end = full.find('\n', end) + 1;
  WriteFile(dir_->File("prefix.csv"), full.substr(0, end));
  const RunResult r =
      Eval(*stream_server_, dir_->File("prefix.csv"), dir_->File("prefix.npy"), false);
  ASSERT_EQ(r.exit_code, 0) << Describe(r);
  EXPECT_NE(r.out.find("via unary"), std::string::npos) << r.out;
  const std::vector<float> prefix = ReadRadianceNpy(dir_->File("prefix.npy"), 100);
  ASSERT_EQ(prefix.size(), 300u);
  EXPECT_TRUE(BitEqual(prefix, std::vector<float>(rgb.begin(), rgb.begin() + 300)));
}

TEST_F(CliEndToEnd, LitQueriesAgreeAcrossFormatsAndTransports) {
  const int count = 1000;
  EvaluateEverywhere("lit", QueriesCsv(count, false, 2), count, true);
}

TEST_F(CliEndToEnd, ExrWidthAndHalf) {
  const int count = 1000;
  WriteFile(dir_->File("q.csv"), QueriesCsv(count, true, 3));
  RunResult r = Eval(*unary_server_, dir_->File("q.csv"), dir_->File("q.npy"), false);
  ASSERT_EQ(r.exit_code, 0) << Describe(r);
  const std::vector<float> rgb = ReadRadianceNpy(dir_->File("q.npy"), count);

  r = Eval(*stream_server_, dir_->File("q.csv"), dir_->File("w.exr"), false, {"--width", "64"});
  ASSERT_EQ(r.exit_code, 0) << Describe(r);
  int w = 0;
  int h = 0;
  const std::vector<float> image = ReadExr(dir_->File("w.exr"), &w, &h);
  EXPECT_EQ(w, 64);
  EXPECT_EQ(h, (count + 63) / 64);
  ASSERT_EQ(image.size(), static_cast<size_t>(w * h * 3));
  EXPECT_TRUE(BitEqual(std::vector<float>(image.begin(), image.begin() + count * 3), rgb));
  for (size_t i = static_cast<size_t>(count) * 3; i < image.size(); ++i) EXPECT_EQ(image[i], 0.0f);

  r = Eval(*unary_server_, dir_->File("q.csv"), dir_->File("h.exr"), false, {"--half"});
  ASSERT_EQ(r.exit_code, 0) << Describe(r);
  const std::vector<float> half = ReadExr(dir_->File("h.exr"), &w, &h);
  ASSERT_EQ(half.size(), rgb.size());
  for (size_t i = 0; i < rgb.size(); ++i) {
    // Half keeps 11 significant bits: relative error <= 2^-11, plus the subnormal step.
    EXPECT_NEAR(half[i], rgb[i], std::fabs(rgb[i]) * 4.9e-4 + 6e-8) << i;
  }
  EXPECT_FALSE(BitEqual(half, rgb)) << "--half should store half floats";
}

TEST_F(CliEndToEnd, ServerRefusalsNameStatusFieldAndQuery) {
  // NaN in query 1234 of a streamed batch: the server names the field and the global index.
  WriteFile(dir_->File("nan.csv"), QueriesCsv(2000, true, 4, 1234));
  RunResult r = Eval(*stream_server_, dir_->File("nan.csv"), dir_->File("nan.csv.out.csv"), false);
  EXPECT_EQ(r.exit_code, 1) << Describe(r);
  EXPECT_NE(r.err.find("INVALID_ARGUMENT"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("wo"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("1234"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_->File("nan.csv.out.csv")));

  // A material without a model.
  WriteFile(dir_->File("q.csv"), QueriesCsv(10, true, 5));
  WriteFile(dir_->File("empty.json"), "{}");
  r = RunProcess(*dir_, {kGlint, "eval", "--server", unary_server_->address(), "--material",
                         dir_->File("empty.json"), "--queries", dir_->File("q.csv"), "--out",
                         dir_->File("e.csv")});
  EXPECT_EQ(r.exit_code, 1) << Describe(r);
  EXPECT_NE(r.err.find("INVALID_ARGUMENT"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("material"), std::string::npos) << r.err;
}

TEST_F(CliEndToEnd, PreviewWritesExrAndPngAlikeForBothTransports) {
  WriteFile(dir_->File("m.json"), kMaterial);
  WriteFile(dir_->File("l.json"), kLights);
  std::vector<std::vector<float>> images;
  for (const Glintd *server : {unary_server_, stream_server_}) {
    const std::string out =
        dir_->File(server == stream_server_ ? "preview_stream.exr" : "preview_unary.exr");
    const RunResult r =
        RunProcess(*dir_, {kGlint, "preview", "--server", server->address(), "--material",
                           dir_->File("m.json"), "--lights", dir_->File("l.json"), "--scene",
                           "sphere", "--size", "64x48", "--out", out, "--exposure", "1"});
    ASSERT_EQ(r.exit_code, 0) << Describe(r);
    const std::string png = out.substr(0, out.size() - 4) + ".png";
    EXPECT_NE(r.out.find(out), std::string::npos) << r.out;
    EXPECT_NE(r.out.find(png), std::string::npos) << r.out;
    EXPECT_EQ(ReadFile(png).substr(0, 8), "\x89PNG\r\n\x1a\n");
    int w = 0;
    int h = 0;
    images.push_back(ReadExr(out, &w, &h));
    EXPECT_EQ(w, 64);
    EXPECT_EQ(h, 48);
  }
  EXPECT_TRUE(BitEqual(images[0], images[1]));
  // Background pixels are zero and the sphere is lit somewhere.
  size_t lit = 0;
  for (size_t i = 0; i < images[0].size(); i += 3) lit += images[0][i] > 0.0f;
  EXPECT_GT(lit, 0u);
  EXPECT_LT(lit, images[0].size() / 3);
}

// ---- The binomial glint model through the CLI ------------------------------------------------

// A BINOMIAL material and the SMOOTH one it converges to (KK24: E[L] = L_smooth), under a 1 deg
// sun: N_P = 3e8 x (1e-3)^2 = 300 facets per footprint, about a fifth of the footprints lit.
constexpr const char *kBinomialMaterial =
    R"({"model": "BINOMIAL", "ndf": "GGX", "alpha_x": 0.3, "alpha_y": 0.3,
        "schlick": {"f0": [1.0, 0.8, 0.6]},
        "binomial": {"density": 3e8, "p_mode": "AREA"}})";
constexpr const char *kBinomialAsSmooth =
    R"({"model": "SMOOTH", "ndf": "GGX", "alpha_x": 0.3, "alpha_y": 0.3,
        "schlick": {"f0": [1.0, 0.8, 0.6]}})";
constexpr const char *kSunLights =
    R"({"lights": [{"directional": {"direction": [0.5, 0, 0.8660254], "irradiance": [1, 1, 1],
                                    "cone_half_angle_deg": 1.0}}]})";

// `count` footprints 1e-3 wide at uv spread over [0, 1000)^2 (each in its own facet cells), one
// view: the smooth radiance is the same for all of them.
std::string FootprintCsv(int count, uint64_t seed) {
  Lcg rng{seed};
  std::string csv = "u,v,dudx,dvdx,dudy,dvdy,wox,woy,woz\n";
  const double len = std::sqrt(0.4 * 0.4 + 0.1 * 0.1 + 0.9 * 0.9);
  char line[256];
  for (int i = 0; i < count; ++i) {
    const double u = 1000.0 * rng.Next();
    const double v = 1000.0 * rng.Next();
    std::snprintf(line, sizeof line, "%.9g,%.9g,1e-3,0,0,1e-3,%.9g,%.9g,%.9g\n", u, v, -0.4 / len,
                  0.1 / len, 0.9 / len);
    csv += line;
  }
  return csv;
}

// glint eval with a BINOMIAL material: unary and streamed results are bit-identical, --seed
// reaches the server (another seed, another pattern), and the mean over 20000 independent
// footprints matches the SMOOTH model within 4 standard errors of the mean.
TEST_F(CliEndToEnd, BinomialEvalIsUnbiasedAndFollowsTheSeed) {
  const int count = 20000;
  WriteFile(dir_->File("binomial.json"), kBinomialMaterial);
  WriteFile(dir_->File("binomial_smooth.json"), kBinomialAsSmooth);
  WriteFile(dir_->File("sun1.json"), kSunLights);
  WriteFile(dir_->File("footprints.csv"), FootprintCsv(count, 9));
  const std::vector<std::string> lights = {"--lights", dir_->File("sun1.json")};
  auto eval = [&](const Glintd &server, const std::string &material, const std::string &out,
                  const std::string &seed) {
    std::vector<std::string> extra = lights;
    extra.insert(extra.end(), {"--seed", seed});
    const RunResult r = EvalWith(server, material, dir_->File("footprints.csv"), out, extra);
    EXPECT_EQ(r.exit_code, 0) << Describe(r);
    return ReadRadianceNpy(out, count);
  };
  const std::vector<float> unary =
      eval(*unary_server_, dir_->File("binomial.json"), dir_->File("b_unary.npy"), "7");
  const std::vector<float> streamed =
      eval(*stream_server_, dir_->File("binomial.json"), dir_->File("b_stream.npy"), "7");
  const std::vector<float> reseeded =
      eval(*unary_server_, dir_->File("binomial.json"), dir_->File("b_seed8.npy"), "8");
  const std::vector<float> smooth =
      eval(*unary_server_, dir_->File("binomial_smooth.json"), dir_->File("s.npy"), "7");
  ASSERT_EQ(unary.size(), size_t(3 * count));
  ASSERT_EQ(reseeded.size(), unary.size());
  ASSERT_EQ(smooth.size(), unary.size());
  EXPECT_TRUE(BitEqual(unary, streamed)) << "chunking changed the glint pattern";

  int differ = 0, lit_either = 0;
  for (size_t i = 0; i < unary.size(); ++i) {
    differ += unary[i] != reseeded[i];
    lit_either += unary[i] > 0.0f || reseeded[i] > 0.0f;
  }
  // Independent patterns lit at a fifth of the footprints each overlap on ~1/9 of the lit ones.
  EXPECT_GT(differ, lit_either / 2) << lit_either << " values lit under either seed";

  for (int c = 0; c < 3; ++c) {
    const double l_smooth = smooth[size_t(c)];
    ASSERT_GT(l_smooth, 0.0);
    double sum = 0, sum_sq = 0;
    int lit = 0;
    for (int i = 0; i < count; ++i) {
      const double v = unary[size_t(3 * i + c)];
      ASSERT_TRUE(std::isfinite(v) && v >= 0.0) << v;
      ASSERT_EQ(smooth[size_t(3 * i + c)], smooth[size_t(c)]) << "one view: one smooth value";
      sum += v;
      sum_sq += v * v;
      lit += v > 0.0;
    }
    const double mean = sum / count;
    const double se = std::sqrt((sum_sq / count - mean * mean) / (count - 1));
    std::printf("glint eval BINOMIAL channel %d: smooth %.5g, mean %.5g +- %.2g, %.3f lit\n", c,
                l_smooth, mean, se, double(lit) / count);
    EXPECT_NEAR(mean, l_smooth, 4 * se) << "channel " << c;
    EXPECT_LT(lit, count * 95 / 100) << "glints expected, not a smooth field";
    EXPECT_GT(lit, 100);
  }
}

// glint preview of the shipped binomial example (examples/materials/sparkle_binomial.json under
// examples/lights/rect_small.json, as scripts/demo.sh renders it): both transports give the same
// image, --seed changes the pattern, and it is glints: the count of reflecting facets varies per
// pixel around its mean, so the image is black wherever the smooth model is (no facet reflects
// where the lobe does not reach) and elsewhere some pixels are brighter than the smooth model and
// some dimmer (KK24 Eq. 16: L = L_smooth b / (N_P p) with b binomial).
TEST_F(CliEndToEnd, BinomialPreviewOfTheShippedExampleRendersGlints) {
  const std::string material = std::string(GLINT_EXAMPLES_DIR) + "/materials/sparkle_binomial.json";
  const std::string lights = std::string(GLINT_EXAMPLES_DIR) + "/lights/rect_small.json";
  const std::string smooth_material = dir_->File("sparkle_smooth.json");
  {
    std::string json = ReadFile(material);
    const size_t at = json.find("\"BINOMIAL\"");
    ASSERT_NE(at, std::string::npos) << json;
    json.replace(at, 10, "\"SMOOTH\"");
    const size_t b = json.find(",\n \"binomial\"");
    ASSERT_NE(b, std::string::npos) << json;
    json = json.substr(0, b) + "}";
    WriteFile(smooth_material, json);
  }
  auto preview = [&](const Glintd &server, const std::string &m, const std::string &name,
                     const char *seed = "1") {
    const std::string out = dir_->File(name + ".exr");
    const RunResult r = RunProcess(
        *dir_, {kGlint, "preview", "--server", server.address(), "--material", m, "--lights",
                lights, "--scene", "plane", "--size", "160x90", "--seed", seed, "--out", out});
    EXPECT_EQ(r.exit_code, 0) << Describe(r);
    EXPECT_EQ(ReadFile(dir_->File(name + ".png")).substr(0, 8), "\x89PNG\r\n\x1a\n");
    int w = 0;
    int h = 0;
    std::vector<float> rgb = ReadExr(out, &w, &h);
    EXPECT_EQ(w, 160);
    EXPECT_EQ(h, 90);
    return rgb;
  };
  const std::vector<float> glints = preview(*unary_server_, material, "glints_unary");
  const std::vector<float> streamed = preview(*stream_server_, material, "glints_stream");
  const std::vector<float> reseeded = preview(*unary_server_, material, "glints_seed2", "2");
  const std::vector<float> smooth = preview(*unary_server_, smooth_material, "glints_smooth");
  ASSERT_EQ(glints.size(), smooth.size());
  EXPECT_TRUE(BitEqual(glints, streamed)) << "the glint pattern depends on the transport";
  EXPECT_FALSE(BitEqual(glints, reseeded)) << "--seed did not reach the server";
  size_t lit = 0, smooth_lit = 0, brighter = 0, dimmer = 0;
  for (size_t i = 0; i < glints.size(); ++i) {
    ASSERT_TRUE(std::isfinite(glints[i]) && glints[i] >= 0.0f) << glints[i];
    const bool g = glints[i] > 0.0f, s = smooth[i] > 0.0f;
    EXPECT_TRUE(!g || s) << "value " << i << " glints where the smooth model is black";
    lit += g;
    smooth_lit += s;
    brighter += glints[i] > smooth[i];
    dimmer += glints[i] < smooth[i];
  }
  std::printf(
      "preview sparkle_binomial under rect_small, 160x90 RGB values: %zu lit (smooth %zu), "
      "%zu brighter and %zu dimmer than the smooth model\n",
      lit, smooth_lit, brighter, dimmer);
  EXPECT_GT(brighter, smooth_lit / 100);
  EXPECT_GT(dimmer, smooth_lit / 100);
}

}  // namespace
