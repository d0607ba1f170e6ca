#include "output/render.hpp"

#include <array>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include <fmt/compile.h>

#include "decoder/protocol/function_codes.hpp"

namespace modtap::output {

namespace {

std::string_view as_chars(std::span<const uint8_t> bytes) {
  return {reinterpret_cast<const char*>(bytes.data()), bytes.size()};
}

// [1,0,1] or [2291,17]: room for the longest is made once, and the digits written into it.
void append_json_numbers(fmt::memory_buffer& out, const Field& f) {
  const bool bits = f.type() == FieldType::bits;
  const size_t at = out.size();
  out.resize(at + 2 + f.count * (bits ? 2 : 6));  // a word has at most 5 digits, and a comma
  char* to = out.data() + at;
  *to++ = '[';
  for (size_t i = 0; i < f.count; ++i) {
    if (i) *to++ = ',';
    if (bits) {
      *to++ = f.bit(i) ? '1' : '0';
    } else {
      to = fmt::format_to(to, FMT_COMPILE("{}"), f.word(i));
    }
  }
  *to++ = ']';
  out.resize(static_cast<size_t>(to - out.data()));
}

void append_json_scalar(fmt::memory_buffer& out, const Field& f) {
  switch (f.type()) {
    case FieldType::name:
      append_json_string(out, f.text);
      break;
    case FieldType::string:
      append_json_string(out, as_chars(f.bytes));
      break;
    case FieldType::bytes:
      out.push_back('"');
      append_hex(out, f.bytes, false);
      out.push_back('"');
      break;
    case FieldType::registers:
    case FieldType::bits:
      append_json_numbers(out, f);
      break;
    default:
      put_int(out, f.number);
  }
}

// Each field's `"name":`, made once from the registry: keys are most of a JSON line's pieces.
void append_json_key(fmt::memory_buffer& out, const Field& f) {
  static const std::vector<std::string> keys = [] {
    std::vector<std::string> made;
    for (const FieldInfo& info : field_registry()) {
      const auto slot = static_cast<size_t>(info.id);
      if (made.size() <= slot) made.resize(slot + 1);
      made[slot] = fmt::format("\"{}\":", info.name);
    }
    return made;
  }();
  put(out, keys[static_cast<size_t>(f.id)]);
}

void append_text_scalar(fmt::memory_buffer& out, const Field& f, size_t max_items,
                        AddressNumbering numbering) {
  auto it = fmt::appender(out);
  switch (f.type()) {
    case FieldType::hex:
      if (f.number >= 0 && f.number <= 0xFFFF) {
        put(out, "0x");
        put_hex(out, static_cast<uint32_t>(f.number), 4, false);
      } else {
        fmt::format_to(it, FMT_COMPILE("0x{:04x}"), f.number);
      }
      break;
    case FieldType::address:  // as the manuals write registers (2502H), or --register-base
      if (numbering.base == RegisterBase::hex) {
        put_hex4(out, static_cast<uint16_t>(f.number));
        out.push_back('H');
      } else {
        fmt::format_to(
            it, FMT_COMPILE("{}"),
            RegisterNumber{numbering.table, static_cast<uint16_t>(f.number), numbering.base});
      }
      break;
    case FieldType::code:  // as vendors' tables write codes: 52H
      if (f.number >= 0 && f.number <= 0xFF) {
        put_hex(out, static_cast<uint32_t>(f.number), 2);
        out.push_back('H');
      } else {
        fmt::format_to(it, FMT_COMPILE("{:02X}H"), f.number);
      }
      break;
    case FieldType::name:
      out.push_back('"');
      put(out, f.text);
      out.push_back('"');
      break;
    case FieldType::string:
      out.push_back('"');
      put(out, as_chars(f.bytes));
      out.push_back('"');
      break;
    case FieldType::bytes:
      append_hex(out, f.bytes, true);
      break;
    case FieldType::bits:
      for (size_t i = 0; i < f.count && i < max_items; ++i) out.push_back(f.bit(i) ? '1' : '0');
      if (f.count > max_items) {
        put(out, "...(");
        put_uint(out, f.count);
        put(out, " bits)");
      }
      break;
    case FieldType::registers: {
      out.push_back('[');
      const size_t shown = std::min<size_t>(f.count, max_items);
      for (size_t i = 0; i < shown; ++i) {
        if (i) out.push_back(' ');
        put_int(out, f.word(i));
      }
      if (shown < f.count) {
        put(out, " ...(");
        put_uint(out, f.count);
        put(out, " values)");
      }
      out.push_back(']');
      break;
    }
    default:
      put_int(out, f.number);
  }
}

}  // namespace

// A byte's two hex digits in one copy, from a table of all 256.
constexpr auto hex_pairs_in(const char (&digits)[17]) {
  std::array<char, 512> pairs{};
  for (int i = 0; i < 256; ++i) {
    pairs[2 * i] = digits[i >> 4];
    pairs[2 * i + 1] = digits[i & 15];
  }
  return pairs;
}
constexpr auto hex_pairs = hex_pairs_in("0123456789abcdef");
constexpr auto upper_hex_pairs = hex_pairs_in("0123456789ABCDEF");

// Spaced for people, in capitals as the manuals and the check column write bytes; packed for
// JSON and filters, in small letters.
void append_hex(fmt::memory_buffer& out, std::span<const uint8_t> bytes, bool spaced) {
  if (bytes.empty()) return;
  const size_t at = out.size();
  const size_t step = spaced ? 3 : 2;
  const auto& pairs = spaced ? upper_hex_pairs : hex_pairs;
  out.resize(at + bytes.size() * step - (spaced ? 1 : 0));
  char* to = out.data() + at;
  for (size_t i = 0; i < bytes.size(); ++i, to += step) {
    std::memcpy(to, &pairs[2 * bytes[i]], 2);
    if (spaced && i + 1 < bytes.size()) to[2] = ' ';
  }
}

namespace {

// The length of the well-formed UTF-8 sequence at the start of `text` (RFC 3629: no overlong
// form, no surrogate, nothing past U+10FFFF), or 0.
size_t utf8_sequence(std::string_view text) {
  const auto byte = [&](size_t i) { return static_cast<unsigned char>(text[i]); };
  const unsigned char lead = byte(0);
  const size_t size = lead >= 0xF0 ? 4 : lead >= 0xE0 ? 3 : lead >= 0xC2 ? 2 : 0;
  if (size == 0 || lead > 0xF4 || text.size() < size) return 0;
  // The second byte's range rules out overlong forms, surrogates and code points too large.
  const unsigned char second = byte(1);
  const unsigned char low = lead == 0xE0 ? 0xA0 : lead == 0xF0 ? 0x90 : 0x80;
  const unsigned char high = lead == 0xED ? 0x9F : lead == 0xF4 ? 0x8F : 0xBF;
  if (second < low || second > high) return 0;
  for (size_t i = 2; i < size; ++i)
    if ((byte(i) & 0xC0) != 0x80) return 0;
  return size;
}

}  // namespace

void append_json_string(fmt::memory_buffer& out, std::string_view text) {
  out.push_back('"');
  const bool plain = std::all_of(text.begin(), text.end(), [](unsigned char c) {
    return c >= 0x20 && c < 0x7F && c != '"' && c != '\\';
  });
  if (plain) {  // names and units, nearly always: in one piece
    put(out, text);
    out.push_back('"');
    return;
  }
  for (size_t i = 0; i < text.size(); ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c == '"' || c == '\\') {
      out.push_back('\\');
      out.push_back(static_cast<char>(c));
    } else if (const size_t n = c >= 0x80 ? utf8_sequence(text.substr(i)) : 0; n > 0) {
      put(out, text.substr(i, n));  // a model's text (Chinese), or a device's UTF-8 string
      i += n - 1;
    } else if (c < 0x20 || c >= 0x7F) {
      // A device string's bytes that are no UTF-8 read as Latin-1, each its own code point.
      fmt::format_to(fmt::appender(out), "\\u{:04x}", c);
    } else {
      out.push_back(static_cast<char>(c));
    }
  }
  out.push_back('"');
}

