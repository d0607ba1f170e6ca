// Whole numbers as the manuals and people write them: 2502H (the manuals' hex), 0x2502, 9474.
#pragma once

#include <charconv>
#include <cstdint>
#include <optional>
#include <string_view>

namespace modtap {

inline std::optional<uint64_t> parse_written_number(std::string_view text) {
  int base = 10;
  if (text.size() > 1 && (text.back() == 'H' || text.back() == 'h')) {
    text.remove_suffix(1);
    base = 16;
  } else if (text.size() > 2 && (text.starts_with("0x") || text.starts_with("0X"))) {
    text.remove_prefix(2);
    base = 16;
  }
  uint64_t value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value, base);
  if (text.empty() || error != std::errc() || end != text.data() + text.size()) return std::nullopt;
  return value;
}

}  // namespace modtap
