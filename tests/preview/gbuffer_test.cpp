// G-buffer -> queries (client/preview/gbuffer.h), checked against an analytic G-buffer the test
// builds itself: the documented preview cameras, a geometric ray / sphere and ray / plane
// intersection and the documented uv maps (preview_scene.h), written to EXR with OpenEXR
// directly under renderer-style channel names. Expected queries follow the documented rules
// (wo from the camera, central differences of uv, one-sided at edges and silhouettes), computed
// here in double from the float G-buffer; the same scene from BuildPreviewQueries must agree to
// float rounding in position, normal, tangent, uv and wo, and in the footprint to the central
// difference's truncation error. Malformed files are refused with the file and layer named.
#include "client/preview/gbuffer.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfMultiPartOutputFile.h>
#include <ImfOutputFile.h>
#include <ImfOutputPart.h>
#include <ImfPartType.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "analytic_gbuffer.h"

namespace glint::client {
namespace {

namespace fs = std::filesystem;
using namespace glint::test;

std::string TempPath(const std::string &name) {
  return (fs::temp_directory_path() / ("glint_gbuffer_test_" + name)).string();
}

float F(double v) {
  return static_cast<float>(v);
}

// Checks GBufferQueries of the analytic G-buffer against the documented rules exactly, and
// against BuildPreviewQueries of the same scene to float rounding / truncation error.
void CheckAgainstRulesAndPreview(PreviewShape shape, const Analytic &a, const PreviewQueries &got,
                                 bool derived_tangent) {
  const PreviewCamera &c = PreviewCameraFor(shape);
  const V3 eye{c.eye[0], c.eye[1], c.eye[2]};
  const glint::v1::QueryBatch &q = got.queries;
  std::vector<int32_t> expected_pixels;
  for (size_t i = 0; i < a.covered.size(); ++i) {
    if (a.covered[i]) expected_pixels.push_back(static_cast<int32_t>(i));
  }
  ASSERT_EQ(got.pixel_of_query, expected_pixels);
  ASSERT_EQ(q.count(), expected_pixels.size());
  for (int k = 0; k < static_cast<int>(q.count()); ++k) {
    const size_t i = static_cast<size_t>(expected_pixels[static_cast<size_t>(k)]);
    const int x = static_cast<int>(i % a.w), y = static_cast<int>(i / a.w);
    for (int j = 0; j < 3; ++j) {
      ASSERT_EQ(q.position(3 * k + j), a.P[3 * i + j]) << k;
      ASSERT_EQ(q.normal(3 * k + j), a.N[3 * i + j]) << k;
    }
    if (derived_tangent) {
      // P = uv / 2 exactly and N = +z: dp/du from the differences is (1/2, 0, 0) exactly.
      ASSERT_EQ(q.tangent(3 * k), 1.0f) << k;
      ASSERT_EQ(q.tangent(3 * k + 1), 0.0f) << k;
      ASSERT_EQ(q.tangent(3 * k + 2), 0.0f) << k;
    } else {
      for (int j = 0; j < 3; ++j) ASSERT_EQ(q.tangent(3 * k + j), a.T[3 * i + j]) << k;
    }
    ASSERT_EQ(q.uv(2 * k), a.uv[2 * i]);
    ASSERT_EQ(q.uv(2 * k + 1), a.uv[2 * i + 1]);
    const V3 to_eye = Sub(eye, {a.P[3 * i], a.P[3 * i + 1], a.P[3 * i + 2]});
    const V3 wo = Mul(1.0 / std::sqrt(Dot(to_eye, to_eye)), to_eye);
    ASSERT_EQ(q.wo(3 * k), F(wo.x)) << k;
    ASSERT_EQ(q.wo(3 * k + 1), F(wo.y)) << k;
    ASSERT_EQ(q.wo(3 * k + 2), F(wo.z)) << k;
    double dx[2], dy[2];
    ExpectedDerivative(a, x, y, true, dx);
    ExpectedDerivative(a, x, y, false, dy);
    ASSERT_EQ(q.footprint(4 * k), F(dx[0])) << "pixel " << x << "," << y;
    ASSERT_EQ(q.footprint(4 * k + 1), F(dx[1])) << "pixel " << x << "," << y;
    ASSERT_EQ(q.footprint(4 * k + 2), F(dy[0])) << "pixel " << x << "," << y;
    ASSERT_EQ(q.footprint(4 * k + 3), F(dy[1])) << "pixel " << x << "," << y;
  }

  // The preview of the same scene: same pixels; positions, normals, uv and wo agree to float
  // rounding (each side rounds the same double quantity, computed in a different order: a few
  // ulp); footprints agree on pixels with a full 5 x 5 neighbourhood to the central
  // difference's truncation error h^2/6 |f'''| (h = 1 pixel), f''' estimated from the exact uv
  // with the 5-point stencil and taken as the largest over the 3 stencil points, plus the
  // uv rounding (the difference of two float uv, halved: 1 ulp of |uv|) and the preview's own
  // documented accuracy (5e-4 relative, preview_scene.h).
  const PreviewQueries pv = BuildPreviewQueries(shape, a.w, a.h);
  ASSERT_EQ(pv.pixel_of_query, got.pixel_of_query);
  auto ulps = [](float v, double n) {
    return n * std::ldexp(1.0, -23) * std::max(1.0, std::abs(double{v}));
  };
  int checked = 0;
  for (int k = 0; k < static_cast<int>(q.count()); ++k) {
    for (int j = 0; j < 3; ++j) {
      ASSERT_NEAR(q.position(3 * k + j), pv.queries.position(3 * k + j),
                  ulps(q.position(3 * k + j), 4));
      ASSERT_NEAR(q.normal(3 * k + j), pv.queries.normal(3 * k + j), ulps(1.0f, 4));
      ASSERT_NEAR(q.wo(3 * k + j), pv.queries.wo(3 * k + j), ulps(1.0f, 8));
    }
    for (int j = 0; j < 2; ++j) {
      ASSERT_NEAR(q.uv(2 * k + j), pv.queries.uv(2 * k + j), ulps(q.uv(2 * k + j), 4));
    }
    const size_t i = static_cast<size_t>(got.pixel_of_query[static_cast<size_t>(k)]);
    const int x = static_cast<int>(i % a.w), y = static_cast<int>(i / a.w);
    bool full = x >= 3 && y >= 3 && x + 3 < a.w && y + 3 < a.h;
    for (int yy = y - 3; full && yy <= y + 3; ++yy) {
      for (int xx = x - 3; full && xx <= x + 3; ++xx)
        full = a.covered[static_cast<size_t>(yy) * a.w + xx];
    }
    if (!full) continue;
    for (int axis = 0; axis < 2; ++axis) {
      for (int comp = 0; comp < 2; ++comp) {
        auto f = [&](int s) {
          const size_t p = axis == 0 ? i + s : i + static_cast<size_t>(s * a.w);
          return comp == 0 ? a.u_exact[p] : a.v_exact[p];
        };
        double third = 0.0;
        for (int s = -1; s <= 1; ++s) {
          third =
              std::max(third, std::abs(0.5 * (f(s + 2) - 2 * f(s + 1) + 2 * f(s - 1) - f(s - 2))));
        }
        const float central = q.footprint(4 * k + 2 * axis + comp);
        const float jac = pv.queries.footprint(4 * k + 2 * axis + comp);
        const double bound = third / 6.0 + ulps(q.uv(2 * k + comp), 1) + 5e-4 * std::abs(jac);
        ASSERT_NEAR(central, jac, bound) << "pixel " << x << "," << y << " axis " << axis;
      }
    }
    ++checked;
  }
  EXPECT_GT(checked, static_cast<int>(q.count()) / 2) << "too few interior pixels checked";
}

TEST(GBuffer, SphereWithArnoldStyleLayersAndAlphaFollowsTheRulesAndMatchesThePreview) {
  const int w = 96, h = 72;
  const Analytic a = BuildAnalytic(PreviewShape::kSphere, w, h);
  std::vector<float> alpha(a.covered.begin(), a.covered.end());
  const std::string path = TempPath("sphere.exr");
  WriteExr(path, w, h,
           {{{"P.R", "P.G", "P.B"}, &a.P},
            {{"N.X", "N.Y", "N.Z"}, &a.N},
            {{"T.x", "T.y", "T.z"}, &a.T},
            {{"uv.X", "uv.Y"}, &a.uv},
            {{"A"}, &alpha}});
  const GBuffer g = ReadGBuffer(path);
  fs::remove(path);
  EXPECT_EQ(g.width, w);
  EXPECT_EQ(g.height, h);
  EXPECT_TRUE(g.view.empty());
  EXPECT_TRUE(g.footprint.empty());
  const PreviewCamera &c = kSphereCamera;
  const PreviewQueries got = GBufferQueries(g, std::array<double, 3>{c.eye[0], c.eye[1], c.eye[2]});
  CheckAgainstRulesAndPreview(PreviewShape::kSphere, a, got, false);
}

TEST(GBuffer, PlaneWithCyclesStyleLayersNoAlphaNoTangentFollowsTheRulesAndMatchesThePreview) {
  const int w = 128, h = 72;  // 16:9: the whole square with background all around
  const Analytic a = BuildAnalytic(PreviewShape::kPlane, w, h);
  const std::string path = TempPath("plane.exr");
  WriteExr(path, w, h,
           {{{"ViewLayer.Position.X", "ViewLayer.Position.Y", "ViewLayer.Position.Z"}, &a.P},
            {{"ViewLayer.Normal.X", "ViewLayer.Normal.Y", "ViewLayer.Normal.Z"}, &a.N},
            {{"ViewLayer.UV.U", "ViewLayer.UV.V"}, &a.uv}});
  GBufferLayers layers;
  std::string error;
  ASSERT_TRUE(
      ParseLayerMapping("P=ViewLayer.Position,N=ViewLayer.Normal,uv=ViewLayer.UV", &layers, &error))
      << error;
  const GBuffer g = ReadGBuffer(path, layers);
  fs::remove(path);
  EXPECT_TRUE(g.tangent.empty());
  const PreviewCamera &c = kPlaneCamera;
  const PreviewQueries got = GBufferQueries(g, std::array<double, 3>{c.eye[0], c.eye[1], c.eye[2]});
  CheckAgainstRulesAndPreview(PreviewShape::kPlane, a, got, true);
}

TEST(GBuffer, PreviewGBufferReproducesThePreviewQueriesBitForBit) {
  for (PreviewShape shape : {PreviewShape::kSphere, PreviewShape::kPlane}) {
    const PreviewQueries scene = BuildPreviewQueries(shape, 80, 60);
    const std::string path = TempPath("preview.exr");
    WriteGBuffer(path, PreviewGBuffer(scene));
    const PreviewQueries again = GBufferQueries(ReadGBuffer(path), std::nullopt);
    fs::remove(path);
    EXPECT_EQ(again.pixel_of_query, scene.pixel_of_query);
    EXPECT_EQ(again.queries.SerializeAsString(), scene.queries.SerializeAsString());
  }
}

TEST(GBuffer, HalfFloatNormalsAreNormalisedAndTangentsOrthogonalised) {
  // Half-float N and T (a renderer's default for AOVs) are not unit to float rounding.
  const int w = 32, h = 24;
  const Analytic a = BuildAnalytic(PreviewShape::kSphere, w, h);
  std::vector<float> alpha(a.covered.begin(), a.covered.end());
  const std::string path = TempPath("half.exr");
  WriteExr(path, w, h,
           {{{"P.X", "P.Y", "P.Z"}, &a.P},
            {{"N.X", "N.Y", "N.Z"}, &a.N, Imf::HALF},
            {{"T.X", "T.Y", "T.Z"}, &a.T, Imf::HALF},
            {{"uv.U", "uv.V"}, &a.uv},
            {{"A"}, &alpha}});
  const PreviewQueries got = GBufferQueries(ReadGBuffer(path), std::array<double, 3>{0, -4, 1.2});
  fs::remove(path);
  ASSERT_GT(got.queries.count(), 0u);
  int renormalised = 0;
  for (int k = 0; k < static_cast<int>(got.queries.count()); ++k) {
    const V3 n{got.queries.normal(3 * k), got.queries.normal(3 * k + 1),
               got.queries.normal(3 * k + 2)};
    const V3 t{got.queries.tangent(3 * k), got.queries.tangent(3 * k + 1),
               got.queries.tangent(3 * k + 2)};
    // Used as written only when unit / orthogonal to kGBufferUnitSlack, else normalised in
    // double and rounded to float (2^-24 per component): unit and orthogonal to the slack.
    EXPECT_NEAR(std::sqrt(Dot(n, n)), 1.0, kGBufferUnitSlack) << k;
    EXPECT_NEAR(std::sqrt(Dot(t, t)), 1.0, kGBufferUnitSlack) << k;
    EXPECT_NEAR(Dot(n, t), 0.0, kGBufferUnitSlack) << k;
    // Half rounding moves a unit vector by at most 2^-11 per component.
    const size_t i = static_cast<size_t>(got.pixel_of_query[static_cast<size_t>(k)]);
    EXPECT_NEAR(n.x, a.N[3 * i], 2e-3);
    const V3 stored{float(Imath::half(a.N[3 * i])), float(Imath::half(a.N[3 * i + 1])),
                    float(Imath::half(a.N[3 * i + 2]))};
    if (std::abs(std::sqrt(Dot(stored, stored)) - 1.0) > kGBufferUnitSlack) ++renormalised;
  }
  EXPECT_GT(renormalised, 0) << "no stored normal needed normalising: the test checks nothing";
}

TEST(GBuffer, UvSeamAndSilhouetteUseOneSidedDifferences) {
  // One row of 7 pixels on the plane z = 0: u = 0.25 x wrapping by -8 between x = 3 and 4 (a
  // texture seam), v = 0.5; pixel 6 is background. Expected du/dx per the documented rule:
  //   x = 0 (image edge): one-sided +, x = 1, 2: central, x = 3: the uv jumps on the + side, so
  //   the - side; x = 4: jump on the - side, so +; x = 5: its + neighbour is background, so -.
  GBuffer g;
  g.width = 7;
  g.height = 1;
  g.data_window = g.display_window = {0, 0, 6, 0};
  g.source = "row";
  for (int x = 0; x < 7; ++x) {
    const bool covered = x < 6;
    const float u = 0.25f * static_cast<float>(x) - (x >= 4 ? 8.0f : 0.0f);
    g.position.insert(g.position.end(), {0.1f * static_cast<float>(x), 0.0f, 0.0f});
    g.normal.insert(g.normal.end(), {0.0f, 0.0f, covered ? 1.0f : 0.0f});
    g.uv.insert(g.uv.end(), {u, 0.5f});
  }
  const PreviewQueries q = GBufferQueries(g, std::array<double, 3>{0, -1, 1});
  ASSERT_EQ(q.queries.count(), 6u);
  const float expected[6] = {0.25f, 0.25f, 0.25f, 0.25f, 0.25f, 0.25f};
  for (int k = 0; k < 6; ++k) {
    EXPECT_EQ(q.queries.footprint(4 * k), expected[k]) << "x = " << k;
    EXPECT_EQ(q.queries.footprint(4 * k + 1), 0.0f) << "x = " << k;
    EXPECT_EQ(q.queries.footprint(4 * k + 2), 0.0f) << "x = " << k;  // no row above or below
    // dp/du = (0.1 / 0.25, 0, 0) along +x: tangent +x (J is singular here, du/dy = dv/dy = 0,
    // so the fallback axis; also +x for n = +z).
    EXPECT_EQ(q.queries.tangent(3 * k), 1.0f) << "x = " << k;
  }
}

// ---- Refusals -------------------------------------------------------------------------------

std::string RefusalOf(const std::string &path, const GBufferLayers &layers = {},
                      std::optional<std::array<double, 3>> camera = std::array<double, 3>{0, -4,
                                                                                          1}) {
  try {
    GBufferQueries(ReadGBuffer(path, layers), camera);
  } catch (const std::runtime_error &e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(GBuffer, MalformedFilesAreRefusedNamingFileLayerAndPixel) {
  const int w = 16, h = 12;
  const Analytic a = BuildAnalytic(PreviewShape::kSphere, w, h);
  std::vector<float> alpha(a.covered.begin(), a.covered.end());
  const std::string path = TempPath("bad.exr");
  const Layer P{{"P.X", "P.Y", "P.Z"}, &a.P}, N{{"N.X", "N.Y", "N.Z"}, &a.N},
      UV{{"uv.U", "uv.V"}, &a.uv}, A{{"A"}, &alpha};

  WriteExr(path, w, h, {P, UV, A});  // no normal
  std::string m = RefusalOf(path);
  EXPECT_NE(m.find(path), std::string::npos) << m;
  EXPECT_NE(m.find("no layer 'N'"), std::string::npos) << m;
  EXPECT_NE(m.find("P.X, P.Y, P.Z"), std::string::npos) << m;  // lists what the file has

  WriteExr(path, w, h, {P, N, {{"uv.U", "uv.W"}, &a.uv}, A});  // half a uv layer
  m = RefusalOf(path);
  EXPECT_NE(m.find("layer 'uv'"), std::string::npos) << m;
  EXPECT_NE(m.find("incomplete: has uv.U"), std::string::npos) << m;

  std::vector<float> fp(4 * static_cast<size_t>(w) * h, 0.0f);
  WriteExr(path, w, h, {P, N, UV, A, {{"dudx", "dvdx", "dudy"}, &fp}});  // 3 of 4
  m = RefusalOf(path);
  EXPECT_NE(m.find("footprint channels are incomplete"), std::string::npos) << m;

  // Mismatched sizes: a layer stored at half resolution (x/y sampling 2).
  WriteExr(path, w, h, {P, N, A, {{"uv.U", "uv.V"}, &a.uv, Imf::FLOAT, 2}});
  m = RefusalOf(path);
  EXPECT_NE(m.find(path), std::string::npos) << m;
  EXPECT_NE(m.find("'uv.U' is subsampled (2x2)"), std::string::npos) << m;

  // NaN in a covered pixel; the same NaN in a background pixel is ignored.
  size_t covered = 0, background = 0;
  for (size_t i = 0; i < a.covered.size(); ++i) (a.covered[i] ? covered : background) = i;
  std::vector<float> bad = a.P;
  bad[3 * background + 1] = std::numeric_limits<float>::quiet_NaN();
  WriteExr(path, w, h, {{{"P.X", "P.Y", "P.Z"}, &bad}, N, UV, A});
  EXPECT_EQ(RefusalOf(path), "(accepted)");
  bad[3 * covered + 1] = std::numeric_limits<float>::quiet_NaN();
  WriteExr(path, w, h, {{{"P.X", "P.Y", "P.Z"}, &bad}, N, UV, A});
  m = RefusalOf(path);
  const std::string where = "layer P.X,P.Y,P.Z: pixel (" + std::to_string(covered % w) + ", " +
                            std::to_string(covered / w) + ") is not finite";
  EXPECT_NE(m.find(where), std::string::npos) << m;

  WriteExr(path, w, h, {P, N, UV, A});  // no camera, no V layer
  m = RefusalOf(path, {}, std::nullopt);
  EXPECT_NE(m.find("no view-vector layer"), std::string::npos) << m;

  // Two parts with different sizes: refused rather than silently reading the first.
  {
    Imf::Header h1(w, h), h2(w, h);
    h2.dataWindow() = Imath::Box2i(Imath::V2i(0, 0), Imath::V2i(w / 2 - 1, h / 2 - 1));
    h1.setName("gbuffer");
    h2.setName("small");
    h1.setType(Imf::SCANLINEIMAGE);
    h2.setType(Imf::SCANLINEIMAGE);
    h1.channels().insert("P.X", Imf::Channel(Imf::FLOAT));
    h2.channels().insert("N.X", Imf::Channel(Imf::FLOAT));
    std::vector<float> z1(static_cast<size_t>(w) * h), z2(static_cast<size_t>(w) * h);
    Imf::MultiPartOutputFile file(path.c_str(), std::vector<Imf::Header>{h1, h2}.data(), 2);
    Imf::OutputPart p1(file, 0), p2(file, 1);
    Imf::FrameBuffer f1, f2;
    f1.insert("P.X", Imf::Slice(Imf::FLOAT, reinterpret_cast<char *>(z1.data()), 4, 4 * w));
    f2.insert("N.X", Imf::Slice(Imf::FLOAT, reinterpret_cast<char *>(z2.data()), 4, 4 * (w / 2)));
    p1.setFrameBuffer(f1);
    p1.writePixels(h);
    p2.setFrameBuffer(f2);
    p2.writePixels(h / 2);
  }
  m = RefusalOf(path);
  EXPECT_NE(m.find("multi-part"), std::string::npos) << m;

  std::ofstream(path) << "not an exr";
  m = RefusalOf(path);
  EXPECT_NE(m.find(path + ": cannot read as OpenEXR"), std::string::npos) << m;
  fs::remove(path);

  GBufferLayers layers;
  std::string error;
  EXPECT_FALSE(ParseLayerMapping("P=Pos,Q=x", &layers, &error));
  EXPECT_NE(error.find("unknown key 'Q'"), std::string::npos) << error;
  EXPECT_FALSE(ParseLayerMapping("P=Pos,P=x", &layers, &error));
  EXPECT_NE(error.find("given twice"), std::string::npos) << error;
  EXPECT_FALSE(ParseLayerMapping("Pos", &layers, &error));
}

}  // namespace
}  // namespace glint::client
