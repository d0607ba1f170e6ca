// Appending text and numbers to an fmt::memory_buffer in place. fmt's own append is compiled
// into libfmt, one call per piece, and its compiled formats copy each literal piece through it:
// for the many short pieces of an output line, a third of the time.
#pragma once

#include <algorithm>
#include <cstdint>
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

// Decimal without fmt's parsing: the hot path of every line. The digits go straight into the
// buffer's room for the longest number, which is then cut to what they took.
template <typename Integer>
[[gnu::always_inline]] inline void put_decimal(fmt::memory_buffer& out, Integer v) {
  const size_t at = out.size();
  out.resize(at + 20);
  const char* end = fmt::format_to(out.data() + at, FMT_COMPILE("{}"), v);
  out.resize(static_cast<size_t>(end - out.data()));
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

// Nanoseconds since the epoch as one integer, as JSON carries times: the second's ten digits
// are made once a second and the nine below it each time, a third of the work of nineteen.
class NanosecondsText {
 public:
  void put(fmt::memory_buffer& out, int64_t ns) {
    if (ns < second_ns) return put_int(out, ns);  // no second's digits to keep (or negative)
    const int64_t seconds = ns / second_ns;
    if (seconds != seconds_) {
      seconds_ = seconds;
      const fmt::format_int digits(seconds);
      seconds_text_.assign(digits.data(), digits.size());
    }
    modtap::put(out, seconds_text_);
    auto below = static_cast<uint32_t>(ns - seconds * second_ns);
    char digits[9];
    for (int i = 8; i >= 0; --i, below /= 10) digits[i] = static_cast<char>('0' + below % 10);
    modtap::put(out, {digits, 9});
  }

 private:
  static constexpr int64_t second_ns = 1'000'000'000;
  int64_t seconds_ = -1;
  std::string seconds_text_;
};

// Four uppercase hex digits: a register address as the manuals write it (2502).
inline void put_hex4(fmt::memory_buffer& out, uint16_t v) {
  constexpr char digits[] = "0123456789ABCDEF";
  const char text[4] = {digits[v >> 12], digits[(v >> 8) & 0xF], digits[(v >> 4) & 0xF],
                        digits[v & 0xF]};
  put(out, {text, 4});
}

}  // namespace modtap
