// The model table (docs/architecture.md, "Adding a model"): one line per model,
// naming the Model its folder defines (models/<name>/<name>_model.cpp). An
// explicit list rather than static self-registration, which the linker drops
// from static libraries.
#include "server/model_table.h"

#define GLINT_MODEL_TABLE(X) \
  X(kSmoothModel)            \
  X(kBinomialModel)          \
  X(kChermainModel)          \
  X(kKemppinenModel)         \
  X(kNormalMapModel)

namespace glint {

#define GLINT_DECLARE_MODEL(name) extern const Model name;
GLINT_MODEL_TABLE(GLINT_DECLARE_MODEL)

std::span<const Model *const> Models() {
#define GLINT_MODEL_ADDRESS(name) &name,
  static const Model *const kModels[] = {GLINT_MODEL_TABLE(GLINT_MODEL_ADDRESS)};
  return kModels;
}

const Model *FindModel(int id) {
  for (const Model *m : Models())
    if (int(m->id) == id) return m;
  return nullptr;
}

}  // namespace glint
