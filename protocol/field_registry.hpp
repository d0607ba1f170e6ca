// Every field modtap shows, written once: its name (the JSON key, the text label, the name a
// filter and the Wireshark plugin use), its title for people, and its type, which says how
// text prints it. Wireshark's hf array is the model; `modtap fields` lists this table.
#pragma once

#include <cstdint>
#include <span>
#include <string_view>

#include "protocol/enum_names.hpp"

namespace modtap {

enum class FieldType : uint8_t {
  integer,    // decimal
  hex,        // text 0x00ff, JSON a number
  address,    // text 2502H as the manuals write registers, JSON a number
  code,       // text 52H as vendors' tables write codes, JSON a number
  real,       // a measured number (latency)
  name,       // a fixed name: the standard's, or an enumeration's
  string,     // characters a device sent
  bytes,      // hex
  registers,  // 16-bit values
  bits,       // coils and inputs, 0 or 1
  list,       // items, each a group of fields (sub-requests, objects)
  names,      // a list of names (findings)
  flag,       // present and true, or absent
};
template <>
struct EnumNames<FieldType> {
  static constexpr std::array<std::string_view, 13> names{
      "integer", "hex",       "address", "code", "real",  "name", "string",
      "bytes",   "registers", "bits",    "list", "names", "flag"};
};

// Record fields first, then the PDU's; the order of FieldInfo in field_registry().
enum class FieldId : uint8_t {
  // Every record
  type,
  index,
  t_ns,
  end_ns,
  channel,
  offset,
  mode,
  raw,
  // Frames
  role,
  slave,
  fc,
  function,
  check,
  check_value,
  expected_check,
  damage,
  exception,
  request,
  latency_us,
  findings,
  model,
  registers,
  notes,
  truncated,
  // Noise and time-outs
  reason,
  waited_us,
  // PDU fields
  address,
  quantity,
  value,
  coil_value,
  state,
  byte_count,
  register_values,
  bit_values,
  sub_function,
  sub_function_name,
  data,
  status,
  event_count,
  message_count,
  events,
  and_mask,
  or_mask,
  read_address,
  read_quantity,
  write_address,
  write_quantity,
  fifo_address,
  fifo_count,
  exception_code,
  exception_name,
  sub_requests,
  sub_responses,
  reference_type,
  file,
  record,
  length,
  record_values,
  mei_type,
  read_device_id_code,
  object_id,
  conformity_level,
  more_follows,
  next_object_id,
  number_of_objects,
  objects,
  object_number,
  object_name,
  object_value,
};

// The PDU's fields begin here; those before belong to the record.
inline constexpr FieldId first_pdu_field = FieldId::address;

struct FieldInfo {
  FieldId id;
  std::string_view name;
  std::string_view title;
  FieldType type;
  bool item = false;  // a field of a list's items (sub-requests, objects), not of the record
};

std::span<const FieldInfo> field_registry();
const FieldInfo& field_info(FieldId id);

// What JSON makes of a type: "number", "string", "array", "boolean".
std::string_view json_kind(FieldType type);

}  // namespace modtap
