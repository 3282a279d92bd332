// File formats of the glint CLI: queries CSV, material/lights JSON, radiance CSV and NPY.
// The NPY and CSV outputs are read back by independent readers written here, not by the
// library's own code.
#include "client/lib/query_io.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

namespace glint::client {
namespace {

namespace fs = std::filesystem;

// Runs `fn`, expects IoError, and returns its message for further checks.
template <typename Fn>
std::string IoErrorOf(Fn fn) {
  try {
    fn();
  } catch (const IoError &e) {
    return e.what();
  }
  ADD_FAILURE() << "expected IoError";
  return "";
}

std::vector<float> Floats(const google::protobuf::RepeatedField<float> &f) {
  return {f.begin(), f.end()};
}

uint32_t Bits(float f) {
  uint32_t b;
  std::memcpy(&b, &f, sizeof b);
  return b;
}

class TempDir {
 public:
  TempDir() {
    std::string tmpl = (fs::temp_directory_path() / "glint_client_test_XXXXXX").string();
    path_ = mkdtemp(tmpl.data());
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  std::string File(const std::string &name) const { return (fs::path(path_) / name).string(); }
  std::string Write(const std::string &name, const std::string &contents) const {
    std::ofstream(File(name), std::ios::binary) << contents;
    return File(name);
  }

 private:
  std::string path_;
};

std::string ReadBytes(const std::string &path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// ---- Queries CSV ----------------------------------------------------------------------------

TEST(QueriesCsv, WoOnlyLeavesOptionalArraysEmpty) {
  const auto batch = ParseQueriesCsv("wox,woy,woz\n0,0,1\n0.6,0,0.8\n", "q.csv");
  EXPECT_EQ(batch.count(), 2u);
  EXPECT_EQ(Floats(batch.wo()), (std::vector<float>{0, 0, 1, 0.6f, 0, 0.8f}));
  EXPECT_TRUE(batch.uv().empty());
  EXPECT_TRUE(batch.footprint().empty());
  EXPECT_TRUE(batch.wi().empty());
  EXPECT_TRUE(batch.position().empty());
  EXPECT_TRUE(batch.normal().empty());
  EXPECT_TRUE(batch.tangent().empty());
}

TEST(QueriesCsv, MissingWoDefaultsToNormalAndMissingVToZero) {
  const auto batch = ParseQueriesCsv("u\n0.25\n-3\n", "q.csv");
  ASSERT_EQ(batch.count(), 2u);
  EXPECT_EQ(Floats(batch.wo()), (std::vector<float>{0, 0, 1, 0, 0, 1}));
  EXPECT_EQ(Floats(batch.uv()), (std::vector<float>{0.25f, 0, -3, 0}));
}

TEST(QueriesCsv, MissingFootprintComponentsAreZero) {
  const auto batch = ParseQueriesCsv("dvdy,wox,woy,woz,dudx\n4,0,0,1,1\n", "q.csv");
  EXPECT_EQ(Floats(batch.footprint()), (std::vector<float>{1, 0, 0, 4}));
}

TEST(QueriesCsv, ColumnOrderDoesNotMatter) {
  const auto a = ParseQueriesCsv(
      "u,v,wox,woy,woz,wix,wiy,wiz\n1,2,0,0.6,0.8,0.8,0,0.6\n3,4,0,0,1,0,0,1\n", "a.csv");
  const auto b = ParseQueriesCsv(
      "wiz,woz,v,wix,u,woy,wox,wiy\n0.6,0.8,2,0.8,1,0.6,0,0\n1,1,4,0,3,0,0,0\n", "b.csv");
  EXPECT_EQ(a.SerializeAsString(), b.SerializeAsString());
  EXPECT_EQ(Floats(b.wi()), (std::vector<float>{0.8f, 0, 0.6f, 0, 0, 1}));
}

TEST(QueriesCsv, FrameColumnsFillPositionNormalTangent) {
  const auto batch =
      ParseQueriesCsv("tz,ty,tx,nz,ny,nx,pz,py,px,wox,woy,woz\n9,8,7,6,5,4,3,2,1,0,0,1\n", "q.csv");
  EXPECT_EQ(Floats(batch.position()), (std::vector<float>{1, 2, 3}));
  EXPECT_EQ(Floats(batch.normal()), (std::vector<float>{4, 5, 6}));
  EXPECT_EQ(Floats(batch.tangent()), (std::vector<float>{7, 8, 9}));
}

TEST(QueriesCsv, PartialWoIsAnErrorNamingTheMissingColumn) {
  const std::string msg = IoErrorOf([] { ParseQueriesCsv("wox,woy\n0,0\n", "q.csv"); });
  EXPECT_NE(msg.find("q.csv:1"), std::string::npos) << msg;
  EXPECT_NE(msg.find("'woz'"), std::string::npos) << msg;
}

TEST(QueriesCsv, PartialWiIsAnErrorNamingTheMissingColumn) {
  const std::string msg =
      IoErrorOf([] { ParseQueriesCsv("wox,woy,woz,wix,wiz\n0,0,1,0,1\n", "q.csv"); });
  EXPECT_NE(msg.find("'wiy'"), std::string::npos) << msg;
}

TEST(QueriesCsv, PartialFrameIsAnError) {
  // Position and normal complete, tangent without tz: the frame is all nine or none.
  const std::string msg = IoErrorOf([] {
    ParseQueriesCsv("px,py,pz,nx,ny,nz,tx,ty,wox,woy,woz\n0,0,0,0,0,1,1,0,0,0,1\n", "q.csv");
  });
  EXPECT_NE(msg.find("'tz'"), std::string::npos) << msg;
  const std::string msg2 =
      IoErrorOf([] { ParseQueriesCsv("px,py,pz,wox,woy,woz\n0,0,0,0,0,1\n", "q.csv"); });
  EXPECT_NE(msg2.find("'nx'"), std::string::npos) << msg2;
}

TEST(QueriesCsv, BadNumberNamesLineAndColumn) {
  // Line 4 counts the blank line 3: numbers refer to the file as an editor shows it.
  const std::string msg =
      IoErrorOf([] { ParseQueriesCsv("wox,woy,woz\n0,0,1\n\n0,abc,1\n", "q.csv"); });
  EXPECT_NE(msg.find("q.csv:4"), std::string::npos) << msg;
  EXPECT_NE(msg.find("'woy'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("'abc'"), std::string::npos) << msg;
}

TEST(QueriesCsv, TrailingGarbageAndEmptyFieldsAreNotNumbers) {
  EXPECT_NE(IoErrorOf([] { ParseQueriesCsv("u\n1.5x\n", "q.csv"); }).find("'1.5x'"),
            std::string::npos);
  EXPECT_NE(IoErrorOf([] { ParseQueriesCsv("u,v\n1,\n", "q.csv"); }).find("column 'v'"),
            std::string::npos);
}

TEST(QueriesCsv, WrongFieldCountNamesLine) {
  const std::string msg = IoErrorOf([] { ParseQueriesCsv("u,v\n1,2\n1,2,3\n", "q.csv"); });
  EXPECT_NE(msg.find("q.csv:3"), std::string::npos) << msg;
  EXPECT_NE(msg.find("expected 2 fields"), std::string::npos) << msg;
}

TEST(QueriesCsv, UnknownAndDuplicateColumnsAreErrors) {
  const std::string unknown = IoErrorOf([] { ParseQueriesCsv("u,w\n1,2\n", "q.csv"); });
  EXPECT_NE(unknown.find("unknown column 'w'"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("field 2"), std::string::npos) << unknown;
  const std::string dup = IoErrorOf([] { ParseQueriesCsv("u,v,u\n1,2,3\n", "q.csv"); });
  EXPECT_NE(dup.find("'u' appears twice"), std::string::npos) << dup;
}

TEST(QueriesCsv, EmptyFileIsAnError) {
  EXPECT_NE(IoErrorOf([] { ParseQueriesCsv("\n \n", "q.csv"); }).find("empty"), std::string::npos);
}

TEST(QueriesCsv, HeaderOnlyGivesZeroQueries) {
  EXPECT_EQ(ParseQueriesCsv("wox,woy,woz\n", "q.csv").count(), 0u);
}

TEST(QueriesCsv, AcceptsCrlfBomSpacesAndNumberForms) {
  const auto batch =
      ParseQueriesCsv("\xEF\xBB\xBFu , v\r\n +1 ,\t-2.5e-1\r\n0.1,1e-50\r\n", "q.csv");
  ASSERT_EQ(batch.count(), 2u);
  EXPECT_EQ(Floats(batch.uv()), (std::vector<float>{1.0f, -0.25f, 0.1f, 0.0f}));
  // Parsed straight to float, correctly rounded: the same bits as the float literal.
  EXPECT_EQ(Bits(batch.uv(2)), Bits(0.1f));
}

TEST(QueriesCsv, OverflowIsAnErrorNotInfinity) {
  const std::string msg = IoErrorOf([] { ParseQueriesCsv("u\n1e50\n", "q.csv"); });
  EXPECT_NE(msg.find("out of float range"), std::string::npos) << msg;
}

TEST(QueriesCsv, ReadsFromFileAndNamesItInErrors) {
  TempDir dir;
  const std::string good = dir.Write("good.csv", "wox,woy,woz\n0,0,1\n");
  EXPECT_EQ(ReadQueriesCsv(good).count(), 1u);
  const std::string bad = dir.Write("bad.csv", "wox,woy,woz\n0,0,one\n");
  EXPECT_NE(IoErrorOf([&] { ReadQueriesCsv(bad); }).find(bad + ":2"), std::string::npos);
  const std::string missing = dir.File("missing.csv");
  EXPECT_NE(IoErrorOf([&] { ReadQueriesCsv(missing); }).find(missing), std::string::npos);
}

// ---- JSON -----------------------------------------------------------------------------------

TEST(MaterialJson, ParsesTheDocumentedExample) {
  TempDir dir;
  const std::string path =
      dir.Write("m.json",
                R"({"model": "SMOOTH", "ndf": "GGX", "alpha_x": 0.3, "alpha_y": 0.1,
          "schlick": {"f0": [0.9, 0.6, 0.3]}})");
  const glint::v1::Material m = ReadMaterialJson(path);
  EXPECT_EQ(m.model(), glint::v1::SMOOTH);
  EXPECT_EQ(m.ndf(), glint::v1::GGX);
  EXPECT_EQ(m.alpha_x(), 0.3f);
  EXPECT_EQ(m.alpha_y(), 0.1f);
  ASSERT_EQ(m.fresnel_case(), glint::v1::Material::kSchlick);
  EXPECT_EQ(Floats(m.schlick().f0()), (std::vector<float>{0.9f, 0.6f, 0.3f}));
}

TEST(MaterialJson, ConductorAndCamelCaseNames) {
  const auto m = ParseMaterialJson(
      R"({"model": "SMOOTH", "ndf": "BECKMANN", "alphaX": 0.5, "alphaY": 0.5,
          "conductor": {"eta": [0.2, 0.9, 1.1], "k": [3.9, 2.4, 2.2]}})",
      "m.json");
  EXPECT_EQ(m.ndf(), glint::v1::BECKMANN);
  EXPECT_EQ(m.alpha_x(), 0.5f);
  EXPECT_EQ(m.conductor().k_size(), 3);
}

TEST(MaterialJson, UnknownFieldIsAnErrorNamingTheFile) {
  const std::string msg = IoErrorOf([] { ParseMaterialJson(R"({"alpha": 0.3})", "m.json"); });
  EXPECT_NE(msg.find("m.json"), std::string::npos) << msg;
  EXPECT_NE(msg.find("alpha"), std::string::npos) << msg;
}

TEST(MaterialJson, BadEnumAndBadSyntaxAreErrors) {
  const std::string bad_enum =
      IoErrorOf([] { ParseMaterialJson(R"({"model": "SHINY"})", "m.json"); });
  EXPECT_NE(bad_enum.find("SHINY"), std::string::npos) << bad_enum;
  const std::string syntax =
      IoErrorOf([] { ParseMaterialJson(R"({"model": "SMOOTH",)", "broken.json"); });
  EXPECT_NE(syntax.find("broken.json"), std::string::npos) << syntax;
  // Two fresnel kinds at once violate the oneof.
  EXPECT_FALSE(IoErrorOf([] {
                 ParseMaterialJson(R"({"schlick": {"f0": [1,1,1]}, "dielectric": {"ior": 1.5}})",
                                   "m.json");
               }).empty());
}

TEST(MaterialJson, MissingFileNamesThePath) {
  const std::string msg = IoErrorOf([] { ReadMaterialJson("/nonexistent/dir/m.json"); });
  EXPECT_NE(msg.find("/nonexistent/dir/m.json"), std::string::npos) << msg;
}

TEST(LightsJson, ParsesTheDocumentedExample) {
  TempDir dir;
  const std::string path = dir.Write(
      "l.json",
      R"({"lights": [{"directional": {"direction": [0, 0.5, 0.866], "irradiance": [1, 1, 1],
                                      "cone_half_angle_deg": 0.26}},
                     {"point": {"position": [0, 1, 2], "intensity": [5, 5, 5], "radius": 0}}]})");
  const std::vector<glint::v1::Light> lights = ReadLightsJson(path);
  ASSERT_EQ(lights.size(), 2u);
  ASSERT_EQ(lights[0].kind_case(), glint::v1::Light::kDirectional);
  EXPECT_EQ(Floats(lights[0].directional().direction()), (std::vector<float>{0, 0.5f, 0.866f}));
  EXPECT_EQ(lights[0].directional().cone_half_angle_deg(), 0.26f);
  ASSERT_EQ(lights[1].kind_case(), glint::v1::Light::kPoint);
  EXPECT_EQ(Floats(lights[1].point().intensity()), (std::vector<float>{5, 5, 5}));
}

