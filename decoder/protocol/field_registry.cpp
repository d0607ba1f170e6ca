#include "decoder/protocol/field_registry.hpp"

#include <array>

namespace modtap {
namespace {
using T = FieldType;
}  // namespace

std::string_view json_kind(FieldType type) {
  switch (type) {
    case T::integer:
    case T::hex:
    case T::address:
    case T::code:
    case T::real:
      return "number";
    case T::name:
    case T::string:
    case T::bytes:
      return "string";
    case T::registers:
    case T::bits:
    case T::list:
    case T::names:
      return "array";
    case T::flag:
      return "boolean";
  }
  return "?";
}

}  // namespace modtap
