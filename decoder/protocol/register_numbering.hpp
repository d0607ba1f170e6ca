// How people number registers. On the wire an address is 0-based; the drives' manuals write it
// in hex (2502H), mbpoll and many PLC manuals count from 1 (holding register 1 is address 0),
// and Modicon's convention puts the table's digit first (40001 is holding address 0, 30001
// input, 10001 discrete, 00001 coil; six digits past 9999: 409475). --register-base picks one
// for text, CSV, statistics and the report; JSON keeps the wire's number.
#pragma once

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

#include <fmt/compile.h>
#include <fmt/format.h>

#include "decoder/protocol/function_codes.hpp"
#include "decoder/protocol/number_text.hpp"

namespace modtap {

enum class RegisterBase : uint8_t { hex, zero, one, modicon };

template <>
struct EnumNames<RegisterBase> {
  static constexpr std::array<std::string_view, 4> names{"hex", "0", "1", "4xxxx"};
};

constexpr int modicon_digit(Table table) {
  switch (table) {
    case Table::coil:
      return 0;
    case Table::discrete:
      return 1;
    case Table::input:
      return 3;
    case Table::holding:
      return 4;
  }
  return 4;
}

// One register as a person of that convention writes it.
struct RegisterNumber {
  Table table;
  uint16_t address;
  RegisterBase base = RegisterBase::hex;
};

// A register a person named by number: 2502H and 0x2502 are always the wire's address; a
// decimal number is read in `base` (1-based: 1 is address 0; 4xxxx: 40001 is holding 0, and
// the digit gives the table). Nothing for a number that is no register in that convention.
struct NamedRegister {
  uint16_t address;
  std::optional<Table> table;  // only the 4xxxx convention says
};
inline std::optional<NamedRegister> parse_register_number(std::string_view text,
                                                          RegisterBase base) {
  const auto number = parse_written_number(text);
  if (!number) return std::nullopt;
  const bool decimal = text.find_first_not_of("0123456789") == std::string_view::npos;
  if (!decimal || base == RegisterBase::hex || base == RegisterBase::zero) {
    if (*number > 0xFFFF) return std::nullopt;
    return NamedRegister{static_cast<uint16_t>(*number), std::nullopt};
  }
  if (base == RegisterBase::one) {
    if (*number == 0 || *number > 0x10000) return std::nullopt;
    return NamedRegister{static_cast<uint16_t>(*number - 1), std::nullopt};
  }
  // 4xxxx: five digits up to 9999, six beyond; the first is the table.
  const uint64_t scale = text.size() >= 6 ? 100000 : 10000;
  const uint64_t digit = *number / scale, rest = *number % scale;
  if (text.size() < 5 || rest == 0 || rest > 0x10000) return std::nullopt;
  for (Table table : {Table::coil, Table::discrete, Table::input, Table::holding})
    if (static_cast<uint64_t>(modicon_digit(table)) == digit)
      return NamedRegister{static_cast<uint16_t>(rest - 1), table};
  return std::nullopt;
}

}  // namespace modtap

template <>
struct fmt::formatter<modtap::RegisterNumber> : formatter<string_view> {
  auto format(const modtap::RegisterNumber& r, format_context& ctx) const {
    const unsigned number = r.address;
    switch (r.base) {
      case modtap::RegisterBase::hex:
        return fmt::format_to(ctx.out(), FMT_COMPILE("{:04X}H"), number);
      case modtap::RegisterBase::zero:
        return fmt::format_to(ctx.out(), FMT_COMPILE("{}"), number);
      case modtap::RegisterBase::one:
        return fmt::format_to(ctx.out(), FMT_COMPILE("{}"), number + 1);
      case modtap::RegisterBase::modicon:
        return fmt::format_to(ctx.out(), "{}{:0{}}", modtap::modicon_digit(r.table), number + 1,
                              number + 1 > 9999 ? 5 : 4);
    }
    return ctx.out();
  }
};
