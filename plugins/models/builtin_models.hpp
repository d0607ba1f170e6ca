// The model files under plugins/models/, compiled in: `--model nta5000` works from any directory.
#pragma once

#include <span>
#include <string_view>

namespace modtap::models {

struct BuiltinModel {
  std::string_view file;
  std::string_view yaml;
};

std::span<const BuiltinModel> builtin_models();

}  // namespace modtap::models
