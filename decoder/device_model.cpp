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
  if (model.registers.empty() && !model.groups) return found;  // the generic model maps nothing
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

}  // namespace modtap::decoder
