// glint render and batch previews as a user runs them. RenderCli.* needs only the glint binary
// (malformed G-buffers are refused before any connection); RenderEndToEnd.* starts two glintd:
// one with the default batch limit (previews of this size go unary) and one with --max-batch
// 256 (renders and batches are streamed in many chunks).
//   - render of a preview's own G-buffer (--gbuffer-out) equals the preview bit for bit;
//   - render of an analytic G-buffer the test builds (tests/support/analytic_gbuffer.h) equals,
//     pixel for pixel and bit for bit, `glint eval` of the queries the test derives itself from
//     the documented rules (wo from --camera, central / one-sided uv differences);
//   - a batch of two materials writes the same EXR and PNG as two single previews, and a
//     contact sheet of the documented size whose tiles are those PNGs; a batch skips the
//     materials it cannot render, renders the others and lists the skipped ones with why;
//   - a streamed preview keeps --area-method (it used to fall back to LTC).
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <gtest/gtest.h>
#include <png.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "analytic_gbuffer.h"
#include "glintd_process.h"

#ifndef GLINT_CLI_PATH
#error "GLINT_CLI_PATH must name the glint executable"
#endif
#ifndef GLINTD_PATH
#define GLINTD_PATH ""
#endif

namespace {

namespace fs = std::filesystem;
using namespace glint::test;

const std::string kGlint = GLINT_CLI_PATH;
const std::string kGlintd = GLINTD_PATH;
const std::string kExamples = GLINT_EXAMPLES_DIR;

struct RunResult {
  int exit_code = -1;
  std::string out, err;
};

RunResult RunGlint(const TempDir &dir, const std::vector<std::string> &args) {
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

// Named float channels of an EXR, read with OpenEXR directly; missing ones are reported.
std::map<std::string, std::vector<float>> ReadChannels(const std::string &path,
                                                       const std::vector<std::string> &names,
                                                       int *w, int *h) {
  Imf::InputFile file(path.c_str());
  const Imath::Box2i dw = file.header().dataWindow();
  *w = dw.max.x - dw.min.x + 1;
  *h = dw.max.y - dw.min.y + 1;
  std::map<std::string, std::vector<float>> out;
  Imf::FrameBuffer fb;
  for (const auto &n : names) {
    EXPECT_NE(file.header().channels().findChannel(n), nullptr) << path << " lacks " << n;
    if (file.header().channels().findChannel(n) == nullptr) continue;
    auto &plane = out[n];
    plane.assign(static_cast<size_t>(*w) * *h, 0.0f);
    fb.insert(n, Imf::Slice::Make(Imf::FLOAT, plane.data(), dw, sizeof(float),
                                  sizeof(float) * static_cast<size_t>(*w)));
  }
  file.setFrameBuffer(fb);
  file.readPixels(dw.min.y, dw.max.y);
  return out;
}

bool BitEqual(const std::vector<float> &a, const std::vector<float> &b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

// 8-bit RGB of a PNG via libpng's simplified API.
std::vector<uint8_t> ReadPng(const std::string &path, int *w, int *h) {
  png_image image;
  std::memset(&image, 0, sizeof image);
  image.version = PNG_IMAGE_VERSION;
  if (png_image_begin_read_from_file(&image, path.c_str()) == 0) {
    ADD_FAILURE() << path << ": " << image.message;
    return {};
  }
  image.format = PNG_FORMAT_RGB;
  std::vector<uint8_t> rgb(PNG_IMAGE_SIZE(image));
  EXPECT_NE(png_image_finish_read(&image, nullptr, rgb.data(), 0, nullptr), 0) << path;
  *w = static_cast<int>(image.width);
  *h = static_cast<int>(image.height);
  return rgb;
}

std::string PngBeside(const std::string &exr) {
  return exr.substr(0, exr.size() - 4) + ".png";
}

void WriteFile(const std::string &path, const std::string &text) {
  std::ofstream(path) << text;
}

// ---- Without a server: malformed G-buffers and usage ---------------------------------------

class RenderCli : public ::testing::Test {
 protected:
  TempDir dir_;
};

// A batch whose server is unreachable stops at its first material instead of trying every
// other one: the summary names that material's failure (UNAVAILABLE) and every later one as not
// attempted, and the exit code is 1.
TEST_F(RenderCli, ABatchStopsAtAFailureThatIsNotTheMaterials) {
  WriteFile(dir_.File("l.json"), R"({"lights": [{"point": {"position": [0, -2, 2],
                                     "intensity": [1, 1, 1]}}]})");
  for (const char *stem : {"a", "b", "c"})
    WriteFile(dir_.File(std::string(stem) + ".json"),
              R"({"model": "SMOOTH", "ndf": "GGX", "alpha_x": 0.3, "alpha_y": 0.3,
                  "schlick": {"f0": [0.9, 0.9, 0.9]}})");
  const RunResult r = RunGlint(
      dir_, {kGlint, "preview", "--server", "127.0.0.1:1", "--material", dir_.File("a.json"),
             "--material", dir_.File("b.json"), "--material", dir_.File("c.json"), "--lights",
             dir_.File("l.json"), "--out", dir_.File("p.exr"), "--size", "16x12"});
  EXPECT_EQ(r.exit_code, 1) << Describe(r);
  EXPECT_NE(r.err.find("3 of 3 materials not rendered:"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("  a (" + dir_.File("a.json") + "): failed: UNAVAILABLE"), std::string::npos)
      << r.err;
  for (const char *stem : {"b", "c"})
    EXPECT_NE(r.err.find(std::string("  ") + stem + " (" + dir_.File(std::string(stem) + ".json") +
                         "): not attempted: the batch stopped at a"),
              std::string::npos)
        << r.err;
  EXPECT_FALSE(fs::exists(dir_.File("p_a.exr")));
}