TEST(LightsJson, WrongShapesAreErrors) {
  // A bare array is not the documented LightList form.
  EXPECT_NE(IoErrorOf([] { ParseLightsJson(R"([{"point": {}}])", "l.json"); }).find("l.json"),
            std::string::npos);
  const std::string msg = IoErrorOf(
      [] { ParseLightsJson(R"({"lights": [{"directional": {"direction": "up"}}]})", "l.json"); });
  EXPECT_NE(msg.find("l.json"), std::string::npos) << msg;
  EXPECT_FALSE(
      IoErrorOf([] { ParseLightsJson(R"({"lights": [{"spot": {}}]})", "l.json"); }).empty());
}

// ---- Radiance CSV ---------------------------------------------------------------------------

TEST(RadianceCsv, RoundTripsEveryFloatBitForBit) {
  TempDir dir;
  const std::vector<float> rgb = {0.1f,
                                  1.0f / 3.0f,
                                  -0.0f,
                                  std::numeric_limits<float>::max(),
                                  std::numeric_limits<float>::min(),
                                  std::numeric_limits<float>::denorm_min(),
                                  123456789.0f,
                                  2.5e-7f,
                                  std::nextafter(1.0f, 2.0f)};
  const std::string path = dir.File("r.csv");
  WriteRadianceCsv(path, rgb);

  // Independent reader: getline + strtof.
  std::ifstream in(path);
  std::string line;
  ASSERT_TRUE(std::getline(in, line));
  EXPECT_EQ(line, "r,g,b");
  std::vector<float> back;
  int rows = 0;
  while (std::getline(in, line)) {
    ++rows;
    std::stringstream ss(line);
    std::string cell;
    int cells = 0;
    while (std::getline(ss, cell, ',')) {
      back.push_back(std::strtof(cell.c_str(), nullptr));
      ++cells;
    }
    EXPECT_EQ(cells, 3) << line;
  }
  EXPECT_EQ(rows, 3);
  ASSERT_EQ(back.size(), rgb.size());
  for (size_t i = 0; i < rgb.size(); ++i) EXPECT_EQ(Bits(back[i]), Bits(rgb[i])) << i;
}

