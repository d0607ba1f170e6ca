// --help as a man page reads it (help2man makes modtap(1) and modtap-bus-simulator(1) from it):
// each option with what it takes, named for what it is (FILE, PORT, {text,json}), not CLI11's
// types and constraints ("TEXT Excludes: --read"). An option that needs another says so in its
// own words, and the command line's error names the conflict when it happens.
#pragma once

#include <regex>
#include <string>

#include <CLI/CLI.hpp>

namespace modtap::tools {

// What a person reads for CLI11's type name: a list of choices as it is ("{auto,raw}"), a range
// of numbers ("147-162"), a name the option gave itself (FILE), else what the value is.
inline std::string value_placeholder(const std::string& type) {
  // CLI11 writes the type, then each check's description after a colon.
  static const std::regex checked(R"((.*?):((\{|\(|>|NONNEGATIVE|POSITIVE|\w+ in \[).*))");
  static const std::regex in_range(R"(\w+ in \[(-?[0-9.]+) - (-?[0-9.]+)\])");
  std::smatch parts, range;
  const bool has_check = std::regex_match(type, parts, checked);
  const std::string base = has_check ? parts[1].str() : type;
  const std::string check = has_check ? parts[2].str() : "";
  const bool generic = base == "TEXT" || base == "FLOAT" || base == "UINT" || base == "INT";
  if (generic && check.starts_with("{")) return check;
  if (generic && std::regex_match(check, range, in_range))
    return range[1].str() + "-" + range[2].str();
  if (base == "TEXT") return "VALUE";
  if (base == "FLOAT") return "NUMBER";
  if (base == "UINT" || base == "INT") return "N";
  return base;
}

class HelpFormatter final : public CLI::Formatter {
 public:
  std::string make_option_opts(const CLI::Option* opt) const override {
    if (opt->get_type_size() == 0) return {};
    std::string out = " " + value_placeholder(opt->get_type_name());
    if (opt->get_expected_max() > 1) out += " ...";
    if (opt->get_required()) out += " (required)";
    return out;
  }
};

}  // namespace modtap::tools
