// The models the server serves: the table in models/model_table.cpp.
#pragma once

#include <span>

#include "server/model.h"

namespace glint {

// Every model, in the order capabilities list them.
std::span<const Model *const> Models();

// The model with this proto id, or nullptr.
const Model *FindModel(int id);

}  // namespace glint