TEST(RadianceCsv, RejectsSizesThatAreNotRgb) {
  TempDir dir;
  EXPECT_THROW(WriteRadianceCsv(dir.File("r.csv"), {1.0f, 2.0f}), IoError);
  EXPECT_THROW(WriteRadianceCsv("/nonexistent/dir/r.csv", {1, 2, 3}), IoError);
}

// ---- NPY ------------------------------------------------------------------------------------

// An independent .npy v1.0 reader following the format description (numpy.lib.format):
// parses the header dict with a regex rather than trusting any fixed layout.
struct Npy {
  std::string descr;
  bool fortran_order = true;
  std::vector<uint64_t> shape;
  std::vector<float> data;
  size_t data_offset = 0;
};

Npy ReadNpy(const std::string &bytes) {
  Npy npy;
  EXPECT_GE(bytes.size(), 10u);
  EXPECT_EQ(bytes.substr(0, 6), std::string("\x93NUMPY", 6));
  EXPECT_EQ(static_cast<uint8_t>(bytes[6]), 1);  // major version
  EXPECT_EQ(static_cast<uint8_t>(bytes[7]), 0);  // minor version
  const size_t header_len =
      static_cast<uint8_t>(bytes[8]) | (static_cast<size_t>(static_cast<uint8_t>(bytes[9])) << 8);
  npy.data_offset = 10 + header_len;
  EXPECT_EQ(npy.data_offset % 64, 0u) << "data should start 64-byte aligned";
  const std::string header = bytes.substr(10, header_len);
  EXPECT_EQ(header.back(), '\n');
  std::smatch m;
  EXPECT_TRUE(std::regex_search(header, m, std::regex(R"('descr'\s*:\s*'([^']*)')")));
  npy.descr = m[1];
  EXPECT_TRUE(std::regex_search(header, m, std::regex(R"('fortran_order'\s*:\s*(True|False))")));
  npy.fortran_order = m[1] == "True";
  EXPECT_TRUE(std::regex_search(header, m, std::regex(R"('shape'\s*:\s*\(([^)]*)\))")));
  const std::string dims = m[1];
  const std::regex number(R"(\d+)");
  for (auto it = std::sregex_iterator(dims.begin(), dims.end(), number);
       it != std::sregex_iterator(); ++it) {
    npy.shape.push_back(std::stoull(it->str()));
  }
  const size_t n = (bytes.size() - npy.data_offset) / 4;
  EXPECT_EQ((bytes.size() - npy.data_offset) % 4, 0u);
  for (size_t i = 0; i < n; ++i) {
    uint32_t bits = 0;
    for (int b = 0; b < 4; ++b) {
      bits |= static_cast<uint32_t>(static_cast<uint8_t>(bytes[npy.data_offset + 4 * i + b]))
              << (8 * b);
    }
    float f;
    std::memcpy(&f, &bits, sizeof f);
    npy.data.push_back(f);
  }
  return npy;
}

