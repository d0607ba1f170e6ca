// Pieces shared by the text and JSON sinks: hex, JSON strings, decoded fields as the field
// registry says each type prints, and register values.
#pragma once

#include <algorithm>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include <fmt/compile.h>
#include <fmt/format.h>

#include "decoder/models/register_meaning.hpp"
#include "decoder/protocol/buffer_put.hpp"
#include "decoder/protocol/clock_time.hpp"
#include "decoder/protocol/pdu_fields.hpp"
#include "decoder/protocol/records.hpp"
#include "decoder/protocol/register_numbering.hpp"

namespace modtap::output {

void append_hex(fmt::memory_buffer& out, std::span<const uint8_t> bytes, bool spaced);
void append_json_string(fmt::memory_buffer& out, std::string_view text);

// How text writes a frame's address fields: the convention, and the table the frame's function
// code addresses (Modicon's numbers say it).
struct AddressNumbering {
  RegisterBase base = RegisterBase::hex;
  Table table = Table::holding;
};
// The table a frame's address fields name, from its function code's register accesses.
Table addressed_table(const Frame& frame);

// The field at `at` as JSON ("key":value; a list with its items), and as text (`key=` is the
// caller's), with at most `max_items` values of an array. Both return the index of the next
// field of the same level.
size_t append_json_field(fmt::memory_buffer& out, const DecodedPdu& pdu, size_t at);
size_t append_text_value(fmt::memory_buffer& out, const DecodedPdu& pdu, size_t at,
                         size_t max_items, AddressNumbering numbering = {});

// The same as a JSON object: {"addr", "name", "raw", "value", "unit", "text"}.
void append_register_json(fmt::memory_buffer& out, const RegisterValue& reg);
// The same keys without the braces, for an object that adds its own.
void append_register_keys(fmt::memory_buffer& out, const RegisterValue& reg);

// "Read Holding Registers", or "Function 0x41" for a code the standard does not name.
struct FunctionLabel {
  uint8_t fc;
};
void put_function_label(fmt::memory_buffer& out, uint8_t fc);

// "per-chunk, a read up to 30 ms late": how the source timed its bytes, and for a clock per read
// how late it may stamp one, below which its latencies and gaps say nothing.
std::string clock_text(ClockQuality clock, int64_t read_lag_ns);

// "1 bad check", "2 bad checks": a count with its noun in the number it takes.
inline std::string counted(uint64_t n, std::string_view one, std::string_view many) {
  return fmt::format("{} {}", n, n == 1 ? one : many);
}

// `count` spaces in one piece (a push_back each checked the room every time).
inline void put_spaces(fmt::memory_buffer& out, size_t count) {
  const size_t at = out.size();
  out.resize(at + count);
  std::fill_n(out.data() + at, count, ' ');
}

// `v` and spaces after it to `width` characters.
inline void put_left_aligned(fmt::memory_buffer& out, uint64_t v, size_t width) {
  const size_t start = out.size();
  put_uint(out, v);
  const size_t used = out.size() - start;
  if (used < width) put_spaces(out, width - used);
}

// Spaces, then `text`, to `width` characters.
inline void put_right_aligned(fmt::memory_buffer& out, std::string_view text, size_t width) {
  if (text.size() < width) put_spaces(out, width - text.size());
  put(out, text);
}
inline void put_right_aligned(fmt::memory_buffer& out, uint64_t v, size_t width) {
  const fmt::format_int digits(v);
  put_right_aligned(out, {digits.data(), digits.size()}, width);
}

// value x 10^-exponent shown with `decimals` digits after the point, from integers: exact
// where the digits suffice (nanoseconds as microseconds with 3), else rounded half away from
// zero. Fixed{ns, 9, 6} is seconds as text shows them. A width in the format pads on the left.
struct Fixed {
  int64_t value;
  int exponent;
  int decimals;
};
// Its text, in `room`.
std::string_view fixed_text(Fixed number, char (&room)[48]);
// Its text after spaces to `width` characters, straight into the buffer.
inline void put_fixed(fmt::memory_buffer& out, Fixed number, size_t width = 0) {
  char room[48];
  put_right_aligned(out, fixed_text(number, room), width);
}

// The format of text modtap composes itself (digits, the standard's names): `[<>]WIDTH` pads
// it with spaces, on the left with `>`. Being ASCII, its width is its length, so fmt's Unicode
// width computation, which cost more than making the digits, is not needed.
struct AsciiFormatter {
  char align = '<';
  int width = 0;

  constexpr auto parse(fmt::format_parse_context& ctx) -> decltype(ctx.begin()) {
    auto it = ctx.begin();
    if (it != ctx.end() && (*it == '<' || *it == '>')) align = *it++;
    while (it != ctx.end() && *it >= '0' && *it <= '9') width = width * 10 + (*it++ - '0');
    if (it != ctx.end() && *it != '}') throw fmt::format_error("expected [<>]WIDTH");
    return it;
  }
  template <typename Out>
  Out write(Out out, std::string_view text) const {
    const size_t pad = static_cast<size_t>(width) > text.size() ? width - text.size() : 0;
    if (align == '>') out = std::fill_n(out, pad, ' ');
    out = fmt::format_to(out, FMT_COMPILE("{}"), text);  // a copy fmt makes in one piece
    if (align != '>') out = std::fill_n(out, pad, ' ');
    return out;
  }
};

}  // namespace modtap::output

template <>
struct fmt::formatter<modtap::output::Fixed> : modtap::output::AsciiFormatter {
  auto format(modtap::output::Fixed number, format_context& ctx) const -> decltype(ctx.out());
};

template <>
struct fmt::formatter<modtap::output::FunctionLabel> : modtap::output::AsciiFormatter {
  auto format(modtap::output::FunctionLabel label, format_context& ctx) const
      -> decltype(ctx.out());
};