TEST_F(RenderCli, MalformedGBuffersAreRefusedNamingTheFileAndLayer) {
  const Analytic a = BuildAnalytic(PreviewShape::kSphere, 16, 12);
  std::vector<float> alpha(a.covered.begin(), a.covered.end());
  const std::string gb = dir_.File("gb.exr");
  WriteFile(dir_.File("m.json"), R"({"model": "SMOOTH", "ndf": "GGX", "alpha_x": 0.3,
                                     "alpha_y": 0.3, "schlick": {"f0": [0.9, 0.9, 0.9]}})");
  WriteFile(dir_.File("l.json"), R"({"lights": [{"point": {"position": [0, -2, 2],
                                     "intensity": [1, 1, 1]}}]})");
  auto render = [&](std::vector<std::string> extra) {
    std::vector<std::string> args = {
        kGlint,  "render",          "--server",          "127.0.0.1:1", "--gbuffer",
        gb,      "--material",      dir_.File("m.json"), "--lights",    dir_.File("l.json"),
        "--out", dir_.File("b.exr")};
    args.insert(args.end(), extra.begin(), extra.end());
    return RunGlint(dir_, args);
  };
  const std::vector<std::string> camera = {"--camera", "0,-4,1.2"};

  WriteExr(gb, 16, 12, {{{"P.X", "P.Y", "P.Z"}, &a.P}, {{"uv.U", "uv.V"}, &a.uv}, {{"A"}, &alpha}});
  RunResult r = render(camera);
  EXPECT_EQ(r.exit_code, 1) << Describe(r);
  EXPECT_NE(r.err.find(gb + ": no layer 'N' (shading normal)"), std::string::npos) << r.err;

  std::vector<float> bad = a.P;
  size_t covered = 0;
  while (!a.covered[covered]) ++covered;
  bad[3 * covered] = std::nanf("");
  WriteExr(gb, 16, 12,
           {{{"P.X", "P.Y", "P.Z"}, &bad},
            {{"N.X", "N.Y", "N.Z"}, &a.N},
            {{"uv.U", "uv.V"}, &a.uv},
            {{"A"}, &alpha}});
  r = render(camera);
  EXPECT_EQ(r.exit_code, 1) << Describe(r);
  EXPECT_NE(r.err.find(gb + ": layer P.X,P.Y,P.Z: pixel (" + std::to_string(covered % 16) + ", " +
                       std::to_string(covered / 16) + ") is not finite"),
            std::string::npos)
      << r.err;

  WriteExr(gb, 16, 12,
           {{{"P.X", "P.Y", "P.Z"}, &a.P},
            {{"N.X", "N.Y", "N.Z"}, &a.N},
            {{"A"}, &alpha},
            {{"uv.U", "uv.V"}, &a.uv, Imf::FLOAT, 2}});
  r = render(camera);
  EXPECT_EQ(r.exit_code, 1) << Describe(r);
  EXPECT_NE(r.err.find("'uv.U' is subsampled"), std::string::npos) << r.err;

  WriteExr(
      gb, 16, 12,
      {{{"P.X", "P.Y", "P.Z"}, &a.P}, {{"N.X", "N.Y", "N.Z"}, &a.N}, {{"uv.U", "uv.V"}, &a.uv}});
  r = render({});  // neither --camera nor a V layer
  EXPECT_EQ(r.exit_code, 1) << Describe(r);
  EXPECT_NE(r.err.find("no view-vector layer"), std::string::npos) << r.err;

  r = render({"--camera", "0,-4"});
  EXPECT_EQ(r.exit_code, 2) << Describe(r);
  EXPECT_NE(r.err.find("--camera"), std::string::npos) << r.err;
  r = render({"--camera", "0,-4,1", "--channels", "P=Pos,normal=N"});
  EXPECT_EQ(r.exit_code, 2) << Describe(r);
  EXPECT_NE(r.err.find("unknown key 'normal'"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_.File("b.exr")));
}

