#include "decoder/models/device_model.hpp"

#include <algorithm>

#include <fmt/compile.h>
#include <fmt/format.h>

namespace modtap {
namespace {

// Whether the group rule numbers a parameter at `address`, in an open group or a closed one.
bool numbers_parameter(const ParameterGroups& groups, uint16_t address) {
  const unsigned group = address >> 8;
  const unsigned index = address & 0xFF;
  if (groups.closed.count(group)) return true;
  if (groups.counts.empty()) return group <= groups.max_group && index <= groups.max_index;
  const auto it = groups.counts.find(group);
  return it != groups.counts.end() && index < it->second;
}

// GGnnH: the group and the index are the two bytes of the address. The parameter is made in
// `made` itself: a lookup per word a frame carries, where a copy of the definition cost more
// than finding it.
void make_group_parameter(const ParameterGroups& groups, uint16_t address, bool& closed,
                          std::optional<RegisterDef>& made) {
  if (!numbers_parameter(groups, address)) return;
  const unsigned group = address >> 8;
  const unsigned index = address & 0xFF;
  closed = groups.closed.count(group) != 0;
  RegisterDef& def = made.emplace();
  def.address = address;
  def.table = groups.table;
  def.access = groups.access;
  // PREFIX GG.nn, each number at least two digits.
  char number[16];
  char* end = fmt::format_to(number, FMT_COMPILE("{:02}.{:02}"), group, index);
  def.name.reserve(groups.prefix.size() + static_cast<size_t>(end - number));
  def.name.append(groups.prefix).append(number, end);
}

}  // namespace

RegisterLookup find_register(const DeviceModel& model, Table table, uint16_t address) {
  RegisterLookup found;
  if (maps_no_register(model)) return found;
  // The alias reaches parameters only (GD20 7.4.3: "P00.07 ... 8007H"): 2000H's control word
  // with the high bit set is no register at all.
  if (model.alias && (address & model.alias->flag) && table == Table::holding) {
    const auto parameter = static_cast<uint16_t>(address & ~model.alias->flag);
    if (!model.groups || !numbers_parameter(*model.groups, parameter)) return found;
    found = find_register(model, table, parameter);
    if (found.def()) found.via_alias = true;
    return found;
  }
  if (auto it = model.registers.find({table, address}); it != model.registers.end()) {
    found.listed = &it->second;
    return found;
  }
  if (model.groups && model.groups->table == table)
    make_group_parameter(*model.groups, address, found.closed_group, found.made);
  return found;
}

bool names_register(const DeviceModel& model, std::string_view name) {
  for (const auto& [key, def] : model.registers)
    if (def.name == name) return true;
  if (!model.groups || !name.starts_with(model.groups->prefix)) return false;
  // PREFIX GG.nn, as make_parameter formats it: two or more digits, a point, two digits.
  const std::string_view number = name.substr(model.groups->prefix.size());
  const size_t point = number.find('.');
  auto digits = [](std::string_view s) {
    return !s.empty() &&
           std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
  };
  return point != std::string_view::npos && point >= 2 && digits(number.substr(0, point)) &&
         number.size() - point - 1 == 2 && digits(number.substr(point + 1));
}

std::string_view exception_meaning(const DeviceModel& model, uint8_t code) {
  const auto it = model.exceptions.find(code);
  return it == model.exceptions.end() ? std::string_view{} : std::string_view{it->second};
}

}  // namespace modtap
