// Every finding modtap reports, named once, as Wireshark's ei array names expert infos: the
// frame's own (what the framer and matcher see) and the device model's (its rules). Text,
// JSON, pcapng comments, statistics and the docs take their names and titles from here.
#pragma once

#include <cstdint>
#include <span>
#include <string_view>

#include "decoder/protocol/enum_names.hpp"

namespace modtap {

// A record's findings (a frame's, or noise's), a bit set so records stay plain values. Bit i is
// entry i of finding_registry(), which is also the order they are shown in.
enum Finding : uint32_t {
  finding_none = 0,
  finding_bad_check = 1u << 0,             // CRC or LRC wrong
  finding_broadcast = 1u << 1,             // slave 0: no response expected
  finding_illegal_broadcast = 1u << 2,     // a read sent to slave 0
  finding_unsolicited = 1u << 3,           // a response with no pending request
  finding_length_mismatch = 1u << 4,       // response content does not fit its request
  finding_echo_mismatch = 1u << 5,         // an echo response differs from its request
  finding_fast_turnaround = 1u << 6,       // the slave answered before t3.5 of silence
  finding_retry = 1u << 7,                 // the request that just went unanswered, sent again
  finding_quantity_out_of_spec = 1u << 8,  // a quantity of 0 or over the standard's limit
  finding_byte_count_mismatch = 1u << 9,   // a byte count that disagrees with its quantity
  finding_value_out_of_spec = 1u << 10,    // FC05 not FF00H/0000H, FC08 data its sub-function bars
  finding_ambiguous_echo = 1u << 11,       // an echo taken for the response that may be a retry
  // What the bus's history shows (decoder/analysis/bus_diagnostics):
  finding_short_gap = 1u << 12,        // a request less than t3.5 after the frame before it
  finding_late_response = 1u << 13,    // the response to a request that already timed out
  finding_exception_storm = 1u << 14,  // the same exception from a slave, again and again
  finding_answers_again = 1u << 15,    // a slave's first answer after time-outs in a row
  finding_poll_jitter = 1u << 16,      // a request far from the slave's usual poll interval
  // What the framer's clock and the matcher see:
  finding_gap_in_frame = 1u << 17,           // a silence over t1.5 between two bytes of one frame
  finding_garbage_after_request = 1u << 18,  // no answer, where a request awaits its answer
  finding_ambiguous_end = 1u << 19,  // a damaged frame whose last byte may be a glitch, or not
  // An answer to a request another master's request cut in on, after that exchange: its
  // latency is its request's, and holds the other exchange.
  finding_after_other_master = 1u << 20,
};
inline constexpr size_t frame_finding_count = 21;
// Time-outs in a row after which a slave has gone silent: its next answer, garbled or not, is
// answers-again, and the statistics list the silence as an outage.
inline constexpr uint64_t silent_after_timeouts = 3;
// A response whose content is not what its request asked for.
inline constexpr uint32_t response_misfit = finding_length_mismatch | finding_echo_mismatch;

// What a device model's rules say of a frame; entry frame_finding_count + kind of the registry.
enum class RuleKind : uint8_t {
  reserved_write,   // a write to a reserved ("do not write") register
  read_only_write,  // a write to a register the device only reports
  write_only_read,  // a read of a write-only register or alias
  closed_group,     // an access to a parameter group the device keeps to itself
  too_many_words,   // more registers in one request than the model allows in this mode
  crosses_group,    // a multi-register access that spans two parameter groups
  out_of_range,     // a value outside the register's min/max
  not_in_enum,      // a value the register's named values do not include
  station_out_of_range,
  unmapped_register,  // an address in none of the model's tables
  too_many_retries,   // a request sent again more often than the model's masters do
  early_response,     // an answer sooner after its request than the manual says the device answers
  reserved_address,   // 248-255, which Modbus reserves, to a slave whose model does not allow it
  exception,          // an exception response, explained with the model's meaning
  identified,
  device_fault,  // the device reports a fault in its fault register (a drive's trip: OL2)
};
inline constexpr size_t rule_kind_count = 16;

// How much a finding matters to someone looking for a fault (Wireshark's expert severities).
enum class Severity : uint8_t { note, warning, error };
template <>
struct EnumNames<Severity> {
  static constexpr std::array<std::string_view, 3> names{"note", "warning", "error"};
};

struct FindingInfo {
  std::string_view name;  // as text, JSON, pcapng comments and filters spell it
  Severity severity;
  std::string_view title;  // one line for people: the docs, the statistics, Wireshark
};

// Frame findings in bit order, then the model's in RuleKind order.
std::span<const FindingInfo> finding_registry();
std::span<const FindingInfo> frame_findings();

constexpr size_t finding_slot(RuleKind kind) {
  return frame_finding_count + static_cast<size_t>(kind);
}
const FindingInfo& finding_info(RuleKind kind);
std::string_view to_string(RuleKind kind);  // its registry name

// Calls `visit(slot)` for each bit set in `bits`, in the registry's order.
template <typename Visit>
void for_each_frame_finding(uint32_t bits, Visit&& visit) {
  for (size_t slot = 0; bits != 0; ++slot, bits >>= 1)
    if (bits & 1) visit(slot);
}

}  // namespace modtap
