// Host-side access to the checked-in Chermain et al. 2020 dictionary
// data/chermain/chermain_dictionary.inc (written by tools/chermain; layout in
// models/chermain/chermain_params.h, regeneration in data/chermain/README.md).
#ifndef GLINT_DATA_CHERMAIN_DICTIONARY_H
#define GLINT_DATA_CHERMAIN_DICTIONARY_H

#include <cstddef>

#include "models/chermain/chermain_params.h"

namespace glint::chermain_data {

namespace data {
// One definition across translation units (C++17 inline variable).
#define GLINT_CHERMAIN_STORAGE alignas(64) inline constexpr
#include "data/chermain/chermain_dictionary.inc"
#undef GLINT_CHERMAIN_STORAGE
}  // namespace data

static_assert(GLINT_CHERMAIN_DICTIONARY_MARGINALS == GLINT_CHERMAIN_MAX_DICTIONARY);
static_assert(sizeof(data::glint_chermain_dictionary) ==
              sizeof(float) * GLINT_CHERMAIN_TABLE_FLOATS);

// The digest the README states (FNV-1a 64 of the floats, tools/chermain DictionaryDigest).
inline constexpr unsigned long long kDigest = 0xd14337de3a68ff37ull;
inline constexpr unsigned long long kSeed = 20200601ull;

inline const float *dictionary() {
  return data::glint_chermain_dictionary;
}
inline constexpr size_t kFloats = GLINT_CHERMAIN_TABLE_FLOATS;

}  // namespace glint::chermain_data

#endif  // GLINT_DATA_CHERMAIN_DICTIONARY_H