TEST(RadianceNpy, HeaderShapeDtypeAndValues) {
  TempDir dir;
  std::vector<float> rgb;
  for (int i = 0; i < 5 * 3; ++i) rgb.push_back(static_cast<float>(i) * 0.37f - 1.0f);
  rgb[4] = std::numeric_limits<float>::denorm_min();
  const std::string path = dir.File("r.npy");
  WriteRadianceNpy(path, rgb, 5);
  const Npy npy = ReadNpy(ReadBytes(path));
  EXPECT_EQ(npy.descr, "<f4");
  EXPECT_FALSE(npy.fortran_order);
  EXPECT_EQ(npy.shape, (std::vector<uint64_t>{5, 3}));
  ASSERT_EQ(npy.data.size(), rgb.size());
  for (size_t i = 0; i < rgb.size(); ++i) EXPECT_EQ(Bits(npy.data[i]), Bits(rgb[i])) << i;
}

TEST(RadianceNpy, LargeAndEmptyShapes) {
  TempDir dir;
  // A count with more digits changes the header length: the padding must follow.
  const uint64_t big = 1234567;
  WriteRadianceNpy(dir.File("big.npy"), std::vector<float>(big * 3, 0.5f), big);
  const Npy npy = ReadNpy(ReadBytes(dir.File("big.npy")));
  EXPECT_EQ(npy.shape, (std::vector<uint64_t>{big, 3}));
  EXPECT_EQ(npy.data.size(), big * 3);
  EXPECT_EQ(npy.data.back(), 0.5f);

  WriteRadianceNpy(dir.File("empty.npy"), {}, 0);
  const Npy empty = ReadNpy(ReadBytes(dir.File("empty.npy")));
  EXPECT_EQ(empty.shape, (std::vector<uint64_t>{0, 3}));
  EXPECT_TRUE(empty.data.empty());
}

