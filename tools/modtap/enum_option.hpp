// Command-line options whose values are an enum's names (EnumNames): CLI11 checks the
// name against the same table that prints it and the run gets the enum, so no option is a
// string compared again later.
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>

#include "decoder/protocol/enum_names.hpp"

namespace modtap::tools {

template <NamedEnum Enum>
std::vector<std::string> enum_names() {
  const auto& names = EnumNames<Enum>::names;
  return {names.begin(), names.end()};
}

// `aliases`: further names for a value (pcapng for pcap).
template <NamedEnum Enum>
CLI::Option* add_enum_option(CLI::App& app, const std::string& name, Enum& value,
                             const std::string& description,
                             std::vector<std::pair<std::string, Enum>> aliases = {}) {
  std::vector<std::string> accepted;  // each name, then its aliases
  for (const std::string& name_of_value : enum_names<Enum>()) {
    accepted.push_back(name_of_value);
    for (const auto& [alias, aliased] : aliases)
      if (to_string(aliased) == name_of_value) accepted.push_back(alias);
  }
  return app
      .add_option_function<std::string>(
          name,
          [&value, aliases](const std::string& text) {
            for (const auto& [alias, aliased] : aliases)
              if (text == alias) value = aliased;
            if (auto named = enum_named<Enum>(text)) value = *named;
          },
          description)
      ->check(CLI::IsMember(accepted));
}

// The same where "auto" leaves the value to the traffic (--parity auto): none.
template <NamedEnum Enum>
CLI::Option* add_enum_or_auto_option(CLI::App& app, const std::string& name,
                                     std::optional<Enum>& value, const std::string& description) {
  std::vector<std::string> accepted = enum_names<Enum>();
  accepted.push_back("auto");
  return app
      .add_option_function<std::string>(
          name,
          [&value](const std::string& text) {
            value = enum_named<Enum>(text);  // none for auto
          },
          description)
      ->check(CLI::IsMember(accepted));
}

// A number that must be positive (-c, the time-outs): `refusal` says so in words a person
// reads ("needs at least 1"), not as CLI11's range up to its largest double.
inline CLI::Validator positive(const std::string& refusal) {
  return CLI::Validator(
      [refusal](std::string& text) -> std::string {
        double value = 0;
        return CLI::detail::lexical_cast(text, value) && value > 0 ? std::string() : refusal;
      },
      "> 0");
}

}  // namespace modtap::tools