// ---- Against glintd ------------------------------------------------------------------------

class RenderEndToEnd : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (kGlintd.empty() || !fs::exists(kGlintd)) return;
    dir_ = new TempDir;
    std::string error;
    unary_ = Glintd::Start(kGlintd, *dir_, "default", {}, &error).release();
    if (unary_ != nullptr) {
      stream_ = Glintd::Start(kGlintd, *dir_, "small", {"--max-batch", "256"}, &error).release();
    }
    start_error_ = new std::string(error);
  }
  static void TearDownTestSuite() {
    delete stream_;
    delete unary_;
    delete start_error_;
    delete dir_;
    stream_ = unary_ = nullptr;
    start_error_ = nullptr;
    dir_ = nullptr;
  }
  void SetUp() override {
    if (kGlintd.empty()) GTEST_SKIP() << "glintd is not built";
    ASSERT_NE(stream_, nullptr) << *start_error_;
  }
  static std::string Material(const std::string &name) {
    return kExamples + "/materials/" + name + ".json";
  }
  static std::string Lights(const std::string &name) {
    return kExamples + "/lights/" + name + ".json";
  }

  static TempDir *dir_;
  static Glintd *unary_;
  static Glintd *stream_;
  static std::string *start_error_;
};
TempDir *RenderEndToEnd::dir_ = nullptr;
Glintd *RenderEndToEnd::unary_ = nullptr;
Glintd *RenderEndToEnd::stream_ = nullptr;
std::string *RenderEndToEnd::start_error_ = nullptr;

