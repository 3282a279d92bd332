// bench_models case of the NORMAL_MAP model (models/normal_map/README.md): the P-NDF's pruning
// cut-off, on a 128 x 128 bumpy map generated here (tools/normal_map) and put into the
// process's normal-map store, as an upload would. Quad rows: polygon lights by the model's MIS
// (normal_map_polygons.h), area_samples per technique (the bench's default). No error reference:
// the P-NDF of a map does not converge to a smooth model; its accuracy is tested against binning
// (normal_map_pndf_test).
#include <cstdio>
#include <stdexcept>
#include <string>

#include "bench/lib/bench_case.h"
#include "server/normal_map_store.h"
#include "tools/normal_map/normal_map_gen.h"

namespace glint::bench {
namespace {

// The digest of the bench map, generated and stored on first use.
const std::string &BenchMapDigest() {
  static const std::string digest = [] {
    DecodedNormalMap map;
    std::string error;
    if (!normal_map_gen::Generate({"bumpy", 128, 1, 0.2}, &map, &error))
      throw std::runtime_error("bench normal map: " + error);
    glint::v1::NormalMapInfo info;
    if (Status s = NormalMaps().Insert("bench bumpy 128", map, &info); !s.ok())
      throw std::runtime_error("bench normal map: " + s.message());
    return info.digest();
  }();
  return digest;
}

ModelBenchCase MakeNormalMapCase() {
  ModelBenchCase c;
  c.model = glint::v1::NORMAL_MAP;
  c.error = ErrorReference::kNone;
  c.base = [](glint::v1::Material *m) {
    for (float f : {0.9f, 0.6f, 0.3f}) m->mutable_schlick()->add_f0(f);
    auto *p = m->mutable_normal_map();
    p->set_digest(BenchMapDigest());
    p->set_intrinsic_roughness(0.02f);
  };
  for (float cutoff : {3.0f, 5.0f}) {
    char name[32];
    std::snprintf(name, sizeof name, "cutoff=%g", double(cutoff));
    c.variants.push_back({name,
                          {Lights::kProbe, Lights::kDirectionalPoint, Lights::kQuad},
                          true,
                          [cutoff](glint::v1::EvaluateRequest *r, const QueryStats &) {
                            r->mutable_material()->mutable_normal_map()->set_cutoff_sigma(cutoff);
                          }});
  }
  return c;
}

GLINT_BENCH_CASE(MakeNormalMapCase);

}  // namespace
}  // namespace glint::bench
