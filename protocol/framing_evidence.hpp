// The evidence the RTU framer weighs at a frame's start, one row each: what it is and why it
// decides. A reading (request or response) whose length rules and CRC agree is kept unless a
// row below says otherwise; `--explain` prints the rows that decided a record.
#pragma once

#include <array>
#include <cstdint>
#include <string_view>

#include "protocol/records.hpp"

namespace modtap {

enum class Evidence : uint8_t {
  length_and_crc,
  no_good_end,
  more_bytes_needed,
  good_frame_before_silence,
  broke_off_at_silence,
  answer_read_as_request,
  request_inside_awaited_answer,
  retry_and_glitch,
  retry_ending_in_zero,
  answer_copying_request,
  answer_cut_before_request,
  swallows_known_frame,
  swallows_exchange,
};

struct EvidenceInfo {
  std::string_view name;
  std::string_view why;
};

inline constexpr std::array<EvidenceInfo, 13> evidence_table{{
    {"length-and-crc", "its function code's length rules and its CRC agree on where it ends"},
    {"no-good-end",
     "neither its function code's length rules nor a CRC search give it an end where its CRC "
     "holds"},
    {"more-bytes-needed", "its length rules need bytes that have not come yet"},
    {"good-frame-before-silence",
     "a silence falls inside it, and the bytes before the silence are a frame with a good CRC "
     "of their own (a 0x00 after a frame keeps a CRC good)"},
    {"broke-off-at-silence",
     "a silence falls inside it and a good frame starts right after it: it broke off there"},
    {"answer-read-as-request",
     "these are the first bytes after the request, beginning as the awaited answer (or a 0xFF "
     "glitch and that answer), read as a request the standard does not allow, too soon for the "
     "master's next one"},
    {"request-inside-awaited-answer",
     "a request inside the span the awaited answer's structure claims, with no answer of its "
     "own after it: a collision's junk whose CRC held by chance"},
    {"retry-and-glitch",
     "on a bus of 0x00 glitches, a copy of the pending request and a glitch read as one byte "
     "more, late enough for the master's retry"},
    {"retry-ending-in-zero",
     "the pending request again, whose CRC ends in 0x00, holds an answer one byte shorter that "
     "its request did not ask for"},
    {"answer-copying-request",
     "a copy of the pending request too soon for a retry, where the awaited answer is longer: "
     "that answer, cut or talked over"},
    {"answer-cut-before-request",
     "the awaited answer cut a byte short, whose missing CRC byte the next request's address "
     "repeats, with that request right behind it"},
    {"swallows-known-frame",
     "a reserved address or an answer nobody awaits would swallow a frame whose length rules "
     "and CRC agree"},
    {"swallows-exchange",
     "its CRC holds by chance across a whole exchange: a request and its answer inside it, junk "
     "after it"},
}};

inline const EvidenceInfo& evidence_info(Evidence e) {
  return evidence_table[static_cast<size_t>(e)];
}

// What became of one reading of the bytes at a frame's start.
enum class ReadingOutcome : uint8_t { kept, refused, waiting, other_reading, no_frame };
template <>
struct EnumNames<ReadingOutcome> {
  static constexpr std::array<std::string_view, 5> names{
      "kept", "refused", "waiting", "gave way to the other reading", "no frame"};
};

struct FramingStep {
  uint16_t channel = 0;
  uint64_t offset = 0;  // where the reading starts
  Role role = Role::request;
  uint16_t length = 0;  // the frame it found, 0 if none
  ReadingOutcome outcome = ReadingOutcome::no_frame;
  Evidence why = Evidence::no_good_end;
};

// Told each reading the framer weighs at the start of what it emits next (--explain).
class FramingObserver {
 public:
  virtual ~FramingObserver() = default;
  // The framer weighs the bytes at `offset` (again, once more of them came).
  virtual void on_start(uint16_t channel, uint64_t offset) = 0;
  virtual void on_reading(const FramingStep& step) = 0;
};

}  // namespace modtap
