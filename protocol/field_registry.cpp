#include "protocol/field_registry.hpp"

#include <array>

namespace modtap {
namespace {

using enum FieldId;
using T = FieldType;

constexpr std::array registry{
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
  for (size_t i = 0; i < registry.size(); ++i)
    if (static_cast<size_t>(registry[i].id) != i) return false;
  return true;
}
static_assert(in_id_order(), "the registry lists every field in FieldId's order");

}  // namespace

std::span<const FieldInfo> field_registry() {
  return registry;
}

const FieldInfo& field_info(FieldId id) {
  return registry[static_cast<size_t>(id)];
}

std::string_view json_kind(FieldType type) {
  switch (type) {
    case T::integer:
    case T::hex:
    case T::address:
    case T::code:
    case T::real:
      return "number";
    case T::name:
    case T::string:
    case T::bytes:
      return "string";
    case T::registers:
    case T::bits:
    case T::list:
    case T::names:
      return "array";
    case T::flag:
      return "boolean";
  }
  return "?";
}

}  // namespace modtap
