// Splits a channel's byte stream into Modbus ASCII frames (':' hex-pairs LRC CR LF) and noise.
#pragma once

#include <cstdint>
#include <vector>

#include "decoder/protocol/frame_sink.hpp"
#include "decoder/protocol/records.hpp"
#include "decoder/protocol/serial_format.hpp"

namespace modtap {

struct AsciiFramerOptions {
  SerialFormat format{9600, 7, Parity::even, 1};
  ClockQuality clock = ClockQuality::per_chunk;
  ChannelRole role = ChannelRole::bus;
  // Modbus over Serial Line 2.5.2.1: the inter-character time-out is 1 s by default.
  int64_t char_timeout_ns = 1'000'000'000;
};

class AsciiFramer {
 public:
  AsciiFramer(uint16_t channel, const AsciiFramerOptions& options, FrameSink& sink);

  void push(const Chunk& chunk);
  void flush(int64_t now_ns);
  void finish();

  int64_t last_byte_ns() const { return last_end_ns_; }
  // When the oldest record not yet handed on began (INT64_MAX if none).
  int64_t held_since_ns() const {
    if (!held_.raw.empty()) return held_.t_ns;
    return pending_.empty() ? INT64_MAX : pending_start_ns_;
  }

  // ':' + 2 * 255 hex characters + CR LF (Modbus over Serial Line 2.5.2.1: 513 characters).
  static constexpr size_t max_frame_chars = 513;

 private:
  void on_byte(uint8_t byte, int64_t end_ns, bool starts_read);
  void emit_pending(NoiseReason reason);
  void emit_frame();
  void emit_noise(NoiseReason reason);
  void hold_noise(NoiseReason reason);
  void release_held();
  void reset(uint64_t offset, int64_t start_ns, bool starts_read);

  uint16_t channel_;
  AsciiFramerOptions options_;
  FrameSink& sink_;
  int64_t char_ns_;

  std::vector<uint8_t> pending_;  // bytes of the record being built
  std::vector<uint8_t> decoded_;
  bool in_frame_ = false;
  uint64_t pending_offset_ = 0;
  int64_t pending_start_ns_ = 0;
  bool pending_untimed_start_ = false;  // Frame::untimed_start
  uint64_t pending_start_read_ = 0;     // Frame::start_read
  uint64_t reads_ = 0;                  // chunks pushed, those that continue a read aside
  int64_t pending_end_ns_ = 0;
  // Junk and frames that never ended, held so that the next such piece joins them: a run of
  // stray ':' (each the start of a frame) is one record, as a run of junk is in RTU.
  struct HeldNoise {
    std::vector<uint8_t> raw;
    uint64_t offset = 0;
    int64_t t_ns = 0, end_ns = 0;
    bool untimed_start = false;
    NoiseReason reason = NoiseReason::junk;
  } held_;
  uint64_t offset_ = 0;  // stream offset of the next byte
  int64_t last_end_ns_ = 0;
};

}  // namespace modtap
