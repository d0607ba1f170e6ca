// Character format of a serial line and the Modbus timings derived from it.
#pragma once

#include <cstdint>
#include <string_view>

#include "decoder/protocol/enum_names.hpp"

namespace modtap {

enum class Parity : uint8_t { none, even, odd };
template <>
struct EnumNames<Parity> {
  static constexpr std::array<std::string_view, 3> names{"none", "even", "odd"};
};

struct SerialFormat {
  uint32_t baud = 19200;
  uint8_t data_bits = 8;
  Parity parity = Parity::even;
  uint8_t stop_bits = 1;

  // Bits on the wire for one character: start + data + parity + stop.
  constexpr uint32_t bits_per_char() const {
    return 1u + data_bits + (parity == Parity::none ? 0u : 1u) + stop_bits;
  }
  // Modbus over Serial Line 2.5: RTU's characters have 8 data bits, ASCII's 7. For a line
  // whose data bits nobody gave, the mode's.
  constexpr SerialFormat with_data_bits_of(bool ascii) const {
    SerialFormat f = *this;
    f.data_bits = ascii ? 7 : 8;
    return f;
  }
  constexpr int64_t char_time_ns() const {
    return static_cast<int64_t>(bits_per_char()) * 1'000'000'000 / baud;
  }
  // Modbus over Serial Line V1.02, 2.5.1.1: above 19200 baud the timers are fixed at
  // 750 us and 1750 us so that fast lines do not load the CPU with tiny time-outs.
  constexpr int64_t t15_ns() const { return baud > 19200 ? 750'000 : char_time_ns() * 3 / 2; }
  constexpr int64_t t35_ns() const { return baud > 19200 ? 1'750'000 : char_time_ns() * 7 / 2; }
};

}  // namespace modtap
