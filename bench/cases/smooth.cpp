// bench_models case of the SMOOTH model: the Fresnel variants on probes and point-like lights,
// the area methods on polygon lights. The conductor is the material of the Mitsuba 3
// roughconductor comparison (issue 13): GGX alpha (0.3, 0.1), eta (0.2, 0.4, 1.4),
// k (3.9, 2.4, 1.8).
#include "bench/lib/bench_case.h"

namespace glint::bench {
namespace {

ModelBenchCase MakeSmoothCase() {
  ModelBenchCase c;
  c.model = glint::v1::SMOOTH;
  c.error = ErrorReference::kExact;
  c.base = [](glint::v1::Material *m) {
    m->set_ndf(glint::v1::GGX);
    m->set_alpha_x(0.3f);
    m->set_alpha_y(0.1f);
    for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
  };
  const std::vector<Lights> point_like = {Lights::kProbe, Lights::kDirectionalPoint};
  c.variants.push_back({"schlick", point_like, true, nullptr});
  c.variants.push_back(
      {"conductor", point_like, true, [](glint::v1::EvaluateRequest *r, const QueryStats &) {
         auto *k = r->mutable_material()->mutable_conductor();
         for (float v : {0.2f, 0.4f, 1.4f}) k->add_eta(v);
         for (float v : {3.9f, 2.4f, 1.8f}) k->add_k(v);
       }});
  for (const AreaMethodChoice &a : AreaMethodChoices()) {
    c.variants.push_back({AreaMethodLabel(a),
                          {Lights::kQuad, Lights::kFourQuads},
                          a.quick,
                          [a](glint::v1::EvaluateRequest *r, const QueryStats &) {
                            r->set_area_method(a.method);
                            r->set_area_samples(a.samples);
                          }});
  }
  return c;
}

GLINT_BENCH_CASE(MakeSmoothCase);

}  // namespace
}  // namespace glint::bench
