// The value types that flow through the pipeline: chunks in, frames, noise and time-outs out.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "decoder/protocol/enum_names.hpp"
#include "decoder/protocol/findings.hpp"

namespace modtap {

// How well a source knows when each byte arrived.
enum class ClockQuality : uint8_t {
  per_byte,   // each chunk is one byte with its own exact time (logic analyzer, simulator)
  per_chunk,  // one time per read or packet; bytes inside a chunk are untimed
  none,       // no time at all (raw files); times are nominal, from the byte offset
};
template <>
struct EnumNames<ClockQuality> {
  static constexpr std::array<std::string_view, 3> names{"per-byte", "per-chunk", "none"};
};

// How late a clock per read may stamp a byte, by default (`--chunk-jitter`): an adapter holds
// bytes for its latency timer (FTDI: 16 ms), a read stamped when it ends may hold bytes from
// that long before, and a scheduler's delay comes on top.
constexpr int64_t default_read_jitter_ns = 30'000'000;

// What a channel carries: both directions (a single RS-485 probe) or one side of a split tap.
enum class ChannelRole : uint8_t { bus, master, slave };
template <>
struct EnumNames<ChannelRole> {
  static constexpr std::array<std::string_view, 3> names{"bus", "master", "slave"};
};

struct ChannelInfo {
  std::string name;
  ChannelRole role = ChannelRole::bus;
};

// Bytes exactly as a source delivered them. t_ns is when the last byte was complete.
struct Chunk {
  uint16_t channel = 0;
  int64_t t_ns = 0;
  std::span<const uint8_t> bytes;
  // Its first byte came in the read before's, so the silence before it is unknown: a frame
  // whose start a first run's clock did not see (Frame::untimed_start), read back from pcapng.
  bool continues_read = false;
  // The rest of its read comes in the next chunk at once (a modtap pcapng packet's bytes after
  // its first, which is apart to be timed): nothing is judged between the two, as the first run
  // judged the read whole.
  bool read_goes_on = false;
};

enum class Mode : uint8_t { rtu, ascii };
template <>
struct EnumNames<Mode> {
  static constexpr std::array<std::string_view, 2> names{"rtu", "ascii"};
};
struct Meaning;     // register_meaning.hpp
struct DecodedPdu;  // pdu_fields.hpp
enum class Role : uint8_t { request, response, unknown };
template <>
struct EnumNames<Role> {
  static constexpr std::array<std::string_view, 3> names{"request", "response", "unknown"};
};

// Which roles the frame's structure allows; the matcher picks between them when both do.
struct RoleFit {
  bool request = false;
  bool response = false;
};

// What happened to a frame whose check failed, where its structure tells.
enum class Damage : uint8_t {
  none,
  corrupted,  // as long as its structure says, with a wrong check: bytes changed on the way
  cut,        // the awaited response broke off before its structure's end (silence or a frame)
  collision,  // the awaited response ran on past its end: something else talked into it
};
template <>
struct EnumNames<Damage> {
  static constexpr std::array<std::string_view, 4> names{"none", "corrupted", "cut", "collision"};
};

// A Modbus ADU. The spans point into the framer's buffer and are valid during the callback.
struct Frame {
  uint64_t index = 0;
  uint16_t channel = 0;
  Mode mode = Mode::rtu;
  Role role = Role::unknown;
  RoleFit fit;
  int64_t t_ns = 0;              // start of the first byte
  int64_t end_ns = 0;            // end of the last byte
  uint64_t offset = 0;           // byte offset of the first byte in its channel's stream
  std::span<const uint8_t> raw;  // exact wire bytes (ASCII: ':' .. CRLF)
  std::span<const uint8_t> adu;  // slave .. check, binary (ASCII: decoded hex)
  bool check_ok = false;
  uint16_t expected_check = 0;  // what the CRC/LRC should have been (none for a cut frame)
  Damage damage = Damage::none;
  uint32_t findings = finding_none;
  uint8_t retries = 0;  // a request: how often it went out unanswered just before (saturates)
  // A clock per read: the frame's first byte came in the read of the byte before it, so the
  // silence before the frame is unknown (its time is placed back to back with that byte's).
  bool untimed_start = false;
  // The numbers of the reads (chunks) that held its first and last bytes, counted per channel
  // from 1 (0: not known): a response that starts in the read its request ended in has no
  // latency the clock saw.
  uint64_t start_read = 0, end_read = 0;
  std::optional<uint64_t> request;       // index of the matched request
  uint8_t request_slave = 0;             // its slave: a damaged answer's own address may be wrong
  std::optional<int64_t> latency_ns;     // end of request to start of response
  std::span<const uint8_t> request_pdu;  // the matched request's PDU, during the callback
  const Meaning* meaning = nullptr;      // the device model's reading, when one is applied
  const DecodedPdu* decoded = nullptr;   // its fields, when a stage before the sinks decoded them

