# Writes a C++ file that holds each model's YAML text, so the built-in models travel inside the
# binary and cannot go missing or out of date. Run by plugins/models/CMakeLists.txt.
set(body "")
foreach(file IN LISTS MODEL_FILES)
  get_filename_component(name "${file}" NAME)
  file(READ "${file}" text)
  string(APPEND body "    {\"${name}\", R\"modtap_yaml(${text})modtap_yaml\"},\n")
endforeach()
file(WRITE "${OUTPUT}.tmp" "// Generated from plugins/models/*.yaml by embed_models.cmake.
#include \"plugins/models/builtin_models.hpp\"

namespace modtap::models {

std::span<const BuiltinModel> builtin_models() {
  static const BuiltinModel models[] = {
${body}  };
  return models;
}

}  // namespace modtap::models
")
file(COPY_FILE "${OUTPUT}.tmp" "${OUTPUT}" ONLY_IF_DIFFERENT)
