#include "decoder/device_model.hpp"

#include <fmt/format.h>

namespace modtap::decoder {
namespace {

// GGnnH: the group and the index are the two bytes of the address.
std::optional<RegisterDef> group_parameter(const ParameterGroups& groups, uint16_t address,
                                           bool& closed) {
  const unsigned group = address >> 8;
  const unsigned index = address & 0xFF;
  if (groups.closed.count(group)) {
    closed = true;
  } else if (groups.counts.empty()) {
    if (group > groups.max_group || index > groups.max_index) return std::nullopt;
  } else {
    const auto it = groups.counts.find(group);
    if (it == groups.counts.end() || index >= it->second) return std::nullopt;
  }
  RegisterDef def;
  def.address = address;
  def.table = groups.table;
  def.access = groups.access;
  def.name = fmt::format("{}{:02}.{:02}", groups.prefix, group, index);
  return def;
}

}  // namespace

RegisterLookup find_register(const DeviceModel& model, Table table, uint16_t address) {
  RegisterLookup found;
  if (model.alias && (address & model.alias->flag) && table == Table::holding) {
    found = find_register(model, table, static_cast<uint16_t>(address & ~model.alias->flag));
    if (found.def()) found.via_alias = true;
    return found;
  }
  if (auto it = model.registers.find({table, address}); it != model.registers.end()) {
    found.listed = &it->second;
    return found;
  }
  if (model.groups && model.groups->table == table)
    found.made = group_parameter(*model.groups, address, found.closed_group);
  return found;
}

const char* to_string(Table table) {
  switch (table) {
    case Table::coil:
      return "coil";
    case Table::discrete:
      return "discrete";
    case Table::holding:
      return "holding";
    case Table::input:
      return "input";
  }
  return "?";
}

const char* to_string(Access access) {
  switch (access) {
    case Access::read:
      return "R";
    case Access::write:
      return "W";
    case Access::read_write:
      return "RW";
  }
  return "?";
}

const char* to_string(ValueType type) {
  switch (type) {
    case ValueType::u16:
      return "u16";
    case ValueType::s16:
      return "s16";
    case ValueType::u32:
      return "u32";
    case ValueType::s32:
      return "s32";
    case ValueType::f32:
      return "f32";
    case ValueType::bcd:
      return "bcd";
    case ValueType::string:
      return "string";
    case ValueType::raw:
      return "raw";
  }
  return "?";
}

}  // namespace modtap::decoder
