// What the request the bus waits on says of the bytes a framer weighs after it: where its
// answer would end by its structure, which of the answer's bytes the request predicts, and
// whether bytes are that request again (the master's retry, or an echo). Each question takes
// the bytes from a candidate start on.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>

#include "decoder/protocol/frame_sink.hpp"

namespace modtap {

class AwaitedAnswer {
 public:
  // `carries_answers`: the channel carries responses (not the master's side of a split tap).
  AwaitedAnswer(const Expectation& expected, bool carries_answers)
      : expected_(expected), carries_answers_(carries_answers) {}

  // When `bytes` start the awaited answer: how long its structure says it is, or at least one
  // byte longer than `bytes` where they end before its structure is complete.
  std::optional<uint16_t> length(std::span<const uint8_t> bytes) const;
  // Whether `bytes` begin with the awaited answer's slave and function code (its exception's
  // too): two bytes, by chance 1 time in 65,536 (awaited-header), whatever follows them.
  bool has_header(std::span<const uint8_t> bytes) const {
    return bytes.size() >= 2 && carries_answers_ && expected_.pending &&
           expected_.slave == bytes[0] && expected_.function == (bytes[1] & 0x7F);
  }
  // Whether `bytes` start the awaited answer, or do with a glitch after them.
  bool starts(std::span<const uint8_t> bytes) const;
  // Whether `bytes` begin with the awaited answer's slave, function code and what its request
  // predicts after them (at least one byte: a byte count, an echoed address).
  bool begins(std::span<const uint8_t> bytes) const;
  // What the request says of byte `pos` of the awaited answer `bytes`: that it is this byte
  // (an echo, a byte count), that it cannot be, or nothing.
  std::optional<bool> byte(std::span<const uint8_t> bytes, size_t pos) const;
  // Whether every byte of the awaited answer `bytes` from `pos` on is the one the request tells.
  bool tells_every_byte(std::span<const uint8_t> bytes, size_t pos) const;
  // Whether an awaited answer of `length` bytes may begin with the request's copy `copy` by a
  // chance a slave's answer often meets: no byte the request predicts is otherwise, and the
  // answer has at most one byte of its own before its CRC.
  bool may_begin_with_copy(std::span<const uint8_t> copy, uint16_t length) const;

  // Whether the first `size` of `bytes` are the pending request again, byte for byte: its
  // slave, its PDU and its CRC.
  bool copies_request(std::span<const uint8_t> bytes, size_t size) const;
  // The pending request's size on the wire (0 where none is pending), and whether `bytes` are
  // its first bytes, CRC included.
  size_t request_size() const {
    return expected_.pending ? 1 + expected_.request_pdu.size() + 2 : 0;  // slave, PDU, CRC
  }
  bool repeats_request(std::span<const uint8_t> bytes) const;
  // Whether a copy of the request starting at `start_ns` came before the master could have
  // timed out: the answer (an echo), not the master's retry.
  bool too_soon_for_retry(int64_t start_ns) const {
    return expected_.retry_from_ns && start_ns < expected_.retry_from_ns;
  }

 private:
  // The pending request's CRC as the wire carries it, low byte first.
  std::array<uint8_t, 2> request_crc() const;

  const Expectation& expected_;
  bool carries_answers_;
};

}  // namespace modtap
