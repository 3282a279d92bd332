// kernels/ndf.h against independent double references: D normalisation and the visible-normal
// (masking) identity by deterministic quadrature, D and Lambda against closed forms written in
// (theta, phi) form, and the height-correlated G2.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "kernel_api.h"
#include "reference.h"

namespace glint_test {
namespace {

using ref::kPi;


// Isotropic and anisotropic roughness pairs, both orientations of the anisotropy so that an
// alpha_x / alpha_y swap in the kernel would show up in the pointwise tests.
constexpr Alphas kAlphas[] = {{1e-3, 1e-3}, {0.05, 0.05}, {0.2, 0.2}, {0.5, 0.5},
                              {1.0, 1.0},   {0.1, 0.6},   {0.6, 0.1}, {0.02, 0.5}};

// Quadrature sizes: trapezoid in the elliptical azimuth psi (periodic, spectrally accurate),
// Gauss-Legendre in the lobe-scaled polar variable u (reference.h). Measured: the normalisation
// integrals come out within 2e-16 of 1 (the elliptical map makes their azimuthal integrand
// constant); the visible-normal identity within 2e-10, limited by the azimuthal rule at
// theta_o = 89 deg (1e-13 with 256 nodes).
constexpr int kPhiNodes = 128;
constexpr int kUNodes = 96;

// ---------------------------------------------------------------------------------------------
// The integrator itself, on integrands with known integrals, so that a failure below points at
// the kernel and not at the quadrature.
TEST(KernelQuadrature, IntegratesKnownHemisphereIntegrals) {
  constexpr double kTol = 1e-12;
  const ref::Rule psi = ref::periodic_trapezoid(kPhiNodes, 0.0);
  auto full = [](double) { return kPi / 2; };
  // Plain (theta, phi) rule (ax = ay = 1): ∫ dω = 2 pi, ∫ cos dω = pi,
  // ∫ cos^3 sin^2 cos^2(phi) dω = pi B(2, 2) / 2 = pi / 12, and a cap theta <= 60 deg of area 2 pi
  // (1 - cos 60).
  auto one = [](Vec3) { return 1.0; };
  EXPECT_NEAR(ref::integrate_hemisphere(psi, kUNodes, 1.0, 1.0, full, one), 2 * kPi, kTol);
  EXPECT_NEAR(ref::integrate_hemisphere(psi, kUNodes, 1.0, 1.0, full, [](Vec3 h) { return h.z; }),
              kPi, kTol);
  EXPECT_NEAR(ref::integrate_hemisphere(psi, kUNodes, 1.0, 1.0, full,
                                        [](Vec3 h) { return h.z * h.z * h.z * h.x * h.x; }),
              kPi / 12, kTol);
  EXPECT_NEAR(ref::integrate_hemisphere(
                  psi, kUNodes, 1.0, 1.0, [](double) { return kPi / 3; }, one),
              kPi, kTol);
  // Lobe-adapted rule: the reference NDFs of reference.h are normalised analytically (the
  // slope-space densities are a bivariate Student-t and a Gaussian), so ∫ D cos dω = 1 checks the
  // elliptical map and the polar substitution, including the Jacobians, at every roughness.
  for (const Alphas a : kAlphas) {
    for (int ndf : kNdfs) {
      double integral = ref::integrate_hemisphere(
          psi, kUNodes, a.x, a.y, full, [&](Vec3 h) { return ref::D(ndf, h, a.x, a.y) * h.z; });
      EXPECT_NEAR(integral, 1.0, kTol) << ndf_name(ndf) << " alpha (" << a.x << ", " << a.y << ")";
    }
  }
}

// ---------------------------------------------------------------------------------------------
// 1. Normalisation of the projected microfacet area (Heitz 2014 Eq. 4):
//      ∫_H D(h) cos(theta_h) dω_h = 1.
TEST(KernelNdf, ProjectedAreaIsNormalised) {
  constexpr double kTol = 1e-10;  // achieved: ~1e-16 (see the printout)
  const ref::Rule psi = ref::periodic_trapezoid(kPhiNodes, 0.0);
  double worst = 0.0;
  for (int ndf : kNdfs) {
    for (const Alphas a : kAlphas) {
      double integral = ref::integrate_hemisphere(
          psi, kUNodes, a.x, a.y, [](double) { return kPi / 2; },
          [&](Vec3 h) { return f64::ndf_D(ndf, h, a.x, a.y) * h.z; });
      worst = std::max(worst, std::fabs(integral - 1.0));
      EXPECT_NEAR(integral, 1.0, kTol) << ndf_name(ndf) << " alpha (" << a.x << ", " << a.y << ")";
    }
  }
  std::printf("[ info ] NDF normalisation: max |∫D cos - 1| = %.2e\n", worst);
}

// D at random microfacet normals against the (theta, phi) closed forms: this is what pins the
// orientation (alpha_x along the tangent +x), which the normalisation cannot see.
TEST(KernelNdf, MatchesClosedFormPointwise) {
  constexpr double kRelTol = 1e-12;
  constexpr int kSamples = 2000;
  ref::Rng rng(7);
  for (int ndf : kNdfs) {
    for (const Alphas a : kAlphas) {
      for (int i = 0; i < kSamples; ++i) {
        // Half of the normals inside the lobe (tan theta up to 4 alpha), half anywhere.
        double phi = rng.uniform(0.0, 2 * kPi);
        double theta = (i % 2 == 0) ? std::atan(4.0 * std::max(a.x, a.y) * rng.uniform())
                                    : std::acos(rng.uniform(0.01, 1.0));
        Vec3 h = ref::from_angles(theta, phi);
        double expected = ref::D(ndf, h, a.x, a.y);
        double got = f64::ndf_D(ndf, h, a.x, a.y);
        if (ndf == kNdfBeckmann && ref::beckmann_exponent(theta, phi, a.x, a.y) > 80.0 - 1e-9) {
          // The kernel flushes D to 0 once exp(-t^2) < exp(-80) (documented cut-off).
          EXPECT_TRUE(got == 0.0 || ref::rel_err(got, expected) < kRelTol)
              << ndf_name(ndf) << " alpha (" << a.x << ", " << a.y << ") h " << h;
          continue;
        }
        EXPECT_LT(ref::rel_err(got, expected), kRelTol)
            << ndf_name(ndf) << " alpha (" << a.x << ", " << a.y << ") h " << h << " got " << got
            << " expected " << expected;
      }
    }
  }
  // Below the horizon there are no microfacets.
  for (int ndf : kNdfs) {
    EXPECT_EQ(f64::ndf_D(ndf, {1.0, 0.0, 0.0}, 0.3, 0.3), 0.0);
    EXPECT_EQ(f64::ndf_D(ndf, {0.6, 0.0, -0.8}, 0.3, 0.3), 0.0);
  }
}

// ---------------------------------------------------------------------------------------------
// 2. Masking: Lambda from the kernel against closed forms, and the visible-normal normalisation
//    (Heitz 2014 Eq. 2 with G1 = 1 / (1 + Lambda), Eq. 43):
//      ∫_H G1(wo) max(0, wo.h) D(h) dω_h = cos(theta_o).
// The domain wo.h >= 0 is split at the azimuths where it starts cutting the hemisphere, so the
// integrand is smooth on each piece: for cos(phi - phi_o) >= 0 all theta <= pi/2 qualify; for
// the other half, wo.h = A cos(theta - delta) with tan(delta) = tan(theta_o) cos(phi - phi_o)
// gives theta <= pi/2 + delta.
constexpr double kViewDegrees[] = {0, 20, 45, 60, 70, 80, 85, 88, 89};
constexpr double kViewAzimuths[] = {0.0, 0.6, kPi / 2, 2.2, 4.0};

double visible_normal_integral(int ndf, Alphas a, double theta_o, double phi_o) {
  Vec3 wo = ref::from_angles(theta_o, phi_o);
  auto g = [&](Vec3 h) { return f64::ndf_D(ndf, h, a.x, a.y) * std::max(0.0, ref::dot(wo, h)); };
  auto delta = [&](double p) {
    return std::atan2(std::sin(theta_o) * std::cos(p - phi_o), std::cos(theta_o));
  };
  auto psi = [&](double p) { return ref::psi_of_phi(p, a.x, a.y); };
  const ref::Rule front =
      ref::gauss_legendre(kPhiNodes, psi(phi_o - kPi / 2), psi(phi_o + kPi / 2));
  const ref::Rule back =
      ref::gauss_legendre(kPhiNodes, psi(phi_o + kPi / 2), psi(phi_o + 3 * kPi / 2));
  double i_front = ref::integrate_hemisphere(
      front, kUNodes, a.x, a.y, [](double) { return kPi / 2; }, g);
  double i_back = ref::integrate_hemisphere(
      back, kUNodes, a.x, a.y, [&](double p) { return kPi / 2 + std::min(0.0, delta(p)); }, g);
  return i_front + i_back;
}

TEST(KernelMasking, LambdaMatchesClosedForm) {
  // Relative tolerance, plus an absolute floor for the reference's own cancellation in
  // -1 + sqrt(1 + x) (GGX) and erf(a) - 1 (Beckmann) when Lambda is tiny; an error of 1e-15 in
  // Lambda is an error of 1e-15 in G1.
  constexpr double kRelTol = 1e-10;
  constexpr double kAbsFloor = 1e-15;
  for (int ndf : kNdfs) {
    for (const Alphas a : kAlphas) {
      for (double deg : kViewDegrees) {
        for (double phi_o : kViewAzimuths) {
          double theta_o = deg * kPi / 180.0;
          Vec3 wo = ref::from_angles(theta_o, phi_o);
          double lambda_kernel = f64::z_lambda(ndf, wo, a.x, a.y) / wo.z;
          double lambda_ref = ndf == kNdfBeckmann ? ref::lambda_beckmann(theta_o, phi_o, a.x, a.y)
                                                  : ref::lambda_ggx(theta_o, phi_o, a.x, a.y);
          EXPECT_NEAR(lambda_kernel, lambda_ref, kRelTol * lambda_ref + kAbsFloor)
              << ndf_name(ndf) << " alpha (" << a.x << ", " << a.y << ") theta_o " << deg
              << " deg phi_o " << phi_o;
          EXPECT_GE(lambda_kernel, 0.0);
        }
      }
    }
  }
}

TEST(KernelMasking, VisibleNormalsIntegrateToCosTheta) {
  constexpr double kRelTol = 1e-8;  // of cos(theta_o); achieved: 2e-10 (see the printout)
  double worst = 0.0;
  for (int ndf : kNdfs) {
    for (const Alphas a : kAlphas) {
      for (double deg : kViewDegrees) {
        for (double phi_o : {0.0, 0.6, kPi / 2}) {
          double theta_o = deg * kPi / 180.0;
          Vec3 wo = ref::from_angles(theta_o, phi_o);
          double g1 = 1.0 / (1.0 + f64::z_lambda(ndf, wo, a.x, a.y) / wo.z);
          double projected = g1 * visible_normal_integral(ndf, a, theta_o, phi_o);
          double err = std::fabs(projected - wo.z) / wo.z;
          worst = std::max(worst, err);
          EXPECT_LT(err, kRelTol) << ndf_name(ndf) << " alpha (" << a.x << ", " << a.y
                                  << ") theta_o " << deg << " deg phi_o " << phi_o
                                  << ": G1 ∫ D <wo,h> = " << projected << ", cos = " << wo.z;
        }
      }
    }
  }
  std::printf("[ info ] visible-normal identity: max relative error = %.2e\n", worst);
}

// ---------------------------------------------------------------------------------------------
// 5. Height-correlated G2 = 4 cos_o cos_i V (Heitz 2014 Eq. 99).
double g2_kernel(int ndf, Vec3 wo, Vec3 wi, Alphas a) {
  return 4.0 * wo.z * wi.z * f64::visibility(ndf, wo, wi, a.x, a.y);
}

TEST(KernelG2, SymmetricBoundedAndMatchesClosedForm) {
  constexpr double kRelTol = 1e-12;
  // Rounding slack for the (in)equalities, relative: when one Lambda is ~0, G2 equals G1 of the
  // other direction up to a few ulp.
  constexpr double kSlack = 1e-14;
  constexpr int kSamples = 2000;
  ref::Rng rng(11);
  for (int ndf : kNdfs) {
    for (const Alphas a : kAlphas) {
      for (int i = 0; i < kSamples; ++i) {
        Vec3 wo = rng.direction(0.01, 1.0), wi = rng.direction(0.01, 1.0);
        double g2 = g2_kernel(ndf, wo, wi, a);
        double g2_swapped = g2_kernel(ndf, wi, wo, a);
        double lo = ref::lambda(ndf, wo, a.x, a.y), li = ref::lambda(ndf, wi, a.x, a.y);
        double g1o = 1.0 / (1.0 + lo), g1i = 1.0 / (1.0 + li);
        SCOPED_TRACE(::testing::Message() << ndf_name(ndf) << " alpha (" << a.x << ", " << a.y
                                          << ") wo " << wo << " wi " << wi << " G2 " << g2);
        EXPECT_GE(g2, 0.0);
        EXPECT_LE(g2, 1.0 + kSlack);
        EXPECT_NEAR(g2, g2_swapped, kSlack * g2);
        EXPECT_LT(ref::rel_err(g2, 1.0 / (1.0 + lo + li)), kRelTol);
        // Height correlation lies between independent masking-shadowing and the weaker of the
        // two: G1o G1i <= G2 <= min(G1o, G1i).
        EXPECT_GE(g2, g1o * g1i * (1.0 - kSlack));
        EXPECT_LE(g2, std::min(g1o, g1i) * (1.0 + kSlack));
      }
    }
  }
}

TEST(KernelG2, TendsToOneAtNormalIncidenceAndSmallAlpha) {
  for (int ndf : kNdfs) {
    for (double alpha : {1e-4, 1e-3, 0.05, 0.5, 1.0}) {
      // Exactly at the normal, Lambda = 0 for every roughness.
      Vec3 n = {0.0, 0.0, 1.0};
      EXPECT_NEAR(g2_kernel(ndf, n, n, {alpha, alpha}), 1.0, 1e-15) << ndf_name(ndf) << alpha;
    }
    // Near the normal with a smooth surface, almost nothing is masked: GGX Lambda ~
    // alpha^2 tan^2(theta) / 4 <= 2e-5 for theta <= 10 deg, alpha <= 0.05.
    constexpr double kNearNormalLoss = 1e-4;
    for (double alpha : {1e-4, 1e-3, 0.01, 0.05}) {
      for (double deg_o : {0.0, 5.0, 10.0}) {
        for (double deg_i : {0.0, 3.0, 10.0}) {
          Vec3 wo = ref::from_angles(deg_o * kPi / 180, 0.3);
          Vec3 wi = ref::from_angles(deg_i * kPi / 180, 2.0);
          double g2 = g2_kernel(ndf, wo, wi, {alpha, alpha});
          EXPECT_GT(g2, 1.0 - kNearNormalLoss)
              << ndf_name(ndf) << " alpha " << alpha << " wo " << wo << " wi " << wi;
        }
      }
    }
    // And as alpha -> 0, even at 80 deg: Lambda_GGX ~ alpha^2 tan^2 / 4 = 8e-8 at 1e-4.
    Vec3 wo = ref::from_angles(80.0 * kPi / 180, 0.0), wi = ref::from_angles(80.0 * kPi / 180, 3.0);
    EXPECT_GT(g2_kernel(ndf, wo, wi, {1e-4, 1e-4}), 1.0 - 1e-6) << ndf_name(ndf);
  }
}

}  // namespace
}  // namespace glint_test
