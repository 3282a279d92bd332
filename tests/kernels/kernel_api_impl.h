// Body of the kernel_api.h wrappers, included by kernel_api_f32.cpp and kernel_api_f64.cpp after
// they have included kernels/smooth_brdf.h into namespace GLINT_TEST_KERNEL_NS. Defines
// glint_test::GLINT_TEST_API_NS (f32 or f64). No include guard on purpose: one inclusion per
// precision, each in its own translation unit.
#if !defined(GLINT_TEST_KERNEL_NS) || !defined(GLINT_TEST_API_NS)
#error "define GLINT_TEST_KERNEL_NS and GLINT_TEST_API_NS before including kernel_api_impl.h"
#endif

namespace glint_test::GLINT_TEST_API_NS {

namespace kn = ::GLINT_TEST_KERNEL_NS;

static_assert(kNdfGgx == GLINT_NDF_GGX && kNdfBeckmann == GLINT_NDF_BECKMANN);
static_assert(kFresnelSchlick == GLINT_FRESNEL_SCHLICK &&
              kFresnelConductor == GLINT_FRESNEL_CONDUCTOR &&
              kFresnelDielectric == GLINT_FRESNEL_DIELECTRIC);

namespace {

kn::real to_real(double x) {
  return static_cast<kn::real>(x);
}

kn::real3 to_real3(Vec3 v) {
  return kn::make_real3(to_real(v.x), to_real(v.y), to_real(v.z));
}

Vec3 to_vec3(kn::real3 v) {
  return {static_cast<double>(v.x), static_cast<double>(v.y), static_cast<double>(v.z)};
}

kn::SmoothMaterial to_material(const Material &m) {
  kn::SmoothMaterial k;
  k.ndf = m.ndf;
  k.alpha_x = to_real(m.alpha_x);
  k.alpha_y = to_real(m.alpha_y);
  k.fresnel.kind = m.fresnel;
  k.fresnel.a = to_real3(m.a);
  k.fresnel.b = to_real3(m.b);
  return k;
}

}  // namespace

Vec3 reflect_cos(const Material &m, Vec3 wi, Vec3 wo) {
  return to_vec3(kn::smooth_reflect_cos(to_material(m), to_real3(wi), to_real3(wo)));
}

Vec3 reflect_cos_view(const Material &m, Vec3 wi, Vec3 wo) {
  const kn::SmoothMaterial km = to_material(m);
  return to_vec3(kn::smooth_reflect_cos_view(km, kn::smooth_view(km, to_real3(wo)), to_real3(wi)));
}

double ndf_D(int ndf, Vec3 h, double alpha_x, double alpha_y) {
  return kn::ndf_D(ndf, to_real3(h), to_real(alpha_x), to_real(alpha_y));
}

double z_lambda(int ndf, Vec3 w, double alpha_x, double alpha_y) {
  return kn::ndf_z_lambda(ndf, to_real3(w), to_real(alpha_x), to_real(alpha_y));
}

double visibility(int ndf, Vec3 wo, Vec3 wi, double alpha_x, double alpha_y) {
  return kn::smith_visibility_correlated(ndf, to_real3(wo), to_real3(wi), to_real(alpha_x),
                                         to_real(alpha_y));
}

double ggx_dv_cos_i(Vec3 h, Vec3 wo, Vec3 wi, double alpha_x, double alpha_y) {
  return kn::ggx_D_visibility_cos_i(to_real3(h), to_real3(wo), to_real3(wi), to_real(alpha_x),
                                    to_real(alpha_y));
}

double fresnel_schlick(double f0, double cos_theta) {
  return kn::F_schlick(to_real(f0), to_real(cos_theta));
}

double fresnel_conductor(double eta, double k, double cos_theta) {
  return kn::F_conductor(to_real(eta), to_real(k), to_real(cos_theta));
}

double fresnel_dielectric(double ior, double cos_theta) {
  return kn::F_dielectric(to_real(ior), to_real(cos_theta));
}

Vec3 fresnel_eval(const Material &m, double cos_theta) {
  return to_vec3(kn::fresnel_eval(to_material(m).fresnel, to_real(cos_theta)));
}

}  // namespace glint_test::GLINT_TEST_API_NS