  uint8_t slave() const { return adu.empty() ? 0 : adu[0]; }
  // The slave the frame is to or from: a response's request tells, where the frame's own
  // address byte may be damaged.
  uint8_t device() const { return request ? request_slave : slave(); }
  uint8_t function() const { return adu.size() < 2 ? 0 : adu[1]; }
  bool is_exception() const { return adu.size() >= 3 && (function() & 0x80) != 0; }
  size_t check_size() const { return mode == Mode::rtu ? 2 : 1; }
  // The PDU: function code and data, without slave address and check. A cut frame has no
  // check: all its bytes after the address are PDU.
  std::span<const uint8_t> pdu() const {
    const size_t check = damage == Damage::cut ? 0 : check_size();
    return adu.size() < 1 + check ? adu.subspan(0, 0) : adu.subspan(1, adu.size() - 1 - check);
  }
  uint16_t wire_check() const;
};

enum class NoiseReason : uint8_t {
  junk,       // bytes that start no frame
  truncated,  // a frame header whose frame never completed
  glitch,     // a lone 0x00/0xFF beside a frame, typical of an RS-485 turnaround
  overlong,   // longer than the largest ADU without an end
  bad_hex,    // an ASCII frame with characters that are not hex pairs
};
template <>
struct EnumNames<NoiseReason> {
  static constexpr std::array<std::string_view, 5> names{"junk", "truncated", "glitch", "overlong",
                                                         "bad-hex"};
};

struct Noise {
  uint64_t index = 0;
  uint16_t channel = 0;
  Mode mode = Mode::rtu;
  int64_t t_ns = 0;
  int64_t end_ns = 0;
  uint64_t offset = 0;
  std::span<const uint8_t> raw;
  NoiseReason reason = NoiseReason::junk;
  bool untimed_start = false;  // as a frame's
  uint32_t findings = finding_none;
  std::optional<uint64_t> request;  // the request whose answer was awaited when it came
  uint8_t request_slave = 0;        // that request's slave
  // It came in the answer's time: the slave's answer, garbled past reading. The request does
  // not time out, unless a readable answer follows.
  bool damaged_answer = false;
};

// Why a request's wait ended without a response. end_of_capture is no time-out: the input
// ended while the request still waited, so it is only unanswered.
enum class TimeoutReason : uint8_t { next_request, silence, end_of_capture };
template <>
struct EnumNames<TimeoutReason> {
  static constexpr std::array<std::string_view, 3> names{"next-request", "silence",
                                                         "end-of-capture"};
};

struct Timeout {
  uint64_t index = 0;
  uint64_t request = 0;
  uint16_t channel = 0;
  uint8_t slave = 0;
  uint8_t function = 0;
  int64_t t_ns = 0;       // when the time-out was known
  int64_t waited_ns = 0;  // from the end of the request to then
  TimeoutReason reason = TimeoutReason::silence;

  bool timed_out() const { return reason != TimeoutReason::end_of_capture; }
};

}  // namespace modtap
