#include "decoder/function_codes.hpp"

#include <array>

namespace modtap::decoder {
namespace {

using L = BodyLength;

constexpr uint16_t be16(std::span<const uint8_t> p, size_t at) {
  return static_cast<uint16_t>(p[at] << 8 | p[at + 1]);
}

// Quantities the standard allows per request (Modbus Application Protocol V1.1b3, 6.x).
constexpr bool in_range(unsigned v, unsigned lo, unsigned hi) {
  return v >= lo && v <= hi;
}

// A length carried in a byte count at `at`: body = at + 1 + count.
L counted(std::span<const uint8_t> p, size_t at, unsigned lo = 0, unsigned hi = 252) {
  if (p.size() <= at) return L::need_more();
  unsigned count = p[at];
  if (!in_range(count, lo, hi)) return L::invalid();
  return L::known(at + 1 + count);
}

// FC2B/0E response: a header of 8 bytes, then objects {id, length, value}.
L device_identification_response(std::span<const uint8_t> p) {
  if (p.size() < 3) return L::need_more();
  if (p[2] != 0x0E) return L::variable(3);
  if (p.size() < 8) return L::need_more();
  size_t at = 8;
  for (unsigned objects = p[7]; objects > 0; --objects) {
    if (p.size() < at + 2) return L::need_more();
    at += 2 + p[at + 1];
    if (at > max_rtu_adu - 2) return L::invalid();
  }
  return L::known(at);
}

// A request's length follows from its structure alone: a quantity or value outside the
// standard's limits is still a frame (a master may ask for 126 registers and get exception 03),
// reported by request_spec_findings.
L request_length(std::span<const uint8_t> p) {
  const uint8_t fc = p[1];
  if (fc & 0x80) return L::invalid();  // the exception bit: only responses carry it
  switch (fc) {
    case 0x01:
    case 0x02:
    case 0x03:
    case 0x04:
    case 0x05:
    case 0x06:
      return L::known(6);
    case 0x07:
    case 0x0B:
    case 0x0C:
    case 0x11:
      return L::known(2);
    case 0x08:
      if (p.size() < 4) return L::need_more();
      return be16(p, 2) == 0x0000 ? L::variable(4) : L::known(6);
    case 0x0F:
    case 0x10:
      return counted(p, 6, 1);
    case 0x14:
    case 0x15:
      return counted(p, 2, 7, 245);
    case 0x16:
      return L::known(8);
    case 0x17:
      return counted(p, 10, 1);
    case 0x18:
      return L::known(4);
    case 0x2B:
      if (p.size() < 3) return L::need_more();
      return p[2] == 0x0E ? L::known(5) : L::variable(3);
    default:
      return L::variable(2);
  }
}

L response_length(std::span<const uint8_t> p) {
  const uint8_t fc = p[1];
  if (fc & 0x80) return p[0] == 0 ? L::invalid() : L::known(3);
  switch (fc) {
    case 0x01:
    case 0x02:
      return counted(p, 2, 1, 250);
    case 0x03:
    case 0x04: {
      L l = counted(p, 2, 2, 250);
      return (l.kind == L::Kind::known && p[2] % 2 != 0) ? L::invalid() : l;
    }
    case 0x05:
    case 0x06:
    case 0x0B:
    case 0x0F:
    case 0x10:
      return L::known(6);
    case 0x07:
      return L::known(3);
    case 0x08:
      if (p.size() < 4) return L::need_more();
      return be16(p, 2) == 0x0000 ? L::variable(4) : L::known(6);
    case 0x0C:
    case 0x11:
    case 0x14:
    case 0x15:
    case 0x17:
      return counted(p, 2, 1, 252);
    case 0x16:
      return L::known(8);
    case 0x18: {
      if (p.size() < 4) return L::need_more();
      unsigned count = be16(p, 2);
      if (!in_range(count, 2, 64)) return L::invalid();
      return L::known(4 + count);
    }
    case 0x2B:
      return device_identification_response(p);
    default:
      return L::variable(2);
  }
}

struct FunctionInfo {
  uint8_t code;
  const char* name;
  bool broadcast;
};

constexpr std::array<FunctionInfo, 20> functions{{
    {0x01, "Read Coils", false},
    {0x02, "Read Discrete Inputs", false},
    {0x03, "Read Holding Registers", false},
    {0x04, "Read Input Registers", false},
    {0x05, "Write Single Coil", true},
    {0x06, "Write Single Register", true},
    {0x07, "Read Exception Status", false},
    {0x08, "Diagnostics", true},
    {0x0B, "Get Comm Event Counter", false},
    {0x0C, "Get Comm Event Log", false},
    {0x0F, "Write Multiple Coils", true},
    {0x10, "Write Multiple Registers", true},
    {0x11, "Report Server ID", false},
    {0x14, "Read File Record", false},
    {0x15, "Write File Record", true},
    {0x16, "Mask Write Register", true},
    {0x17, "Read/Write Multiple Registers", false},
    {0x18, "Read FIFO Queue", false},
    {0x2B, "Encapsulated Interface Transport", false},
    {0x00, nullptr, false},
}};

const FunctionInfo* find(uint8_t fc) {
  for (const auto& f : functions)
    if (f.name && f.code == fc) return &f;
  return nullptr;
}

// The standard's quantity limits per request (Modbus Application Protocol V1.1b3, 6.x).
struct QuantityRule {
  uint8_t fc;
  uint8_t quantity_at;  // in the PDU
  uint16_t max;
  uint8_t count_at;       // the byte count that must match, or 0
  uint8_t bits_per_item;  // 1 for coils, 16 for registers
};

constexpr std::array<QuantityRule, 7> quantity_rules{{
    {0x01, 3, 2000, 0, 1},
    {0x02, 3, 2000, 0, 1},
    {0x03, 3, 125, 0, 16},
    {0x04, 3, 125, 0, 16},
    {0x0F, 3, 1968, 5, 1},
    {0x10, 3, 123, 5, 16},
    {0x17, 7, 121, 9, 16},  // the write quantity; the read one is checked like FC03's
}};

uint32_t quantity_findings(const QuantityRule& rule, std::span<const uint8_t> pdu) {
  if (pdu.size() < rule.quantity_at + 2u) return finding_none;
  const unsigned quantity = be16(pdu, rule.quantity_at);
  uint32_t found = in_range(quantity, 1, rule.max) ? finding_none : finding_quantity_out_of_spec;
  if (rule.count_at && pdu.size() > rule.count_at &&
      pdu[rule.count_at] != (quantity * rule.bits_per_item + 7) / 8)
    found |= finding_byte_count_mismatch;
  return found;
}

}  // namespace

uint32_t request_spec_findings(std::span<const uint8_t> pdu) {
  if (pdu.empty()) return finding_none;
  uint32_t found = finding_none;
  for (const QuantityRule& rule : quantity_rules)
    if (rule.fc == pdu[0]) found |= quantity_findings(rule, pdu);
  if (pdu[0] == 0x17 && pdu.size() >= 5 && !in_range(be16(pdu, 3), 1, 125))
    found |= finding_quantity_out_of_spec;
  if (pdu[0] == 0x05 && pdu.size() >= 5 && be16(pdu, 3) != 0xFF00 && be16(pdu, 3) != 0x0000)
    found |= finding_value_out_of_spec;
  return found;
}

BodyLength body_length(Role role, std::span<const uint8_t> prefix) {
  if (prefix.size() < 2) return BodyLength::need_more();
  return role == Role::request ? request_length(prefix) : response_length(prefix);
}

bool is_public_function(uint8_t fc) {
  return find(fc & 0x7F) != nullptr;
}

bool may_broadcast(uint8_t fc) {
  const FunctionInfo* f = find(fc);
  return f == nullptr || f->broadcast;
}

const char* function_name(uint8_t fc) {
  const FunctionInfo* f = find(fc & 0x7F);
  return f ? f->name : nullptr;
}

const char* exception_name(uint8_t code) {
  switch (code) {
    case 0x01:
      return "Illegal Function";
    case 0x02:
      return "Illegal Data Address";
    case 0x03:
      return "Illegal Data Value";
    case 0x04:
      return "Server Device Failure";
    case 0x05:
      return "Acknowledge";
    case 0x06:
      return "Server Device Busy";
    case 0x07:
      return "Negative Acknowledge";
    case 0x08:
      return "Memory Parity Error";
    case 0x0A:
      return "Gateway Path Unavailable";
    case 0x0B:
      return "Gateway Target Device Failed to Respond";
    default:
      return nullptr;
  }
}

const char* diagnostic_name(uint16_t sub) {
  switch (sub) {
    case 0x00:
      return "Return Query Data";
    case 0x01:
      return "Restart Communications Option";
    case 0x02:
      return "Return Diagnostic Register";
    case 0x03:
      return "Change ASCII Input Delimiter";
    case 0x04:
      return "Force Listen Only Mode";
    case 0x0A:
      return "Clear Counters and Diagnostic Register";
    case 0x0B:
      return "Return Bus Message Count";
    case 0x0C:
      return "Return Bus Communication Error Count";
    case 0x0D:
      return "Return Bus Exception Error Count";
    case 0x0E:
      return "Return Server Message Count";
    case 0x0F:
      return "Return Server No Response Count";
    case 0x10:
      return "Return Server NAK Count";
    case 0x11:
      return "Return Server Busy Count";
    case 0x12:
      return "Return Bus Character Overrun Count";
    case 0x14:
      return "Clear Overrun Counter and Flag";
    default:
      return nullptr;
  }
}

}  // namespace modtap::decoder
