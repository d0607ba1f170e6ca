// Appending text and numbers to an fmt::memory_buffer in place. fmt's own append is compiled
// into libfmt, one call per piece, and its compiled formats copy each literal piece through it:
// for the many short pieces of an output line, a third of the time.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>

#include <fmt/compile.h>
#include <fmt/format.h>

namespace modtap {

[[gnu::always_inline]] inline void put(fmt::memory_buffer& out, std::string_view text) {
  const size_t at = out.size();
  out.resize(at + text.size());
  std::copy(text.begin(), text.end(), out.data() + at);
}

// Room for `n` more characters, made out of line: the paths that write into it then need no
// registers for growing the buffer, which they would save and restore on every call.
[[gnu::noinline]] inline void make_room(fmt::memory_buffer& out, size_t n) {
  out.reserve(out.size() + n);
}

// What the buffer already holds at [from, to), appended again: a number printed twice is copied.
inline void put_again(fmt::memory_buffer& out, size_t from, size_t to) {
  const size_t at = out.size();
  out.resize(at + (to - from));
  std::memcpy(out.data() + at, out.data() + from, to - from);
}

// Decimal without fmt's parsing: the hot path of every line. The digits go straight into the
// buffer's room for the longest number; its size is then set to what they took, through the
// buffer's base, where growing is a call it never makes here.
template <typename Integer>
[[gnu::always_inline]] inline void put_decimal(fmt::memory_buffer& out, Integer v) {
  if (out.capacity() - out.size() < 20) make_room(out, 20);
  const char* end = fmt::format_to(out.data() + out.size(), FMT_COMPILE("{}"), v);
  static_cast<fmt::detail::buffer<char>&>(out).try_resize(static_cast<size_t>(end - out.data()));
}
// What fits 32 bits unsigned (nearly every index, count and duration) takes 32-bit arithmetic: its
// division by 100 per two digits is a cheaper multiply than the 64-bit one.
inline void put_uint(fmt::memory_buffer& out, uint64_t v) {
  if (v <= UINT32_MAX) return put_decimal(out, static_cast<uint32_t>(v));
  put_decimal(out, v);
}
inline void put_int(fmt::memory_buffer& out, int64_t v) {
  if (v >= 0) return put_uint(out, static_cast<uint64_t>(v));
  put_decimal(out, v);
}

// "00" to "99": decimal digits two at a time, one division by 100 a pair.
inline constexpr auto decimal_pairs = [] {
  std::array<char, 200> pairs{};
  for (int i = 0; i < 100; ++i) {
    pairs[2 * i] = static_cast<char>('0' + i / 10);
    pairs[2 * i + 1] = static_cast<char>('0' + i % 10);
  }
  return pairs;
}();

// Exactly `count` digits of `v`, zeros first (v < 10^count): the digits below a second.
inline void put_zero_padded(fmt::memory_buffer& out, uint32_t v, int count) {
  const size_t at = out.size();
  out.resize(at + static_cast<size_t>(count));
  char* end = out.data() + at + count;
  for (; count >= 2; count -= 2, v /= 100) {
    end -= 2;
    std::memcpy(end, &decimal_pairs[2 * (v % 100)], 2);
  }
  if (count) end[-1] = static_cast<char>('0' + v);
}

// A text for each value of a byte, made once by `make(out, byte)`: a piece that every record
// repeats (a function code's name with the keys around it) then goes in one copy.
template <typename Make>
std::array<std::string, 256> texts_per_byte(Make make) {
  std::array<std::string, 256> texts;
  fmt::memory_buffer piece;
  for (size_t value = 0; value < texts.size(); ++value) {
    piece.clear();
    make(piece, static_cast<uint8_t>(value));
    texts[value].assign(piece.data(), piece.size());
  }
  return texts;
}

// The digits of a number that changes seldom (a time's whole seconds), made only when it does.
class KeptDecimal {
 public:
  std::string_view of(uint64_t v) {
    if (v != value_ || text_.empty()) {
      value_ = v;
      const fmt::format_int digits(v);
      text_.assign(digits.data(), digits.size());
    }
    return text_;
  }

 private:
  uint64_t value_ = 0;
  std::string text_;
};

// Nanoseconds since the epoch as one integer, as JSON carries times: the second's ten digits
// are made once a second and the nine below it each time, a third of the work of nineteen.
class NanosecondsText {
 public:
  void put(fmt::memory_buffer& out, int64_t ns) {
    if (ns < second_ns) return put_int(out, ns);  // no second's digits to keep (or negative)
    const int64_t seconds = ns / second_ns;
    modtap::put(out, seconds_.of(static_cast<uint64_t>(seconds)));
    put_zero_padded(out, static_cast<uint32_t>(ns - seconds * second_ns), 9);
  }

 private:
  static constexpr int64_t second_ns = 1'000'000'000;
  KeptDecimal seconds_;
};

// `count` hex digits of `v`, uppercase (a register address as the manuals write it: 2502) or
// lowercase (a value shown as 0xff00).
inline void put_hex(fmt::memory_buffer& out, uint32_t v, int count, bool upper = true) {
  const char* digits = upper ? "0123456789ABCDEF" : "0123456789abcdef";
  const size_t at = out.size();
  out.resize(at + static_cast<size_t>(count));
  char* end = out.data() + at + count;
  for (; count > 0; --count, v >>= 4) *--end = digits[v & 0xF];
}
inline void put_hex4(fmt::memory_buffer& out, uint16_t v) {
  put_hex(out, v, 4);
}

}  // namespace modtap
