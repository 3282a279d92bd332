// Double-typed entry points into the portable BRDF headers (kernels/*.h), compiled twice: once
// with real = float (glint_test::f32, kernel_api_f32.cpp) and once with real = double
// (glint_test::f64, kernel_api_f64.cpp). A header can be included only once per translation unit
// (include guards), so this is how one test binary compares both precisions.
//
// Every wrapper first rounds its arguments to the kernel's `real`; a caller that wants both builds
// to see identical inputs passes float-representable values (see round_to_float in reference.h).
#ifndef GLINT_TESTS_KERNELS_KERNEL_API_H
#define GLINT_TESTS_KERNELS_KERNEL_API_H

#include <ostream>

namespace glint_test {

struct Vec3 {
  double x, y, z;
};

inline std::ostream &operator<<(std::ostream &os, Vec3 v) {
  return os << "(" << v.x << ", " << v.y << ", " << v.z << ")";
}

// Mirror the GLINT_NDF_* / GLINT_FRESNEL_* macros (the impl static_asserts that they agree), so
// test files need not include the kernel headers themselves.
inline constexpr int kNdfGgx = 1;
inline constexpr int kNdfBeckmann = 2;
inline constexpr int kFresnelSchlick = 1;
inline constexpr int kFresnelConductor = 2;
inline constexpr int kFresnelDielectric = 3;

inline constexpr int kNdfs[] = {kNdfGgx, kNdfBeckmann};
inline const char *ndf_name(int ndf) {
  return ndf == kNdfBeckmann ? "Beckmann" : "GGX";
}

// An anisotropic roughness pair (alpha_x along the tangent, alpha_y along the bitangent).
struct Alphas {
  double x, y;
};

// SmoothMaterial / FresnelParams in double: a = f0 (schlick), eta (conductor) or ior in a.x
// (dielectric); b = k (conductor).
struct Material {
  int ndf;
  double alpha_x;
  double alpha_y;
  int fresnel;
  Vec3 a;
  Vec3 b;
};

inline std::ostream &operator<<(std::ostream &os, const Material &m) {
  return os << "{ndf " << m.ndf << ", alpha (" << m.alpha_x << ", " << m.alpha_y << "), fresnel "
            << m.fresnel << ", a " << m.a << ", b " << m.b << "}";
}

// The same declarations for both precisions.
#define GLINT_TEST_DECLARE_KERNEL_API                                            \
  /* smooth_reflect_cos: f(wi, wo) cos(theta_i), RGB */                          \
  Vec3 reflect_cos(const Material &m, Vec3 wi, Vec3 wo);                         \
  /* smooth_reflect_cos_view(m, smooth_view(m, wo), wi): the per-light path */   \
  Vec3 reflect_cos_view(const Material &m, Vec3 wi, Vec3 wo);                    \
  double ndf_D(int ndf, Vec3 h, double alpha_x, double alpha_y);                 \
  /* ndf_z_lambda: w.z * Lambda(w) */                                            \
  double z_lambda(int ndf, Vec3 w, double alpha_x, double alpha_y);              \
  /* smith_visibility_correlated: G2 / (4 cos_o cos_i) */                        \
  double visibility(int ndf, Vec3 wo, Vec3 wi, double alpha_x, double alpha_y);  \
  /* ggx_D_visibility_cos_i: GGX D(h) V(wo, wi) cos_i in one division */         \
  double ggx_dv_cos_i(Vec3 h, Vec3 wo, Vec3 wi, double alpha_x, double alpha_y); \
  double fresnel_schlick(double f0, double cos_theta);                           \
  double fresnel_conductor(double eta, double k, double cos_theta);              \
  double fresnel_dielectric(double ior, double cos_theta);                       \
  /* fresnel_eval on the material's Fresnel parameters */                        \
  Vec3 fresnel_eval(const Material &m, double cos_theta);

namespace f32 {
GLINT_TEST_DECLARE_KERNEL_API
}  // namespace f32
namespace f64 {
GLINT_TEST_DECLARE_KERNEL_API
}  // namespace f64

#undef GLINT_TEST_DECLARE_KERNEL_API

}  // namespace glint_test

#endif  // GLINT_TESTS_KERNELS_KERNEL_API_H
