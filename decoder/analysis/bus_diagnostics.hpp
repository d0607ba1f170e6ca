// Findings that one frame cannot show but the bus's history can: a request that crowds the
// frame before it, a response that comes after its request timed out, the same exception again
// and again, a slave that went silent and came back. A stage right after the analyzer: it adds
// these findings to the frames and hands every record on, so every output shows them.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include "decoder/analysis/silence_run.hpp"
#include "decoder/protocol/record_sink.hpp"
#include "decoder/protocol/serial_format.hpp"

namespace modtap {

class BusDiagnostics final : public RecordSink {
 public:
  static constexpr uint64_t storm_exceptions = 5;  // the same exception in a row that is a storm
  // A slave's usual poll interval is the median of its last `poll_history` intervals, known
  // once `poll_history_known` are seen; a request off it by half or more is poll-jitter.
  static constexpr size_t poll_history = 16, poll_history_known = 8;
  // `read_jitter_ns`: how late a clock per read may stamp a request; below it, such a clock
  // cannot tell a master's jitter from its own.
  BusDiagnostics(SerialFormat format, ClockQuality clock, RecordSink& next,
                 int64_t read_jitter_ns = default_read_jitter_ns);

  void on_frame(const Frame& frame) override;
  void on_noise(const Noise& noise) override;
  void on_timeout(const Timeout& timeout) override;

 private:
  struct SlaveHistory {
    SilenceRun silence;
    std::optional<uint8_t> timed_out_function;  // its last request timed out, none since
    uint8_t exception = 0;  // the exception of its answers in a row, and how many
    uint8_t exception_function = 0;
    uint64_t exceptions_in_a_row = 0;
    std::optional<int64_t> last_poll_ns;            // the start of its last request (not a retry)
    std::array<int64_t, poll_history> intervals{};  // the last ones, in a ring
    std::array<int64_t, poll_history> sorted{};     // the same in order, for their median
    size_t intervals_seen = 0;
  };

  uint32_t diagnose(const Frame& frame);
  uint32_t answered(const Frame& frame, SlaveHistory& slave);
  uint32_t polled(const Frame& frame, SlaveHistory& slave);
  static uint32_t back_from_silence(SlaveHistory& slave);
  static void remember_interval(SlaveHistory& slave, int64_t interval);
  static size_t count_before(const std::array<int64_t, poll_history>& sorted, size_t n,
                             int64_t value, bool after_equals);

  int64_t t35_ns_;
  bool sees_gaps_;  // only a per-byte clock times the silence between frames truly
  std::optional<int64_t> jitter_floor_ns_;  // none: the source has no clock to time polls by
  RecordSink& next_;
  std::array<SlaveHistory, 256> slaves_{};
  std::vector<std::optional<int64_t>> last_end_ns_;  // per channel
};

}  // namespace modtap