TEST_F(RenderEndToEnd, RenderOfThePreviewsGBufferEqualsThePreviewBitForBit) {
  // A glinty material (footprint- and frame-dependent) and a smooth one, on both scenes; the
  // preview goes unary, the render streams in chunks of 256.
  for (const std::string scene : {"sphere", "plane"}) {
    for (const std::string material : {"sparkle_binomial", "paint_schlick"}) {
      SCOPED_TRACE(scene + " " + material);
      const std::string pv = dir_->File("pv_" + scene + material + ".exr");
      const std::string gb = dir_->File("gb_" + scene + material + ".exr");
      const std::string beauty = dir_->File("beauty_" + scene + material + ".exr");
      const RunResult p =
          RunGlint(*dir_, {kGlint, "preview", "--server", unary_->address(), "--material",
                           Material(material), "--lights", Lights("sun"), "--out", pv, "--scene",
                           scene, "--size", "96x64", "--gbuffer-out", gb});
      ASSERT_EQ(p.exit_code, 0) << Describe(p);
      const RunResult r = RunGlint(
          *dir_, {kGlint, "render", "--server", stream_->address(), "--gbuffer", gb, "--material",
                  Material(material), "--lights", Lights("sun"), "--out", beauty});
      ASSERT_EQ(r.exit_code, 0) << Describe(r);
      EXPECT_NE(r.out.find("via stream"), std::string::npos) << r.out;
      int w = 0, h = 0, w2 = 0, h2 = 0;
      auto want = ReadChannels(pv, {"R", "G", "B"}, &w, &h);
      auto got = ReadChannels(beauty, {"R", "G", "B", "A"}, &w2, &h2);
      ASSERT_EQ(w2, w);
      ASSERT_EQ(h2, h);
      double sum = 0.0;
      for (const char *c : {"R", "G", "B"}) {
        EXPECT_TRUE(BitEqual(got[c], want[c])) << c;
        for (float v : want[c]) sum += v;
      }
      EXPECT_GT(sum, 0.0) << "an all-black preview compares nothing";
      auto gba = ReadChannels(gb, {"A"}, &w2, &h2);
      EXPECT_TRUE(BitEqual(got["A"], gba["A"])) << "the beauty's A is the G-buffer's";
    }
  }
}

TEST_F(RenderEndToEnd, AnalyticGBufferRendersExactlyWhatEvalReturnsForEachPixelsQuery) {
  const int w = 64, h = 48;
  const Analytic a = BuildAnalytic(PreviewShape::kSphere, w, h);
  std::vector<float> alpha(a.covered.begin(), a.covered.end());
  for (size_t i = 0; i < alpha.size(); ++i) alpha[i] = a.covered[i] ? 0.75f : 0.0f;
  const std::string gb = dir_->File("analytic.exr");
  // Renderer-style names, renamed with --channels.
  WriteExr(gb, w, h,
           {{{"Pworld.R", "Pworld.G", "Pworld.B"}, &a.P},
            {{"N.X", "N.Y", "N.Z"}, &a.N},
            {{"tangentU.x", "tangentU.y", "tangentU.z"}, &a.T},
            {{"st.R", "st.G"}, &a.uv},
            {{"alpha"}, &alpha}});

  // The queries per the documented rules, computed here: one CSV row per covered pixel.
  const V3 eye{kSphereCamera.eye[0], kSphereCamera.eye[1], kSphereCamera.eye[2]};
  std::string csv = "u,v,dudx,dvdx,dudy,dvdy,wox,woy,woz,px,py,pz,nx,ny,nz,tx,ty,tz\n";
  std::vector<size_t> pixels;
  char line[1024];
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      if (!a.covered[i]) continue;
      pixels.push_back(i);
      double dx[2], dy[2];
      ExpectedDerivative(a, x, y, true, dx);
      ExpectedDerivative(a, x, y, false, dy);
      const V3 to_eye = Sub(eye, {a.P[3 * i], a.P[3 * i + 1], a.P[3 * i + 2]});
      const V3 wo = Mul(1.0 / std::sqrt(Dot(to_eye, to_eye)), to_eye);
      std::snprintf(line, sizeof line,
                    "%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,"
                    "%.9g,%.9g,%.9g\n",
                    a.uv[2 * i], a.uv[2 * i + 1], static_cast<float>(dx[0]),
                    static_cast<float>(dx[1]), static_cast<float>(dy[0]), static_cast<float>(dy[1]),
                    static_cast<float>(wo.x), static_cast<float>(wo.y), static_cast<float>(wo.z),
                    a.P[3 * i], a.P[3 * i + 1], a.P[3 * i + 2], a.N[3 * i], a.N[3 * i + 1],
                    a.N[3 * i + 2], a.T[3 * i], a.T[3 * i + 1], a.T[3 * i + 2]);
      csv += line;
    }
  }
  WriteFile(dir_->File("analytic.csv"), csv);
  const std::string material = Material("sparkle_binomial");
  const RunResult e =
      RunGlint(*dir_, {kGlint, "eval", "--server", unary_->address(), "--material", material,
                       "--lights", Lights("sun"), "--queries", dir_->File("analytic.csv"), "--out",
                       dir_->File("eval.csv")});
  ASSERT_EQ(e.exit_code, 0) << Describe(e);
  const std::string beauty = dir_->File("analytic_beauty.exr");
  const RunResult r =
      RunGlint(*dir_, {kGlint, "render", "--server", stream_->address(), "--gbuffer", gb,
                       "--material", material, "--lights", Lights("sun"), "--out", beauty,
                       "--camera", "0,-4,1.2", "--channels", "P=Pworld,T=tangentU,uv=st,A=alpha"});
  ASSERT_EQ(r.exit_code, 0) << Describe(r);

  std::vector<float> eval;
  {
    std::ifstream in(dir_->File("eval.csv"));
    std::string row;
    std::getline(in, row);
    while (std::getline(in, row)) {
      std::stringstream ss(row);
      std::string cell;
      while (std::getline(ss, cell, ',')) eval.push_back(std::strtof(cell.c_str(), nullptr));
    }
  }
  ASSERT_EQ(eval.size(), 3 * pixels.size());
  int w2 = 0, h2 = 0;
  auto got = ReadChannels(beauty, {"R", "G", "B", "A"}, &w2, &h2);
  ASSERT_EQ(w2, w);
  ASSERT_EQ(h2, h);
  const char *names[3] = {"R", "G", "B"};
  std::vector<float> expected_image[3];
  for (auto &plane : expected_image) plane.assign(static_cast<size_t>(w) * h, 0.0f);
  int lit = 0;
  for (size_t k = 0; k < pixels.size(); ++k) {
    for (int c = 0; c < 3; ++c) expected_image[c][pixels[k]] = eval[3 * k + c];
    lit += eval[3 * k] > 0.0f;
  }
  for (int c = 0; c < 3; ++c) EXPECT_TRUE(BitEqual(got[names[c]], expected_image[c])) << names[c];
  EXPECT_TRUE(BitEqual(got["A"], alpha)) << "the beauty's A is the G-buffer's";
  EXPECT_GT(lit, 0) << "no pixel lit: the comparison would be vacuous";
}