size_t append_json_field(fmt::memory_buffer& out, const DecodedPdu& pdu, size_t at) {
  const Field& f = pdu.fields[at];
  append_json_key(out, f);
  if (f.type() != FieldType::list) {
    append_json_scalar(out, f);
    return at + 1;
  }
  const size_t end = pdu.next(at);
  out.push_back('[');
  for (size_t i = at + 1; i < end; ++i) {
    const Field& field = pdu.fields[i];
    const bool first_of_item = pdu.fields[i - 1].item != field.item;
    if (first_of_item) put(out, i == at + 1 ? "{" : "},{");
    if (!first_of_item) out.push_back(',');
    append_json_key(out, field);
    append_json_scalar(out, field);
  }
  put(out, end > at + 1 ? "}]" : "]");
  return end;
}

Table addressed_table(const Frame& frame) {
  // A response's fields are placed by its request; an echo or a lone frame reads as its own.
  const bool placed_by_request = frame.role == Role::response && !frame.request_pdu.empty();
  const auto pdu = placed_by_request ? frame.request_pdu : frame.pdu();
  if (pdu.empty()) return Table::holding;
  const auto accesses = function_code(pdu[0] & 0x7F).request_accesses(pdu);
  return accesses.size ? accesses.list[0].table : Table::holding;
}

