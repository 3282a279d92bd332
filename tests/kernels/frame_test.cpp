// kernels/frame.h (fp64): the shading frame is orthonormal and right-handed, maps the normal to
// +z and the tangent into +x (DESIGN.md conventions), and through models/smooth/smooth_eval.h the
// tangent is the alpha_x axis of the BRDF. References: an independent Gram-Schmidt in double
// (reference.h vectors) and exact frames.
#include <gtest/gtest.h>

#include <cassert>
#include <cmath>
#include <string>
#include <vector>

#include "kernel_api.h"
#include "reference.h"

namespace k64 {
#define GLINT_USE_DOUBLE 1
#include "models/smooth/smooth_eval.h"
}  // namespace k64

namespace glint_test {
namespace {

k64::real3 to_k(Vec3 v) {
  return k64::make_real3(v.x, v.y, v.z);
}
Vec3 from_k(k64::real3 v) {
  return {v.x, v.y, v.z};
}

constexpr double kTol = 1e-14;

void expect_vec_near(Vec3 got, Vec3 expected, double tol, const std::string &what) {
  EXPECT_NEAR(got.x, expected.x, tol) << what << ": got " << got << " expected " << expected;
  EXPECT_NEAR(got.y, expected.y, tol) << what << ": got " << got << " expected " << expected;
  EXPECT_NEAR(got.z, expected.z, tol) << what << ": got " << got << " expected " << expected;
}

// A random normal of random length and a random tangent that is not within ~8 deg of it (the
// validation limit is the server's business; the frame must be exact for any such pair).
struct NormalTangent {
  Vec3 normal, tangent;
};

std::vector<NormalTangent> random_pairs(int n) {
  ref::Rng rng(23);
  std::vector<NormalTangent> out;
  while (static_cast<int>(out.size()) < n) {
    Vec3 nrm = ref::scale(rng.sphere(), rng.uniform(0.1, 10.0));
    Vec3 tan = ref::scale(rng.sphere(), rng.uniform(0.1, 10.0));
    if (std::fabs(ref::dot(ref::normalized(nrm), ref::normalized(tan))) > 0.99) continue;
    out.push_back({nrm, tan});
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// 10. Orthonormal, right-handed, normal -> +z, tangent -> +x after Gram-Schmidt.
TEST(KernelFrame, OrthonormalAndRightHanded) {
  for (const auto &[nrm, tan] : random_pairs(2000)) {
    k64::ShadingFrame f = k64::frame_from_normal_tangent(to_k(nrm), to_k(tan));
    Vec3 t = from_k(f.t), b = from_k(f.b), n = from_k(f.n);
    SCOPED_TRACE(::testing::Message() << "normal " << nrm << " tangent " << tan);
    EXPECT_NEAR(ref::norm(t), 1.0, kTol);
    EXPECT_NEAR(ref::norm(b), 1.0, kTol);
    EXPECT_NEAR(ref::norm(n), 1.0, kTol);
    EXPECT_NEAR(ref::dot(t, b), 0.0, kTol);
    EXPECT_NEAR(ref::dot(t, n), 0.0, kTol);
    EXPECT_NEAR(ref::dot(b, n), 0.0, kTol);
    // Right-handed: t x b = n, i.e. det[t b n] = +1.
    expect_vec_near(ref::cross(t, b), n, kTol, "t x b");
    EXPECT_NEAR(ref::dot(ref::cross(t, b), n), 1.0, kTol);
  }
}

TEST(KernelFrame, NormalMapsToZAndTangentToX) {
  for (const auto &[nrm, tan] : random_pairs(2000)) {
    k64::ShadingFrame f = k64::frame_from_normal_tangent(to_k(nrm), to_k(tan));
    SCOPED_TRACE(::testing::Message() << "normal " << nrm << " tangent " << tan);
    // The (unit) normal is local +z; the raw normal keeps its length.
    expect_vec_near(from_k(k64::frame_to_local(f, to_k(ref::normalized(nrm)))), {0, 0, 1}, kTol,
                    "unit normal");
    expect_vec_near(from_k(k64::frame_to_local(f, to_k(nrm))), {0, 0, ref::norm(nrm)},
                    kTol * ref::norm(nrm), "normal");
    // Independent Gram-Schmidt: the tangent's component orthogonal to n is local +x ...
    Vec3 n_hat = ref::normalized(nrm);
    Vec3 t_perp = ref::normalized(ref::add(tan, ref::scale(n_hat, -ref::dot(n_hat, tan))));
    expect_vec_near(from_k(k64::frame_to_local(f, to_k(t_perp))), {1, 0, 0}, kTol,
                    "orthogonalised tangent");
    // ... so the raw tangent lies in the local x-z half-plane with x > 0.
    Vec3 t_local = from_k(k64::frame_to_local(f, to_k(tan)));
    EXPECT_NEAR(t_local.y, 0.0, kTol * ref::norm(tan));
    EXPECT_GT(t_local.x, 0.0);
    // And n x t_perp is local +y.
    expect_vec_near(from_k(k64::frame_to_local(f, to_k(ref::cross(n_hat, t_perp)))), {0, 1, 0},
                    kTol, "n x t");
  }
}

// A rotation preserves lengths and angles: dot products survive frame_to_local.
TEST(KernelFrame, PreservesDotProducts) {
  ref::Rng rng(29);
  for (const auto &[nrm, tan] : random_pairs(500)) {
    k64::ShadingFrame f = k64::frame_from_normal_tangent(to_k(nrm), to_k(tan));
    Vec3 u = ref::scale(rng.sphere(), 3.0), v = rng.sphere();
    Vec3 lu = from_k(k64::frame_to_local(f, to_k(u))), lv = from_k(k64::frame_to_local(f, to_k(v)));
    EXPECT_NEAR(ref::dot(lu, lv), ref::dot(u, v), 4 * kTol)
        << "normal " << nrm << " tangent " << tan;
    EXPECT_NEAR(ref::norm(lu), 3.0, 4 * kTol) << "normal " << nrm << " tangent " << tan;
  }
}

TEST(KernelFrame, KnownFrames) {
  // The identity frame.
  k64::ShadingFrame id = k64::frame_from_normal_tangent(to_k({0, 0, 1}), to_k({1, 0, 0}));
  expect_vec_near(from_k(k64::frame_to_local(id, to_k({0.3, -0.4, 0.5}))), {0.3, -0.4, 0.5}, 0.0,
                  "identity");
  // Tangent along world +y: local x = world y, local y = n x t = z x y = -x.
  k64::ShadingFrame ty = k64::frame_from_normal_tangent(to_k({0, 0, 2}), to_k({0, 3, 0}));
  expect_vec_near(from_k(k64::frame_to_local(ty, to_k({0.3, -0.4, 0.5}))), {-0.4, -0.3, 0.5}, 0.0,
                  "tangent +y");
  // Normal along world +x, tangent along world +y: local (x, y, z) = world (y, z, x).
  k64::ShadingFrame nx = k64::frame_from_normal_tangent(to_k({1, 0, 0}), to_k({0, 1, 0}));
  expect_vec_near(from_k(k64::frame_to_local(nx, to_k({0.3, -0.4, 0.5}))), {-0.4, 0.5, 0.3}, 0.0,
                  "normal +x");
}

// ---------------------------------------------------------------------------------------------
// Through the per-query evaluation: the tangent is the alpha_x axis, and framed probes equal the
// local BRDF of the directions expressed in an independently built frame.

// Parameters are float-exact, like the engine's packed material block, so the framed path
// (which reads the packed floats) and the reference see the same numbers.
k64::SmoothMaterial material(int ndf, double ax, double ay) {
  auto f = [](double x) { return double(float(x)); };
  k64::SmoothMaterial m;
  m.ndf = ndf;
  m.alpha_x = f(ax);
  m.alpha_y = f(ay);
  m.fresnel.kind = kFresnelConductor;
  m.fresnel.a = k64::make_real3(f(0.143), f(0.374), f(1.442));
  m.fresnel.b = k64::make_real3(f(3.983), f(2.385), f(1.603));
  return m;
}

// One framed probe through smooth_query (inputs are float arrays, as on the wire, and the
// material is packed as the engine packs it).
Vec3 framed_probe(const k64::SmoothMaterial &m, Vec3 wi, Vec3 wo, Vec3 normal, Vec3 tangent) {
  const float wo_f[3] = {float(wo.x), float(wo.y), float(wo.z)};
  const float wi_f[3] = {float(wi.x), float(wi.y), float(wi.z)};
  const float p_f[3] = {0.0f, 0.0f, 0.0f};
  const float n_f[3] = {float(normal.x), float(normal.y), float(normal.z)};
  const float t_f[3] = {float(tangent.x), float(tangent.y), float(tangent.z)};
  k64::EvalSpec spec = {};
  spec.ndf = m.ndf;
  spec.fresnel = m.fresnel.kind;
  spec.probe = 1;
  spec.has_frame = 1;
  const float material[GLINT_MATERIAL_FLOATS] = {
      float(m.alpha_x),     float(m.alpha_y),     float(m.fresnel.a.x), float(m.fresnel.a.y),
      float(m.fresnel.a.z), float(m.fresnel.b.x), float(m.fresnel.b.y), float(m.fresnel.b.z)};
  k64::KernelInputs q = {};
  q.n = 1;
  q.wo = wo_f;
  q.wi = wi_f;
  q.position = p_f;
  q.normal = n_f;
  q.tangent = t_f;
  q.material = material;
  return from_k(k64::smooth_query(spec, q, 0));
}

TEST(KernelSmoothEval, TangentIsTheAlphaXAxis) {
  // With the tangent along world +y, local = (wy, -wx, wz), so the framed BRDF with (ax, ay)
  // is the world-frame BRDF with the roughnesses swapped. Directions are float-exact.
  constexpr double kRelTol = 1e-12;
  constexpr int kPairs = 500;
  ref::Rng rng(31);
  for (int ndf : {kNdfGgx, kNdfBeckmann}) {
    int anisotropy_visible = 0;
    for (int i = 0; i < kPairs; ++i) {
      Vec3 wo = ref::round_to_float(rng.direction(0.1, 1.0));
      Vec3 wi = ref::round_to_float(rng.direction(0.1, 1.0));
      Vec3 got = framed_probe(material(ndf, 0.1, 0.5), wi, wo, {0, 0, 1}, {0, 1, 0});
      auto world = [&](double ax, double ay) {
        return from_k(k64::smooth_reflect_cos(material(ndf, ax, ay), k64::r3_normalize(to_k(wi)),
                                              k64::r3_normalize(to_k(wo))));
      };
      Vec3 expected = world(0.5, 0.1);
      EXPECT_NEAR(got.x, expected.x, kRelTol * expected.x) << "wi " << wi << " wo " << wo;
      EXPECT_NEAR(got.z, expected.z, kRelTol * expected.z) << "wi " << wi << " wo " << wo;
      if (std::fabs(world(0.1, 0.5).x - expected.x) > 1e-3 * expected.x) ++anisotropy_visible;
    }
    // The check is not vacuous: for most pairs, swapping the roughnesses changes the value.
    EXPECT_GT(anisotropy_visible, kPairs / 2) << ndf_name(ndf);
  }
}

TEST(KernelSmoothEval, FramedProbeMatchesIndependentlyBuiltFrame) {
  constexpr double kRelTol = 1e-9;
  ref::Rng rng(37);
  const auto frames = random_pairs(300);
  for (int ndf : {kNdfGgx, kNdfBeckmann}) {
    for (const auto &[nrm0, tan0] : frames) {
      // The wire carries floats: build the reference frame from the same rounded vectors.
      Vec3 nrm = ref::round_to_float(nrm0), tan = ref::round_to_float(tan0);
      Vec3 n = ref::normalized(nrm);
      Vec3 t = ref::normalized(ref::add(tan, ref::scale(n, -ref::dot(n, tan))));
      Vec3 b = ref::cross(n, t);
      // World directions above the shading plane.
      Vec3 lo = rng.direction(0.1, 1.0), li = rng.direction(0.1, 1.0);
      auto to_world = [&](Vec3 l) {
        return ref::add(ref::add(ref::scale(t, l.x), ref::scale(b, l.y)), ref::scale(n, l.z));
      };
      Vec3 wo = ref::round_to_float(to_world(lo)), wi = ref::round_to_float(to_world(li));
      auto to_local = [&](Vec3 w) {
        Vec3 u = ref::normalized(w);
        return Vec3{ref::dot(u, t), ref::dot(u, b), ref::dot(u, n)};
      };
      const k64::SmoothMaterial m = material(ndf, 0.15, 0.4);
      Vec3 got = framed_probe(m, wi, wo, nrm, tan);
      Vec3 h = ref::normalized(ref::add(to_local(wi), to_local(wo)));
      if (ndf == kNdfBeckmann &&
          ref::beckmann_exponent(ref::theta_of(h), ref::phi_of(h), 0.15, 0.4) > 79.99) {
        continue;  // beyond the documented D cut-off (tested in smooth_brdf_test)
      }
      // The reference takes the material's float-exact values (see material()).
      auto f = [](double x) { return double(float(x)); };
      Vec3 expected = ref::brdf_cos({ndf,
                                     f(0.15),
                                     f(0.4),
                                     kFresnelConductor,
                                     {f(0.143), f(0.374), f(1.442)},
                                     {f(3.983), f(2.385), f(1.603)}},
                                    to_local(wi), to_local(wo));
      EXPECT_NEAR(got.x, expected.x, kRelTol * expected.x + 1e-300)
          << "normal " << nrm << " tangent " << tan << " wi " << wi << " wo " << wo;
      EXPECT_NEAR(got.z, expected.z, kRelTol * expected.z + 1e-300)
          << "normal " << nrm << " tangent " << tan << " wi " << wi << " wo " << wo;
    }
  }
}

}  // namespace
}  // namespace glint_test
