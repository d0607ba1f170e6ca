// Writes modtap.lua with modtap's names of the function and exception codes in it, so that
// Wireshark names each code as modtap's other outputs do, and no packet's comment has to.
//
//   lua_names TEMPLATE OUTPUT
//
// The template's line that declares the two tables empty gets them filled.
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <string_view>

#include "protocol/function_codes.hpp"

namespace {

constexpr std::string_view empty_tables = "local FUNCTION_NAMES, EXCEPTION_NAMES = {}, {}";

// A Lua table from code to name, one entry a named code.
template <typename NameOf>
std::string lua_table(NameOf name_of) {
  std::string table = "{";
  for (unsigned code = 0; code < 256; ++code) {
    const std::string_view name = name_of(static_cast<uint8_t>(code));
    if (name.empty()) continue;
    table += "\n  [" + std::to_string(code) + "] = \"";
    for (const char c : name) {
      if (c == '"' || c == '\\') table += '\\';
      table += c;
    }
    table += "\",";
  }
  return table + "\n}";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: lua_names TEMPLATE OUTPUT\n");
    return 2;
  }
  std::ifstream in(argv[1]);
  std::stringstream text;
  text << in.rdbuf();
  std::string lua = text.str();
  const size_t at = lua.find(empty_tables);
  if (!in || at == std::string::npos) {
    std::fprintf(stderr, "lua_names: %s has no line '%.*s'\n", argv[1],
                 static_cast<int>(empty_tables.size()), empty_tables.data());
    return 1;
  }
  const std::string tables = "local FUNCTION_NAMES = " + lua_table([](uint8_t fc) {
                               return fc < 0x80 ? modtap::function_name(fc) : "";
                             }) +
                             "\nlocal EXCEPTION_NAMES = " + lua_table(modtap::exception_name);
  lua.replace(at, empty_tables.size(), tables);
  std::ofstream out(argv[2], std::ios::binary);
  out << lua;
  out.close();
  if (!out) {
    std::fprintf(stderr, "lua_names: cannot write %s\n", argv[2]);
    return 1;
  }
  return 0;
}