TEST(RadianceNpy, CountMustMatch) {
  TempDir dir;
  EXPECT_THROW(WriteRadianceNpy(dir.File("r.npy"), {1, 2, 3}, 2), IoError);
}

// ---- Image layout and formats ---------------------------------------------------------------

TEST(QueriesToImage, RowsFollowQueryOrderWithBlackTail) {
  std::vector<float> rgb;
  for (int i = 1; i <= 5 * 3; ++i) rgb.push_back(static_cast<float>(i));
  const RgbImage image = QueriesToImage(rgb, 2);
  EXPECT_EQ(image.width, 2);
  EXPECT_EQ(image.height, 3);
  ASSERT_EQ(image.rgb.size(), 2u * 3u * 3u);
  for (size_t i = 0; i < rgb.size(); ++i) EXPECT_EQ(image.rgb[i], rgb[i]);
  EXPECT_EQ(image.rgb[15], 0.0f);
  EXPECT_EQ(image.rgb[17], 0.0f);

  const RgbImage row = QueriesToImage(rgb, 0);
  EXPECT_EQ(row.width, 5);
  EXPECT_EQ(row.height, 1);
  EXPECT_EQ(row.rgb, rgb);
}

TEST(OutputFormat, FromExtension) {
  EXPECT_EQ(OutputFormatFromPath("a/b.csv"), OutputFormat::kCsv);
  EXPECT_EQ(OutputFormatFromPath("B.NPY"), OutputFormat::kNpy);
  EXPECT_EQ(OutputFormatFromPath("x.exr"), OutputFormat::kExr);
  EXPECT_EQ(OutputFormatFromPath("x.txt"), OutputFormat::kUnknown);
  EXPECT_EQ(OutputFormatFromPath("dir.csv/noext"), OutputFormat::kUnknown);
}

}  // namespace
}  // namespace glint::client