TEST_F(RenderEndToEnd, BatchOfTwoEqualsTwoSinglePreviewsAndTheSheetTilesThem) {
  const std::string mats = dir_->File("batch_materials");
  fs::create_directories(mats);
  fs::copy_file(Material("paint_schlick"), mats + "/paint.json");
  fs::copy_file(Material("sparkle_binomial"), mats + "/sparkle.json");
  const std::string size = "80x56";
  const std::string sheet = dir_->File("sheet.png");
  // Streamed batch in chunks of 256 (several chunks per material) ...
  const RunResult b =
      RunGlint(*dir_, {kGlint, "preview", "--server", stream_->address(), "--materials", mats,
                       "--lights", Lights("sun"), "--out", dir_->File("b.exr"), "--size", size,
                       "--contact-sheet", sheet});
  ASSERT_EQ(b.exit_code, 0) << Describe(b);
  EXPECT_NE(b.out.find("2 materials"), std::string::npos) << b.out;
  EXPECT_NE(b.out.find("materials/s"), std::string::npos) << b.out;
  // ... and the same with repeated --material (same files, same order).
  const RunResult b2 =
      RunGlint(*dir_, {kGlint, "preview", "--server", unary_->address(), "--material",
                       mats + "/paint.json", "--material", mats + "/sparkle.json", "--lights",
                       Lights("sun"), "--out", dir_->File("c.exr"), "--size", size});
  ASSERT_EQ(b2.exit_code, 0) << Describe(b2);

  int sw = 0, sh = 0;
  const std::vector<uint8_t> sheet_rgb = ReadPng(sheet, &sw, &sh);
  // Two tiles: ceil(sqrt(2)) = 2 columns, 1 row; label strip clamp(56 / 10, 16, 48) = 16.
  EXPECT_EQ(sw, 2 * 80);
  EXPECT_EQ(sh, 56 + 16);
  int col = 0;
  for (const std::string stem : {"paint", "sparkle"}) {
    SCOPED_TRACE(stem);
    const std::string single = dir_->File("single_" + stem + ".exr");
    const RunResult s = RunGlint(*dir_, {kGlint, "preview", "--server", unary_->address(),
                                         "--material", mats + "/" + stem + ".json", "--lights",
                                         Lights("sun"), "--out", single, "--size", size});
    ASSERT_EQ(s.exit_code, 0) << Describe(s);
    int w = 0, h = 0;
    const auto want = ReadChannels(single, {"R", "G", "B"}, &w, &h);
    for (const std::string prefix : {"b", "c"}) {
      const auto got =
          ReadChannels(dir_->File(prefix + "_" + stem + ".exr"), {"R", "G", "B"}, &w, &h);
      for (const char *c : {"R", "G", "B"}) EXPECT_TRUE(BitEqual(got.at(c), want.at(c))) << c;
    }
    int pw = 0, ph = 0, bw = 0, bh = 0;
    const auto png = ReadPng(PngBeside(single), &pw, &ph);
    EXPECT_EQ(ReadPng(dir_->File("b_" + stem + ".png"), &bw, &bh), png);
    // The sheet's tile is the material's PNG, pixel for pixel.
    bool same = true;
    for (int y = 0; y < ph && same; ++y) {
      same = std::memcmp(&sheet_rgb[3 * (static_cast<size_t>(y) * sw + col * pw)],
                         &png[3 * static_cast<size_t>(y) * pw], 3 * static_cast<size_t>(pw)) == 0;
    }
    EXPECT_TRUE(same);
    // A label is drawn: the strip under the tile is not all one colour.
    int bright = 0;
    for (int y = ph; y < sh; ++y) {
      for (int x = col * pw; x < (col + 1) * pw; ++x) {
        bright += sheet_rgb[3 * (static_cast<size_t>(y) * sw + x)] > 128;
      }
    }
    EXPECT_GT(bright, 10) << "no label text under tile " << col;
    ++col;
  }

  // A batch goes on past the materials it cannot render (issue 12 leftovers: a TD's 200
  // overnight previews): BINOMIAL under a directional light without a cone and a material with
  // alpha_x 0 (both refused by the server), and NORMAL_MAP without --normal-map (skipped by the
  // CLI) are skipped; the others are rendered, over a new stream after each refusal, equal to
  // their single previews bit for bit; the summary on stderr names each skipped material, its
  // file and the server's reason (the field); the contact sheet tiles the rendered ones; exit 1.
  WriteFile(dir_->File("zz_bad.json"), R"({"model": "SMOOTH", "ndf": "GGX", "alpha_x": 0,
                                          "alpha_y": 0.3, "schlick": {"f0": [1, 1, 1]}})");
  WriteFile(dir_->File("nm.json"), R"({"model": "NORMAL_MAP", "schlick": {"f0": [1, 1, 1]}})");
  const std::string cone0 = dir_->File("cone0.json");
  WriteFile(cone0, R"({"lights": [{"directional": {"direction": [0, 0.6, 0.8],
                                                     "irradiance": [1, 1, 1]}}]})");
  const std::string skip_sheet = dir_->File("skip_sheet.png");
  const RunResult bad = RunGlint(*dir_, {kGlint,
                                         "preview",
                                         "--server",
                                         stream_->address(),
                                         "--material",
                                         mats + "/sparkle.json",
                                         "--material",
                                         mats + "/paint.json",
                                         "--material",
                                         dir_->File("zz_bad.json"),
                                         "--material",
                                         dir_->File("nm.json"),
                                         "--material",
                                         Material("plastic_beckmann"),
                                         "--lights",
                                         cone0,
                                         "--out",
                                         dir_->File("e.exr"),
                                         "--size",
                                         size,
                                         "--contact-sheet",
                                         skip_sheet});
  EXPECT_EQ(bad.exit_code, 1) << Describe(bad);
  EXPECT_NE(bad.out.find("2 of 5 materials"), std::string::npos) << bad.out;
  EXPECT_NE(bad.out.find("3 streams"), std::string::npos) << bad.out;  // restarted twice
  EXPECT_NE(bad.err.find("3 of 5 materials not rendered:"), std::string::npos) << bad.err;
  for (const std::string &line :
       {"  sparkle (" + mats +
            "/sparkle.json): skipped: INVALID_ARGUMENT: "
            "lights[0].directional.cone_half_angle_deg: 0",
        "  zz_bad (" + dir_->File("zz_bad.json") + "): skipped: INVALID_ARGUMENT: material.alpha_x",
        "  nm (" + dir_->File("nm.json") +
            "): skipped: a NORMAL_MAP material needs a normal map: "
            "pass --normal-map FILE"})
    EXPECT_NE(bad.err.find(line), std::string::npos) << line << "\n" << bad.err;
  EXPECT_EQ(bad.err.find("chunk "), std::string::npos) << "stream chunk numbers: " << bad.err;
  for (const std::string stem : {"sparkle", "zz_bad", "nm"})
    EXPECT_FALSE(fs::exists(dir_->File("e_" + stem + ".exr"))) << stem;
  for (const auto &[stem, file] :
       {std::pair<std::string, std::string>{"paint", mats + "/paint.json"},
        {"plastic_beckmann", Material("plastic_beckmann")}}) {
    SCOPED_TRACE(stem);
    const std::string single = dir_->File("cone0_" + stem + ".exr");
    const RunResult one =
        RunGlint(*dir_, {kGlint, "preview", "--server", unary_->address(), "--material", file,
                         "--lights", cone0, "--out", single, "--size", size});
    ASSERT_EQ(one.exit_code, 0) << Describe(one);
    int w = 0, h = 0;
    const auto want = ReadChannels(single, {"R", "G", "B"}, &w, &h);
    const auto got = ReadChannels(dir_->File("e_" + stem + ".exr"), {"R", "G", "B"}, &w, &h);
    for (const char *c : {"R", "G", "B"}) EXPECT_TRUE(BitEqual(got.at(c), want.at(c))) << c;
    double sum = 0;
    for (float v : want.at("R")) sum += v;
    EXPECT_GT(sum, 0.0) << "an all-black preview compares nothing";
  }
  int kw = 0, kh = 0;
  ReadPng(skip_sheet, &kw, &kh);
  EXPECT_EQ(kw, 2 * 80);  // two rendered tiles side by side
  EXPECT_EQ(kh, 56 + 16);

  // Two materials with the same stem would overwrite each other's files: refused.
  const RunResult dup = RunGlint(
      *dir_, {kGlint, "preview", "--server", unary_->address(), "--material", mats + "/paint.json",
              "--material", Material("paint_schlick"), "--material", mats + "/paint.json",
              "--lights", Lights("sun"), "--out", dir_->File("d.exr")});
  EXPECT_EQ(dup.exit_code, 2) << Describe(dup);
  EXPECT_NE(dup.err.find("two materials named 'paint'"), std::string::npos) << dup.err;
}

