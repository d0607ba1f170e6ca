#include "tools/modtap/render.hpp"

#include <array>
#include <cmath>

#include <fmt/ranges.h>

#include "decoder/function_codes.hpp"

namespace modtap::tools {

using decoder::Field;

void append_hex(fmt::memory_buffer& out, std::span<const uint8_t> bytes, bool spaced) {
  static constexpr char digits[] = "0123456789abcdef";
  for (size_t i = 0; i < bytes.size(); ++i) {
    if (spaced && i) out.push_back(' ');
    out.push_back(digits[bytes[i] >> 4]);
    out.push_back(digits[bytes[i] & 15]);
  }
}

void append_json_string(fmt::memory_buffer& out, std::string_view text) {
  out.push_back('"');
  for (unsigned char c : text) {
    if (c == '"' || c == '\\') {
      out.push_back('\\');
      out.push_back(static_cast<char>(c));
    } else if (c < 0x20 || c >= 0x7F) {
      // Device strings are bytes, not UTF-8: escape anything outside printable ASCII.
      fmt::format_to(std::back_inserter(out), "\\u{:04x}", c);
    } else {
      out.push_back(static_cast<char>(c));
    }
  }
  out.push_back('"');
}

void append_json_value(fmt::memory_buffer& out, const Field& f) {
  auto it = std::back_inserter(out);
  switch (f.kind) {
    case Field::Kind::number:
    case Field::Kind::hex:
      fmt::format_to(it, "{}", f.number);
      break;
    case Field::Kind::text:
      append_json_string(out, f.text);
      break;
    case Field::Kind::numbers:
    case Field::Kind::bits:
      fmt::format_to(it, "[{}]", fmt::join(f.numbers, ","));
      break;
    case Field::Kind::bytes:
      out.push_back('"');
      append_hex(out, f.bytes, false);
      out.push_back('"');
      break;
    case Field::Kind::items:
      out.push_back('[');
      for (size_t i = 0; i < f.items.size(); ++i) {
        if (i) out.push_back(',');
        out.push_back('{');
        for (size_t j = 0; j < f.items[i].size(); ++j) {
          if (j) out.push_back(',');
          fmt::format_to(it, "\"{}\":", f.items[i][j].key);
          append_json_value(out, f.items[i][j]);
        }
        out.push_back('}');
      }
      out.push_back(']');
      break;
  }
}

void append_text_value(fmt::memory_buffer& out, const Field& f, size_t max_items) {
  auto it = std::back_inserter(out);
  switch (f.kind) {
    case Field::Kind::number:
      fmt::format_to(it, "{}", f.number);
      break;
    case Field::Kind::hex:
      fmt::format_to(it, "0x{:04x}", f.number);
      break;
    case Field::Kind::text:
      fmt::format_to(it, "\"{}\"", f.text);
      break;
    case Field::Kind::bits:
      for (size_t i = 0; i < f.numbers.size() && i < max_items; ++i)
        out.push_back(f.numbers[i] ? '1' : '0');
      if (f.numbers.size() > max_items) fmt::format_to(it, "...({} bits)", f.numbers.size());
      break;
    case Field::Kind::numbers: {
      const size_t shown = std::min(f.numbers.size(), max_items);
      fmt::format_to(
          it, "[{}",
          fmt::join(f.numbers.begin(), f.numbers.begin() + static_cast<long>(shown), " "));
      if (shown < f.numbers.size()) fmt::format_to(it, " ...({} values)", f.numbers.size());
      out.push_back(']');
      break;
    }
    case Field::Kind::bytes:
      append_hex(out, f.bytes, true);
      break;
    case Field::Kind::items:
      for (size_t i = 0; i < f.items.size(); ++i) {
        out.push_back(i ? ' ' : '{');
        for (size_t j = 0; j < f.items[i].size(); ++j) {
          fmt::format_to(it, "{}{}=", j ? " " : "", f.items[i][j].key);
          append_text_value(out, f.items[i][j], max_items);
        }
        out.push_back(';');
      }
      if (!f.items.empty()) out.push_back('}');
      break;
  }
}

namespace {

void append_number(fmt::memory_buffer& out, const decoder::RegisterValue& reg) {
  fmt::format_to(std::back_inserter(out), "{:.{}f}", reg.value, reg.decimals);
}

}  // namespace

void append_register_json(fmt::memory_buffer& out, const decoder::RegisterValue& reg) {
  auto optional_string = [&](const std::string& text) {
    if (text.empty()) {
      fmt::format_to(std::back_inserter(out), "null");
    } else {
      append_json_string(out, text);
    }
  };
  fmt::format_to(std::back_inserter(out), "{{\"addr\":{},\"name\":", reg.address);
  optional_string(reg.name);
  fmt::format_to(std::back_inserter(out), ",\"raw\":{},\"value\":", reg.raw);
  if (std::isfinite(reg.value)) {
    append_number(out, reg);
  } else {
    fmt::format_to(std::back_inserter(out), "null");
  }
  fmt::format_to(std::back_inserter(out), ",\"unit\":");
  optional_string(reg.unit);
  fmt::format_to(std::back_inserter(out), ",\"text\":");
  optional_string(reg.text);
  fmt::format_to(std::back_inserter(out), "}}");
}

std::string function_label(uint8_t fc) {
  if (const char* name = decoder::function_name(fc)) return name;
  return fmt::format("Function 0x{:02X}", fc & 0x7F);
}

}  // namespace modtap::tools
