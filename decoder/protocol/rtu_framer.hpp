// Splits a channel's byte stream into RTU frames and noise.
//
// Structure decides, timing advises: a boundary is where the function-code length rules say
// a frame ends and the CRC agrees. Gaps of t3.5 or more (beyond what the source's clock can
// blur) are marks that cut a frame which cannot complete. Every byte pushed leaves in exactly
// one Frame or Noise record, in order.
//
// The framer keeps the stream (RtuStream) and emits the records; how the bytes from a start
// read is RtuReadings' to say, on that stream, read only (rtu_readings.hpp).
#pragma once

#include <cstdint>
#include <optional>
#include <span>

#include "decoder/protocol/frame_sink.hpp"
#include "decoder/protocol/records.hpp"
#include "decoder/protocol/rtu_readings.hpp"

namespace modtap {

class RtuFramer {
 public:
  RtuFramer(uint16_t channel, const RtuFramerOptions& options, FrameSink& sink);

  void push(const Chunk& chunk);
  // Called with the current time when no bytes came: after a silence long enough to be a
  // boundary, whatever is pending is resolved.
  void flush(int64_t now_ns);
  // End of the stream: resolve everything.
  void finish();

  int64_t last_byte_ns() const { return s_.timeline.last_end_ns(); }
  // When the first byte not yet in a record began (INT64_MAX if none): what comes out later
  // may still be from then.
  int64_t held_since_ns() const;

 private:
  using Match = RtuReadings::Match;
  static constexpr uint16_t crc_size = RtuReadings::crc_size;
  static constexpr uint16_t min_adu = RtuReadings::min_adu;
  static constexpr uint8_t max_unicast_slave = RtuReadings::max_unicast_slave;
  static bool is_glitch_byte(uint8_t byte) { return RtuReadings::is_glitch_byte(byte); }

  void resolve(bool final);
  // First position >= from that starts a good frame; `decided` false if one is still open.
  uint64_t next_start(uint64_t from, bool final, bool& decided);
  Frame frame_of(uint64_t begin, uint64_t end, RoleFit fit) const;
  void emit_frame(uint64_t at, const Match& match);
  void emit_unframed(uint64_t begin, uint64_t end);
  // `glitch_after`: the byte after the piece was just taken for a turnaround's glitch, which
  // weighs against its own last byte being a second (last_edge).
  void emit_piece(uint64_t begin, uint64_t end, uint32_t findings = finding_none,
                  bool glitch_after = false);
  void emit_run_on(uint64_t begin, uint64_t end);
  PieceHeader piece_header(uint64_t at) const;
  std::optional<EdgeByte> first_edge(uint64_t begin, uint64_t end) const;
  std::optional<EdgeByte> last_edge(uint64_t begin, uint64_t end, bool glitch_after) const;
  void observe_edge(const EdgeByte& edge) const;
  void emit_damaged(uint64_t begin, uint64_t end, Damage damage, uint32_t findings);
  void emit_noise(uint64_t begin, uint64_t end, NoiseReason reason);
  void consume(uint64_t to);

  const uint8_t* at_ptr(uint64_t offset) const { return s_.at_ptr(offset); }
  std::span<const uint8_t> bytes(uint64_t begin, uint64_t end) const {
    return s_.bytes(begin, end);
  }

  uint16_t channel_;
  RtuFramerOptions options_;
  FrameSink& sink_;
  RtuStream s_;
  RtuReadings readings_;     // reads s_, never changes it
  uint64_t scanned_to_ = 0;  // positions below this are known not to start a frame
};

}  // namespace modtap
