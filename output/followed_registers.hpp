// The registers a run follows (--follow): by name or by number, in every output that picks
// registers (-T csv, the report's charts, MQTT, modtap top).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "decoder/models/register_meaning.hpp"
#include "decoder/protocol/register_numbering.hpp"

namespace modtap::output {

// One --follow item: a register's name (frequency_command, P00.04) or number (2502H, 0x2502,
// or a decimal number in the --register-base convention: 9474, 9475, 49475).
struct FollowedRegister {
  std::string name;
  std::optional<NamedRegister> number;
};

// Whether `reg` is one of `follow` (by name or address); an empty list follows every register.
bool follows(const std::vector<FollowedRegister>& follow, const RegisterValue& reg);

}  // namespace modtap::output
