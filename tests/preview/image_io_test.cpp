// Image I/O checked against the libraries themselves: EXR files are read back with OpenEXR's
// own InputFile (and ReadExrRgb is fed a file written by Imf::RgbaOutputFile), PNG files are
// decoded with libpng.
#include "client/preview/image_io.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfRgbaFile.h>
#include <gtest/gtest.h>
#include <png.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <stdexcept>

namespace glint::client {
namespace {

namespace fs = std::filesystem;

class ImageIoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto *info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::path(::testing::TempDir()) /
           ("glint_preview_" + std::string(info->name()) + "_" + std::to_string(getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Path(const std::string &name) const { return (dir_ / name).string(); }

  fs::path dir_;
};

// A test image with values a tone mapper or a half conversion could get wrong: zero,
// negatives, tiny and large magnitudes, and non-repeating mantissas.
std::vector<float> TestImage(int w, int h) {
  std::vector<float> rgb(3 * static_cast<size_t>(w) * h);
  for (size_t i = 0; i < rgb.size(); ++i) {
    const float k = static_cast<float>(i);
    rgb[i] = std::sin(0.37f * k) * std::exp2(static_cast<float>(static_cast<int>(i % 23) - 11));
  }
  rgb[0] = 0.0f;
  return rgb;
}

struct ExrContents {
  int width = 0, height = 0;
  Imf::PixelType type[3] = {};
  std::vector<float> rgb;
};

// Independent reader: OpenEXR's general interface, one float slice per channel.
ExrContents ReadWithOpenExr(const std::string &path) {
  Imf::InputFile file(path.c_str());
  const Imath::Box2i dw = file.header().dataWindow();
  ExrContents out;
  out.width = dw.max.x - dw.min.x + 1;
  out.height = dw.max.y - dw.min.y + 1;
  const size_t n = static_cast<size_t>(out.width) * out.height;
  std::vector<float> planes[3];
  Imf::FrameBuffer fb;
  const char *names[3] = {"R", "G", "B"};
  for (int c = 0; c < 3; ++c) {
    const Imf::Channel *ch = file.header().channels().findChannel(names[c]);
    EXPECT_NE(ch, nullptr) << names[c];
    if (ch) out.type[c] = ch->type;
    planes[c].assign(n, -1.0f);
    fb.insert(names[c], Imf::Slice::Make(Imf::FLOAT, planes[c].data(), dw));
  }
  file.setFrameBuffer(fb);
  file.readPixels(dw.min.y, dw.max.y);
  out.rgb.resize(3 * n);
  for (size_t i = 0; i < n; ++i) {
    for (int c = 0; c < 3; ++c) out.rgb[3 * i + c] = planes[c][i];
  }
  return out;
}

TEST_F(ImageIoTest, ExrFloatRoundTripIsExact) {
  const int w = 37, h = 21;  // odd sizes catch stride mistakes
  const std::vector<float> rgb = TestImage(w, h);
  const std::string path = Path("float.exr");
  WriteExrRgb(path, w, h, rgb);

  const ExrContents c = ReadWithOpenExr(path);
  EXPECT_EQ(c.width, w);
  EXPECT_EQ(c.height, h);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(c.type[k], Imf::FLOAT);
  ASSERT_EQ(c.rgb.size(), rgb.size());
  for (size_t i = 0; i < rgb.size(); ++i) ASSERT_EQ(c.rgb[i], rgb[i]) << "index " << i;

  int rw = 0, rh = 0;
  const std::vector<float> back = ReadExrRgb(path, &rw, &rh);
  EXPECT_EQ(rw, w);
  EXPECT_EQ(rh, h);
  EXPECT_EQ(back, rgb);
}

// NaN and Inf must survive a float EXR untouched (they are what a broken query returns).
TEST_F(ImageIoTest, ExrFloatKeepsNonFinite) {
  std::vector<float> rgb = {std::numeric_limits<float>::quiet_NaN(),
                            std::numeric_limits<float>::infinity(), -0.0f};
  const std::string path = Path("nan.exr");
  WriteExrRgb(path, 1, 1, rgb);
  const ExrContents c = ReadWithOpenExr(path);
  EXPECT_TRUE(std::isnan(c.rgb[0]));
  EXPECT_EQ(c.rgb[1], std::numeric_limits<float>::infinity());
  EXPECT_TRUE(std::signbit(c.rgb[2]));
}

// Half has an 11-bit significand: round-to-nearest is within 2^-11 relative for normal
// values (|x| >= 2^-14); below that the absolute spacing 2^-24 bounds the error.
TEST_F(ImageIoTest, ExrHalfRoundTripWithinHalfPrecision) {
  const int w = 19, h = 8;
  const std::vector<float> rgb = TestImage(w, h);
  const std::string path = Path("half.exr");
  WriteExrRgb(path, w, h, rgb, /*half_float=*/true);

  const ExrContents c = ReadWithOpenExr(path);
  EXPECT_EQ(c.width, w);
  EXPECT_EQ(c.height, h);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(c.type[k], Imf::HALF);
  ASSERT_EQ(c.rgb.size(), rgb.size());
  int inexact = 0;
  for (size_t i = 0; i < rgb.size(); ++i) {
    const float tol = std::max(std::abs(rgb[i]) * std::exp2(-11.0f), std::exp2(-24.0f));
    ASSERT_NEAR(c.rgb[i], rgb[i], tol) << "index " << i;
    inexact += c.rgb[i] != rgb[i];
  }
  EXPECT_GT(inexact, 0) << "the file should really be half, not float";

  int rw = 0, rh = 0;
  EXPECT_EQ(ReadExrRgb(path, &rw, &rh), c.rgb);
}

// ReadExrRgb on a file it did not write: half RGBA from RgbaOutputFile with a data window
// that does not start at the origin.
TEST_F(ImageIoTest, ReadsForeignExrWithOffsetDataWindow) {
  const int w = 6, h = 4;
  Imath::Box2i display(Imath::V2i(0, 0), Imath::V2i(19, 19));
  Imath::Box2i data(Imath::V2i(5, 7), Imath::V2i(5 + w - 1, 7 + h - 1));
  Imf::Header header(display, data);
  std::vector<Imf::Rgba> px(static_cast<size_t>(w) * h);
  for (int i = 0; i < w * h; ++i) {
    px[i] = Imf::Rgba(static_cast<float>(i), 0.5f * static_cast<float>(i), -1.0f, 1.0f);
  }
  const std::string path = Path("rgba.exr");
  {
    Imf::RgbaOutputFile out(path.c_str(), header, Imf::WRITE_RGBA);
    out.setFrameBuffer(px.data() - data.min.x - data.min.y * w, 1, w);
    out.writePixels(h);
  }
  int rw = 0, rh = 0;
  const std::vector<float> rgb = ReadExrRgb(path, &rw, &rh);
  ASSERT_EQ(rw, w);
  ASSERT_EQ(rh, h);
  for (int i = 0; i < w * h; ++i) {
    EXPECT_EQ(rgb[3 * i + 0], static_cast<float>(i));
    EXPECT_EQ(rgb[3 * i + 1], 0.5f * static_cast<float>(i));
    EXPECT_EQ(rgb[3 * i + 2], -1.0f);
  }
}

TEST_F(ImageIoTest, ErrorsNameThePath) {
  const std::string missing_dir = Path("no/such/dir/out.exr");
  auto expect_path_error = [](auto &&fn, const std::string &path) {
    try {
      fn();
      ADD_FAILURE() << "no exception for " << path;
    } catch (const std::runtime_error &e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
  };
  const std::vector<float> one = {1.0f, 2.0f, 3.0f};
  expect_path_error([&] { WriteExrRgb(missing_dir, 1, 1, one); }, missing_dir);
  expect_path_error([&] { WriteExrRgb(missing_dir, 1, 1, one, true); }, missing_dir);
  const std::string missing = Path("missing.exr");
  int w = 0, h = 0;
  expect_path_error([&] { ReadExrRgb(missing, &w, &h); }, missing);
  const std::string not_exr = Path("not.exr");
  {
    std::FILE *f = std::fopen(not_exr.c_str(), "wb");
    std::fputs("hello", f);
    std::fclose(f);
  }
  expect_path_error([&] { ReadExrRgb(not_exr, &w, &h); }, not_exr);
  const std::string png = Path("no/such/dir/out.png");
  expect_path_error([&] { WritePngToneMapped(png, 1, 1, one); }, png);
  const std::string size = Path("size.exr");
  expect_path_error([&] { WriteExrRgb(size, 2, 1, one); }, size);
  expect_path_error([&] { WritePngToneMapped(size, 1, 2, one); }, size);
}

struct DecodedPng {
  unsigned width = 0, height = 0;
  std::vector<uint8_t> rgb;
};

DecodedPng DecodePng(const std::string &path) {
  png_image image;
  std::memset(&image, 0, sizeof(image));
  image.version = PNG_IMAGE_VERSION;
  DecodedPng out;
  if (!png_image_begin_read_from_file(&image, path.c_str())) {
    ADD_FAILURE() << "libpng: " << image.message;
    return out;
  }
  out.width = image.width;
  out.height = image.height;
  image.format = PNG_FORMAT_RGB;
  out.rgb.resize(PNG_IMAGE_SIZE(image));
  if (!png_image_finish_read(&image, nullptr, out.rgb.data(), 0, nullptr)) {
    ADD_FAILURE() << "libpng: " << image.message;
  }
  return out;
}

TEST_F(ImageIoTest, PngDecodesAndShowsNonFiniteAsMagenta) {
  const int w = 5, h = 3;
  std::vector<float> rgb(3 * w * h, 0.0f);
  auto set = [&](int x, int y, float r, float g, float b) {
    rgb[3 * (y * w + x) + 0] = r;
    rgb[3 * (y * w + x) + 1] = g;
    rgb[3 * (y * w + x) + 2] = b;
  };
  set(1, 0, 0.2f, std::numeric_limits<float>::quiet_NaN(), 0.2f);
  set(2, 0, std::numeric_limits<float>::infinity(), 0.0f, 0.0f);
  set(3, 0, 0.0f, 0.0f, -std::numeric_limits<float>::infinity());
  set(0, 1, 1e6f, 1e6f, 1e6f);   // far above the white point
  set(1, 1, -5.0f, 0.0f, 0.0f);  // negative radiance
  set(2, 1, 0.18f, 0.18f, 0.18f);
  set(3, 1, 0.5f, 1.0f, 2.0f);  // increasing channels must stay increasing
  set(4, 2, 0.5f, 0.5f, 0.5f);
  const std::string path = Path("out.png");
  WritePngToneMapped(path, w, h, rgb);

  const DecodedPng png = DecodePng(path);
  ASSERT_EQ(png.width, static_cast<unsigned>(w));
  ASSERT_EQ(png.height, static_cast<unsigned>(h));
  ASSERT_EQ(png.rgb.size(), static_cast<size_t>(3 * w * h));
  auto at = [&](int x, int y, int c) { return png.rgb[3 * (y * w + x) + c]; };
  for (int x : {1, 2, 3}) {
    EXPECT_EQ(at(x, 0, 0), 255) << x;
    EXPECT_EQ(at(x, 0, 1), 0) << x;
    EXPECT_EQ(at(x, 0, 2), 255) << x;
  }
  for (int c = 0; c < 3; ++c) {
    EXPECT_EQ(at(0, 0, c), 0);    // background black
    EXPECT_EQ(at(0, 1, c), 255);  // white, not magenta
    EXPECT_EQ(at(1, 1, c), 0);
  }
  // 18% grey lands in the lower-middle of the range (sRGB of 0.154 is ~110), far from both ends.
  EXPECT_GT(at(2, 1, 0), 90);
  EXPECT_LT(at(2, 1, 0), 130);
  EXPECT_LT(at(3, 1, 0), at(3, 1, 1));
  EXPECT_LT(at(3, 1, 1), at(3, 1, 2));
  EXPECT_LT(at(3, 1, 2), 255);

  // One stop of exposure is the same as doubling the radiance.
  std::vector<float> half_bright = rgb;
  for (float &v : half_bright) v *= 0.5f;
  const std::string path2 = Path("exposed.png");
  WritePngToneMapped(path2, w, h, half_bright, 1.0f);
  const DecodedPng png2 = DecodePng(path2);
  EXPECT_EQ(png2.rgb, png.rgb);
}

TEST(ScatterTest, PutsValuesAtTheirPixels) {
  const PreviewQueries scene = BuildPreviewQueries(PreviewShape::kSphere, 24, 18);
  const size_t n = scene.pixel_of_query.size();
  ASSERT_GT(n, 0u);
  std::vector<float> query_rgb(3 * n);
  for (size_t q = 0; q < n; ++q) {
    query_rgb[3 * q + 0] = static_cast<float>(q) + 1.0f;
    query_rgb[3 * q + 1] = static_cast<float>(scene.pixel_of_query[q]);
    query_rgb[3 * q + 2] = 7.0f;
  }
  const std::vector<float> image = ScatterToImage(scene, query_rgb);
  ASSERT_EQ(image.size(), static_cast<size_t>(3 * 24 * 18));
  size_t covered = 0;
  for (int p = 0; p < 24 * 18; ++p) {
    if (image[3 * p + 2] == 7.0f) {
      ++covered;
      EXPECT_EQ(image[3 * p + 1], static_cast<float>(p));
      const size_t q = static_cast<size_t>(image[3 * p + 0]) - 1;
      ASSERT_LT(q, n);
      EXPECT_EQ(scene.pixel_of_query[q], p);
    } else {
      for (int c = 0; c < 3; ++c) EXPECT_EQ(image[3 * p + c], 0.0f) << "background pixel " << p;
    }
  }
  EXPECT_EQ(covered, n);
}

TEST(ScatterTest, HandBuiltSceneAndErrors) {
  PreviewQueries scene;
  scene.width = 3;
  scene.height = 2;
  scene.pixel_of_query = {5, 0, 3};  // bottom-right, top-left, bottom-left
  const std::vector<float> query_rgb = {1, 2, 3, 4, 5, 6, 7, 8, 9};
  const std::vector<float> expected = {4, 5, 6, 0, 0, 0, 0, 0, 0,  //
                                       7, 8, 9, 0, 0, 0, 1, 2, 3};
  EXPECT_EQ(ScatterToImage(scene, query_rgb), expected);
  EXPECT_THROW(ScatterToImage(scene, {1, 2, 3}), std::invalid_argument);
  scene.pixel_of_query = {6, 0, 3};
  EXPECT_THROW(ScatterToImage(scene, query_rgb), std::invalid_argument);
}

}  // namespace
}  // namespace glint::client
