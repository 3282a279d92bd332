#include "bench/lib/bench_case.h"

namespace glint::bench {

namespace {

std::vector<ModelBenchCase (*)()> &Registry() {
  static std::vector<ModelBenchCase (*)()>
      registry;  // constructed on first use (static init order)
  return registry;
}

}  // namespace

bool RegisterBenchCase(ModelBenchCase (*make)()) {
  Registry().push_back(make);
  return true;
}

std::vector<ModelBenchCase> BenchCases() {
  std::vector<ModelBenchCase> cases;
  for (auto make : Registry()) cases.push_back(make());
  return cases;
}

const std::vector<AreaMethodChoice> &AreaMethodChoices() {
  static const std::vector<AreaMethodChoice> choices = {
      {glint::v1::LTC, 0, true},
      {glint::v1::LECOCQ, 0, true},
      {glint::v1::LECOCQ_PEARSON, 0, true},
      {glint::v1::MONTE_CARLO, 4, false},
      {glint::v1::MONTE_CARLO, 16, true},
      {glint::v1::MONTE_CARLO, 64, true},
      {glint::v1::MONTE_CARLO, 256, false},
      {glint::v1::REFERENCE, 8, true},
      {glint::v1::REFERENCE, 32, false},
  };
  return choices;
}

std::string AreaMethodLabel(const AreaMethodChoice &c) {
  std::string s = glint::v1::AreaMethod_Name(c.method);
  if (c.samples) {
    s += ':';  // two appends: GCC 12 warns falsely (-Wrestrict) on ":" + std::to_string
    s += std::to_string(c.samples);
  }
  return s;
}

}  // namespace glint::bench
