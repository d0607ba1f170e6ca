// Each enum's names in one table, in the order of its values: fmt prints the enum by it,
// to_string gives the name, enum_named parses it. A specialisation of EnumNames beside the
// enum holds the table; the enum's first value is 0 and the values follow without gaps.
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <string_view>
#include <type_traits>

#include <fmt/format.h>

namespace modtap {

template <typename Enum>
struct EnumNames;  // static constexpr std::array<std::string_view, N> names

template <typename Enum>
concept NamedEnum = std::is_enum_v<Enum> && requires {
  EnumNames<Enum>::names;
};

template <NamedEnum Enum>
constexpr std::string_view to_string(Enum value) {
  const auto& names = EnumNames<Enum>::names;
  const auto index = static_cast<size_t>(value);
  return index < names.size() ? names[index] : "?";
}

template <NamedEnum Enum>
constexpr std::optional<Enum> enum_named(std::string_view name) {
  const auto& names = EnumNames<Enum>::names;
  for (size_t i = 0; i < names.size(); ++i)
    if (names[i] == name) return static_cast<Enum>(i);
  return std::nullopt;
}

}  // namespace modtap

template <modtap::NamedEnum Enum>
struct fmt::formatter<Enum, char> : fmt::formatter<std::string_view, char> {
  template <typename FormatContext>
  auto format(Enum value, FormatContext& context) const {
    return fmt::formatter<std::string_view, char>::format(modtap::to_string(value), context);
  }
};
