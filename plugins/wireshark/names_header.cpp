// Writes the C header the Wireshark plugin is built with: modtap's names of the function and
// exception codes, and the field registry's titles of the record fields, so that Wireshark
// names a code and titles a field as modtap's other outputs do, from the same tables.
//
//   names_header OUTPUT
#include <cstdio>
#include <fstream>
#include <string>
#include <string_view>

#include "decoder/protocol/field_registry.hpp"
#include "decoder/protocol/function_codes.hpp"

namespace {

std::string c_string(std::string_view text) {
  std::string quoted = "\"";
  for (const char c : text) {
    if (c == '"' || c == '\\') quoted += '\\';
    quoted += c;
  }
  return quoted + '"';
}

// A C array from code to name, with a designated initializer for each named code.
template <typename NameOf>
std::string names_array(std::string_view name, unsigned size, NameOf name_of) {
  std::string array =
      "static const char *const " + std::string(name) + "[" + std::to_string(size) + "] = {\n";
  for (unsigned code = 0; code < size; ++code)
    if (const std::string_view text = name_of(static_cast<uint8_t>(code)); !text.empty())
      array += "    [" + std::to_string(code) + "] = " + c_string(text) + ",\n";
  return array + "};\n";
}

std::string field_titles() {
  std::string table =
      "static const struct modtap_field_title {\n    const char *name;\n    const char *title;\n"
      "} modtap_field_titles[] = {\n";
  for (const modtap::FieldInfo& field : modtap::field_registry())
    if (!field.item)
      table += "    {" + c_string(field.name) + ", " + c_string(field.title) + "},\n";
  return table + "};\n";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: names_header OUTPUT\n");
    return 2;
  }
  std::ofstream out(argv[1], std::ios::binary);
  out << "/* Written by the build from modtap's tables (plugins/wireshark/names_header.cpp). */\n"
      << names_array("modtap_function_names", 128, modtap::function_name)
      << names_array("modtap_exception_names", 256, modtap::exception_name) << field_titles();
  out.close();
  if (!out) {
    std::fprintf(stderr, "names_header: cannot write %s\n", argv[1]);
    return 1;
  }
  return 0;
}
