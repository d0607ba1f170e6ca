// The one table of Modbus function codes: for each public code its name, whether slave 0 may
// receive it, how long its request and response are, whether a response fits its request,
// its fields, and the registers it reads or writes. The framers, the matcher, the field
// decoder, the model stage and the simulator all read it; nothing else knows a function code.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>

#include "decoder/protocol/enum_names.hpp"
#include "decoder/protocol/pdu_fields.hpp"
#include "decoder/protocol/records.hpp"

namespace modtap {

// Length of slave address + PDU (no CRC/LRC), told from the bytes seen so far.
struct BodyLength {
  enum class Kind : uint8_t {
    need_more,  // the header that tells the length has not arrived yet
    known,      // `bytes` is the length
    variable,   // the header does not tell (FC08/0000, unknown codes): search from `bytes` on
    invalid,    // this cannot be a frame of this role (bad byte count, illegal quantity)
  };
  Kind kind = Kind::invalid;
  // A variable length of a public function (FC08/0000 Return Query Data, FC2B/0D CANopen
  // reference), not of a code nobody publishes: its header is a frame a bus carries. It sits
  // in `kind`'s padding: a length rule's answer, asked at every start, stays four bytes.
  bool public_header = false;
  uint16_t bytes = 0;

  static constexpr BodyLength need_more() { return {Kind::need_more, false, 0}; }
  static constexpr BodyLength known(unsigned n) {
    return {Kind::known, false, static_cast<uint16_t>(n)};
  }
  static constexpr BodyLength variable(unsigned min) {
    return {Kind::variable, false, static_cast<uint16_t>(min)};
  }
  static constexpr BodyLength public_variable(unsigned min) {
    return {Kind::variable, true, static_cast<uint16_t>(min)};
  }
  static constexpr BodyLength invalid() { return {Kind::invalid, false, 0}; }
};
static_assert(sizeof(BodyLength) == 4);

// The four tables of the Modbus data model.
enum class Table : uint8_t { coil, discrete, holding, input };
template <>
struct EnumNames<Table> {
  static constexpr std::array<std::string_view, 4> names{"coil", "discrete", "holding", "input"};
};

// Registers or bits a PDU reads or writes, and where the values it carries are.
struct RegisterAccess {
  enum class Data : uint8_t {
    none,        // a read request, or a write whose value the PDU does not carry whole
    words,       // 16-bit values, big-endian
    bits,        // packed bits, LSB of the first byte first
    coil_state,  // FC05's FF00H (on) or 0000H (off)
  };
  Table table = Table::holding;
  uint16_t start = 0;
  uint16_t count = 0;
  bool write = false;
  Data data = Data::none;
  std::span<const uint8_t> values;
};

// At most two (FC17 reads and writes).
struct RegisterAccesses {
  std::array<RegisterAccess, 2> list{};
  uint8_t size = 0;
  const RegisterAccess* begin() const { return list.data(); }
  const RegisterAccess* end() const { return list.data() + size; }
};

// The first bytes of the PDU every good (non-exception) response to a request carries, as far
// as the request tells them: its echo, a byte count from the quantity, at least the code.
struct ResponsePrefix {
  std::array<uint8_t, 8> pdu{};
  uint8_t size = 0;
  // Every good response is the request again, CRC and all, whatever its length: each of its
  // bytes is told, and where the response's own header does not tell its length (FC08 Return
  // Query Data), the request's does.
  bool echoes_request = false;
};

struct FunctionCode {
  uint8_t code = 0;
  std::string_view name;  // empty for a code the standard does not define
  bool broadcast = true;  // writes may go to slave 0; reads may not (Application Protocol 4.1)
  // `prefix` starts at the slave address; at least two bytes.
  BodyLength (*request_length)(std::span<const uint8_t> prefix);
  BodyLength (*response_length)(std::span<const uint8_t> prefix);
  // What a request asks beyond the standard's limits: quantity, byte count, value findings.
  uint32_t (*request_findings)(std::span<const uint8_t> pdu);
  // Whether a (non-exception) response fits its request: a Finding, or finding_none.
  Finding (*response_fit)(std::span<const uint8_t> request_pdu, std::span<const uint8_t> pdu);
  // The fields after the function code.
  void (*request_fields)(PduReader& pdu, FieldWriter& out);
  void (*response_fields)(PduReader& pdu, std::span<const uint8_t> request_pdu, FieldWriter& out);
  RegisterAccesses (*request_accesses)(std::span<const uint8_t> pdu);
  // The values a response carries, placed by its request.
  std::optional<RegisterAccess> (*response_values)(std::span<const uint8_t> pdu,
                                                   std::span<const uint8_t> request_pdu);
  ResponsePrefix (*response_prefix)(std::span<const uint8_t> request_pdu);

  bool is_public() const { return !name.empty(); }
};

// The row of `fc` (exception bit ignored); a code the standard does not define gets a row that
// reads its data as bytes and its length from the CRC.
const FunctionCode& function_code(uint8_t fc);
// The public codes, in order.
std::span<const FunctionCode> public_function_codes();

// `prefix` starts at the slave address. Role must be request or response.
BodyLength body_length(Role role, std::span<const uint8_t> prefix);

// What a request asks beyond the standard's limits: finding_quantity_out_of_spec,
// finding_byte_count_mismatch, finding_value_out_of_spec.
uint32_t request_spec_findings(std::span<const uint8_t> pdu);
// What every good response to this request PDU starts with (ResponsePrefix).
ResponsePrefix response_prefix(std::span<const uint8_t> request_pdu);
// The slave address and PDU of the answer to `request_pdu` from `slave`, where the request
// tells its length (a read's byte count, an echo): that many bytes, 0 where it does not.
uint16_t told_answer_size(uint8_t slave, std::span<const uint8_t> request_pdu);
// Whether a response's content fits its request: byte counts against quantities, echoes
// against what was sent. Returns the finding to raise, or finding_none.
Finding check_response_fit(std::span<const uint8_t> request_pdu,
                           std::span<const uint8_t> response_pdu);

inline bool is_public_function(uint8_t fc) {
  return function_code(fc).is_public();
}
inline bool may_broadcast(uint8_t fc) {
  return function_code(fc).broadcast;
}
// The standard's name, or empty.
inline std::string_view function_name(uint8_t fc) {
  return function_code(fc).name;
}
// The standard's name, or "Function 0x41" for a code it does not name (the exception bit
// left off).
std::string_view function_label(uint8_t fc);
// Names from the Modbus Application Protocol, or empty where it has none.
std::string_view exception_name(uint8_t code);
std::string_view diagnostic_name(uint16_t sub);  // FC08 sub-function

// The largest ADU: 256 bytes in RTU (Modbus over Serial Line 2.5.1.1).
inline constexpr uint16_t max_rtu_adu = 256;

}  // namespace modtap