TEST_F(RenderEndToEnd, StreamedPreviewKeepsTheAreaMethod) {
  // Monte Carlo polygon-light integration differs from LTC in every lit pixel; a streamed
  // preview that dropped --area-method would equal the LTC one instead of the unary MC one.
  std::map<std::string, std::vector<float>> out;
  for (const std::string which : {"mc_unary", "mc_stream", "ltc_stream"}) {
    const bool stream = which.find("stream") != std::string::npos;
    const std::string method = which.substr(0, which.find('_'));
    const std::string exr = dir_->File("area_" + which + ".exr");
    const RunResult r = RunGlint(
        *dir_, {kGlint, "preview", "--server", (stream ? stream_ : unary_)->address(), "--material",
                Material("paint_schlick"), "--lights", Lights("rect_small"), "--out", exr, "--size",
                "48x32", "--area-method", method, "--samples", "8"});
    ASSERT_EQ(r.exit_code, 0) << Describe(r);
    int w = 0, h = 0;
    out[which] = ReadChannels(exr, {"R"}, &w, &h).at("R");
  }
  EXPECT_TRUE(BitEqual(out["mc_stream"], out["mc_unary"]));
  EXPECT_FALSE(BitEqual(out["mc_stream"], out["ltc_stream"]));
}

}  // namespace
