// Every field modtap shows, written once: its name (the JSON key, the text label, the name a
// filter and the Wireshark plugin use), its title for people, and its type, which says how
// text prints it. Wireshark's hf array is the model; `modtap fields` lists this table.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string_view>
#include <type_traits>

#include "decoder/protocol/enum_names.hpp"

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
  damaged_answer,
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

namespace field_registry_table {
using enum FieldId;
using T = FieldType;

inline constexpr std::array field_table{
    FieldInfo{type, "type", "Record type", T::name},
    FieldInfo{index, "index", "Record", T::integer},
    FieldInfo{t_ns, "t_ns", "Start (ns)", T::integer},
    FieldInfo{end_ns, "end_ns", "End (ns)", T::integer},
    FieldInfo{channel, "channel", "Channel", T::string},
    FieldInfo{offset, "offset", "Byte offset", T::integer},
    FieldInfo{mode, "mode", "Mode", T::name},
    FieldInfo{raw, "raw", "Wire bytes", T::bytes},
    FieldInfo{role, "role", "Role", T::name},
    FieldInfo{slave, "slave", "Slave", T::integer},
    FieldInfo{fc, "fc", "Function code", T::integer},
    FieldInfo{function, "function", "Function", T::name},
    FieldInfo{check, "check", "Check", T::name},
    FieldInfo{check_value, "check_value", "Check on the wire", T::integer},
    FieldInfo{expected_check, "expected_check", "Expected check", T::integer},
    FieldInfo{damage, "damage", "Damage", T::name},
    FieldInfo{exception, "exception", "Exception code", T::code},
    FieldInfo{request, "request", "Request in record", T::integer},
    FieldInfo{latency_us, "latency_us", "Latency (us)", T::real},
    FieldInfo{findings, "findings", "Findings", T::names},
    FieldInfo{model, "model", "Device model", T::name},
    FieldInfo{registers, "registers", "Registers", T::list},
    FieldInfo{notes, "notes", "Model findings", T::list},
    FieldInfo{truncated, "truncated", "PDU shorter than its fields", T::flag},
    FieldInfo{reason, "reason", "Reason", T::name},
    FieldInfo{waited_us, "waited_us", "Waited (us)", T::real},
    FieldInfo{damaged_answer, "damaged_answer", "The slave's answer, garbled", T::flag},
    FieldInfo{address, "address", "Address", T::address},
    FieldInfo{quantity, "quantity", "Quantity", T::integer},
    FieldInfo{value, "value", "Value", T::integer},
    FieldInfo{coil_value, "value", "Coil value", T::hex},
    FieldInfo{state, "state", "Coil state", T::name},
    FieldInfo{byte_count, "byte_count", "Byte count", T::integer},
    FieldInfo{register_values, "values", "Register values", T::registers},
    FieldInfo{bit_values, "values", "Bit values", T::bits},
    FieldInfo{sub_function, "sub_function", "Sub-function", T::integer},
    FieldInfo{sub_function_name, "sub_function_name", "Sub-function name", T::name},
    FieldInfo{data, "data", "Data", T::bytes},
    FieldInfo{status, "status", "Status", T::hex},
    FieldInfo{event_count, "event_count", "Event count", T::integer},
    FieldInfo{message_count, "message_count", "Message count", T::integer},
    FieldInfo{events, "events", "Events", T::bytes},
    FieldInfo{and_mask, "and_mask", "AND mask", T::hex},
    FieldInfo{or_mask, "or_mask", "OR mask", T::hex},
    FieldInfo{read_address, "read_address", "Read address", T::address},
    FieldInfo{read_quantity, "read_quantity", "Read quantity", T::integer},
    FieldInfo{write_address, "write_address", "Write address", T::address},
    FieldInfo{write_quantity, "write_quantity", "Write quantity", T::integer},
    FieldInfo{fifo_address, "fifo_address", "FIFO address", T::address},
    FieldInfo{fifo_count, "fifo_count", "FIFO count", T::integer},
    FieldInfo{exception_code, "exception_code", "Exception code", T::code},
    FieldInfo{exception_name, "exception_name", "Exception", T::name},
    FieldInfo{sub_requests, "sub_requests", "Sub-requests", T::list},
    FieldInfo{sub_responses, "sub_responses", "Sub-responses", T::list},
    FieldInfo{reference_type, "reference_type", "Reference type", T::integer, true},
    FieldInfo{file, "file", "File number", T::integer, true},
    FieldInfo{record, "record", "Record number", T::integer, true},
    FieldInfo{length, "length", "Record length", T::integer, true},
    FieldInfo{record_values, "values", "Record values", T::registers, true},
    FieldInfo{mei_type, "mei_type", "MEI type", T::hex},
    FieldInfo{read_device_id_code, "read_device_id_code", "Read device ID code", T::integer},
    FieldInfo{object_id, "object_id", "Object ID", T::integer},
    FieldInfo{conformity_level, "conformity_level", "Conformity level", T::integer},
    FieldInfo{more_follows, "more_follows", "More follows", T::integer},
    FieldInfo{next_object_id, "next_object_id", "Next object ID", T::integer},
    FieldInfo{number_of_objects, "number_of_objects", "Number of objects", T::integer},
    FieldInfo{objects, "objects", "Objects", T::list},
    FieldInfo{object_number, "id", "Object ID", T::integer, true},
    FieldInfo{object_name, "name", "Object name", T::name, true},
    FieldInfo{object_value, "value", "Object value", T::string, true},
};

constexpr bool in_id_order() {
  for (size_t i = 0; i < field_table.size(); ++i)
    if (static_cast<size_t>(field_table[i].id) != i) return false;
  return true;
}
static_assert(in_id_order(), "the registry lists every field in FieldId's order");

}  // namespace field_registry_table

inline std::span<const FieldInfo> field_registry() {
  return field_registry_table::field_table;
}
constexpr const FieldInfo& field_info(FieldId id) {
  return field_registry_table::field_table[static_cast<size_t>(id)];
}

// A field's id as a type, for code that wants its name at compile time (JSON's keys).
template <FieldId id>
using FieldTag = std::integral_constant<FieldId, id>;
template <FieldId id>
inline constexpr FieldTag<id> field{};

// What JSON makes of a type: "number", "string", "array", "boolean".
std::string_view json_kind(FieldType type);

}  // namespace modtap