size_t append_text_value(fmt::memory_buffer& out, const DecodedPdu& pdu, size_t at,
                         size_t max_items, AddressNumbering numbering) {
  const Field& f = pdu.fields[at];
  if (f.type() != FieldType::list) {
    append_text_scalar(out, f, max_items, numbering);
    return at + 1;
  }
  // {key=value key=value; key=value;}
  const size_t end = pdu.next(at);
  for (size_t i = at + 1; i < end; ++i) {
    const Field& field = pdu.fields[i];
    const bool first_of_item = pdu.fields[i - 1].item != field.item;
    if (first_of_item) put(out, i == at + 1 ? "{" : "; ");
    if (!first_of_item) out.push_back(' ');
    put(out, field.name());
    out.push_back('=');
    append_text_scalar(out, field, max_items, numbering);
  }
  if (end > at + 1) put(out, ";}");
  return end;
}

void append_register_json(fmt::memory_buffer& out, const RegisterValue& reg) {
  out.push_back('{');
  append_register_keys(out, reg);
  out.push_back('}');
}

void append_register_keys(fmt::memory_buffer& out, const RegisterValue& reg) {
  auto optional_string = [&](std::string_view text) {
    if (text.empty()) {
      put(out, "null");
    } else {
      append_json_string(out, text);
    }
  };
  put(out, "\"addr\":");
  put_int(out, reg.address);
  if (reg.name.empty()) {  // most of a bus of unknown devices: one copy, not three
    put(out, ",\"name\":null,\"raw\":");
  } else {
    put(out, ",\"name\":");
    append_json_string(out, reg.name);
    put(out, ",\"raw\":");
  }
  const size_t raw_at = out.size();
  put_uint(out, reg.raw);
  const size_t raw_end = out.size();
  put(out, ",\"value\":");
  // Unscaled, as most are: the raw digits again.
  if (reg.value == reg.raw && reg.decimals == 0 && !std::signbit(reg.value)) {
    put_again(out, raw_at, raw_end);
  } else if (std::isfinite(reg.value)) {
    append_number(out, reg.value, reg.decimals);
  } else {
    put(out, "null");
  }
  if (reg.unit.empty() && reg.text.empty()) {  // a register the model does not know
    put(out, ",\"unit\":null,\"text\":null");
    return;
  }
  put(out, ",\"unit\":");
  optional_string(reg.unit);
  put(out, ",\"text\":");
  optional_string(reg.text);
}

std::string clock_text(ClockQuality clock, int64_t read_lag_ns) {
  if (clock != ClockQuality::per_chunk || read_lag_ns <= 0) return std::string(to_string(clock));
  return fmt::format("{}, a read up to {:g} ms late", to_string(clock), read_lag_ns / 1e6);
}

void put_function_label(fmt::memory_buffer& out, uint8_t fc) {
  put(out, function_label(fc));
}

}  // namespace modtap::output

auto fmt::formatter<modtap::output::FunctionLabel>::format(modtap::output::FunctionLabel label,
                                                           format_context& ctx) const
    -> decltype(ctx.out()) {
  return write(ctx.out(), modtap::function_label(label.fc));
}

auto fmt::formatter<modtap::output::Fixed>::format(modtap::output::Fixed number,
                                                   format_context& ctx) const
    -> decltype(ctx.out()) {
  char room[48];
  return write(ctx.out(), modtap::output::fixed_text(number, room));
}

std::string_view modtap::output::fixed_text(Fixed number, char (&text)[48]) {
  const bool negative = number.value < 0;
  uint64_t units =
      negative ? 0 - static_cast<uint64_t>(number.value) : static_cast<uint64_t>(number.value);
  uint64_t dropped = 1;  // the digits below the last one shown
  for (int i = number.decimals; i < number.exponent; ++i) dropped *= 10;
  units = (units + dropped / 2) / dropped;
  char* at = std::end(text);
  for (int i = 0; i < number.decimals; ++i, units /= 10)
    *--at = static_cast<char>('0' + units % 10);
  if (number.decimals > 0) *--at = '.';
  do *--at = static_cast<char>('0' + units % 10);
  while ((units /= 10) != 0);
  if (negative) *--at = '-';
  return {at, static_cast<size_t>(std::end(text) - at)};
}
