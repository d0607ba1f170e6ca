// Telling a line's settings from its traffic, without transmitting: run the analyzer under each
// candidate format and keep the one under which the most bytes form frames with a good check.
// Also the measure behind the "is the baud rate right?" hint.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "decoder/protocol/analyzer.hpp"

namespace modtap {

// What says a line's settings are not the ones modtap reads it with, one place for the hint
// after a run and the settings-look-wrong problem: too little of a sizeable stream forms good
// frames, or most timed answers would begin before their request ended (the line is faster).
inline bool mostly_junk(uint64_t bytes, uint64_t good_frame_bytes) {
  return bytes >= 64 && 2 * good_frame_bytes < bytes;
}
inline bool mostly_early(uint64_t timed_answers, uint64_t early_answers) {
  return timed_answers >= 10 && 2 * early_answers > timed_answers;
}

// Counts how much of the traffic made sense, and passes every record on (or nowhere).
class LineHealth final : public RecordSink {
 public:
  explicit LineHealth(RecordSink* next = nullptr) : next_(next) {}
  void on_frame(const Frame& frame) override;
  void on_noise(const Noise& noise) override;
  void on_timeout(const Timeout& timeout) override;

  uint64_t bytes = 0;             // every byte in a frame or noise record
  uint64_t good_frame_bytes = 0;  // bytes of frames whose CRC/LRC checks
  uint64_t frames = 0;
  uint64_t good_frames = 0;
  double good_share() const { return bytes ? static_cast<double>(good_frame_bytes) / bytes : 0; }
  // Too little of a sizeable stream made sense: the settings are probably wrong.
  bool looks_wrong() const { return mostly_junk(bytes, good_frame_bytes); }

 private:
  RecordSink* next_;
};

// For sources timed per read: does a read bring more bytes than the baud could carry since the
// previous one? A line faster than its --baud shows it read after read.
class ChunkPace {
 public:
  explicit ChunkPace(const SerialFormat& format) : char_ns_(format.char_time_ns()) {}
  void add(const Chunk& chunk);
  bool too_fast() const { return reads >= 10 && fast_reads * 2 > reads; }

  uint64_t reads = 0;
  uint64_t fast_reads = 0;

 private:
  int64_t char_ns_;
  std::vector<int64_t> last_ns_;  // per channel
};

struct FormatTrial {
  SerialFormat format;
  uint64_t bytes = 0;
  uint64_t good_frame_bytes = 0;
  uint64_t frames = 0;
  uint64_t good_frames = 0;
  uint64_t parity_errors = 0;  // where the source sees parity bits (a logic analyzer)

  // A clean, sizeable read: evidence enough to stop trying (the common settings come first).
  bool convincing() const {
    return good_frames >= 4 && good_frame_bytes * 10 >= bytes * 9 && parity_errors == 0;
  }
};

// Settings to try, the common ones first: a fixed value narrows its dimension to itself.
std::vector<SerialFormat> candidate_formats(std::optional<uint32_t> baud,
                                            std::optional<Parity> parity, uint8_t data_bits,
                                            uint8_t stop_bits);

// Feeds chunks from `next` (false at the end) through an analyzer with `format`, at most
// `byte_budget` bytes, and scores the result.
FormatTrial try_format(const AnalyzerOptions& options, const std::vector<ChannelInfo>& channels,
                       const std::function<bool(Chunk&)>& next, uint64_t byte_budget);

// The trial with the most bytes in good frames, then the fewest parity errors; the earlier one
// on a tie.
const FormatTrial& best_trial(const std::vector<FormatTrial>& trials);

// "19200 8E1: 30 of 30 frames good, 100% of 119 bytes"
std::string describe(const FormatTrial& trial);
std::string describe(const SerialFormat& format);

}  // namespace modtap
