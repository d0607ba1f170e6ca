// One table of the public Modbus function codes, shared by both framers, the matcher and the
// field decoder: names, whether slave 0 may receive them, and how long their frames are.
#pragma once

#include <cstdint>
#include <span>

#include "decoder/records.hpp"

namespace modtap::decoder {

// Length of slave address + PDU (no CRC/LRC), told from the bytes seen so far.
struct BodyLength {
  enum class Kind : uint8_t {
    need_more,  // the header that tells the length has not arrived yet
    known,      // `bytes` is the length
    variable,   // the header does not tell (FC08/0000, unknown codes): search from `bytes` on
    invalid,    // this cannot be a frame of this role (bad byte count, illegal quantity)
  };
  Kind kind = Kind::invalid;
  uint16_t bytes = 0;

  static constexpr BodyLength need_more() { return {Kind::need_more, 0}; }
  static constexpr BodyLength known(unsigned n) { return {Kind::known, static_cast<uint16_t>(n)}; }
  static constexpr BodyLength variable(unsigned min) {
    return {Kind::variable, static_cast<uint16_t>(min)};
  }
  static constexpr BodyLength invalid() { return {Kind::invalid, 0}; }
};

// `prefix` starts at the slave address. Role must be request or response.
BodyLength body_length(Role role, std::span<const uint8_t> prefix);

// What a request (`pdu` from the function code on) asks beyond the standard's limits:
// finding_quantity_out_of_spec, finding_byte_count_mismatch, finding_value_out_of_spec.
uint32_t request_spec_findings(std::span<const uint8_t> pdu);

// Whether `fc` (without the exception bit) is a public function code.
bool is_public_function(uint8_t fc);
// Writes may be broadcast to slave 0; reads may not (Modbus Application Protocol 4.1).
bool may_broadcast(uint8_t fc);

// Names from the Modbus Application Protocol, or nullptr where the standard has none.
const char* function_name(uint8_t fc);  // exception bit ignored
const char* exception_name(uint8_t code);
const char* diagnostic_name(uint16_t sub);  // FC08 sub-function

// The largest ADU: 256 bytes in RTU (Modbus over Serial Line 2.5.1.1).
inline constexpr uint16_t max_rtu_adu = 256;

}  // namespace modtap::decoder
