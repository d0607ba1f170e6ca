// The log of `jpnevulator --read --timing-print`: a "YYYY-MM-DD HH:MM:SS.uuuuuu:" line
// (followed by the tty's name when several are read), then the bytes as hex on the next lines,
// after a byte count with --byte-count and before a text column with --ascii.
//
// jpnevulator stamps a block with the time its first read returned, after that read's bytes,
// and adds every read that follows within --timing-delta (100 ms by default) to the block. A
// block is therefore read as one read that ended at its stamp: its bytes placed back to back up
// to it, none of the silences inside it known (no latency is measured within a block). With
// --timing-delta=0 a block is one read, and that is exact. A block placed so would begin before
// the one before it ended only if it held several reads; it then follows that block, back to
// back, with the silence before it unknown too. A stamp before the one before it is the
// computer's clock set back, and stays where it says.
#pragma once

#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "captures/chunk_source.hpp"
#include "captures/line_reader.hpp"

namespace modtap::captures {

class HexlogReader final : public ChunkSource {
 public:
  // `char_time_ns` places a block's bytes before its time stamp.
  HexlogReader(const std::string& path, int64_t char_time_ns);

  bool next(Chunk& chunk) override;
  ClockQuality clock() const override { return ClockQuality::per_chunk; }
  bool absolute_time() const override { return true; }
  const std::vector<ChannelInfo>& channels() const override { return channels_; }
  std::optional<uint64_t> file_position() const override { return lines_.bytes_read(); }

  // Whether a line is a jpnevulator time stamp line (used to recognise the format).
  static bool is_header(const std::string& line);

 private:
  // The lines of one block, read ahead: its stamp says where it ends.
  struct Block {
    uint16_t channel = 0;
    int64_t stamp_ns = 0;
    std::vector<uint8_t> bytes;
    std::vector<size_t> line_ends;  // where each line's bytes end in `bytes`
    size_t next_line = 0;
    int64_t start_ns = 0;
    bool follows_unknown_silence = false;
  };
  // A block larger than this is placed in parts, each after the one before.
  static constexpr size_t max_block_bytes = 1 << 16;

  bool read_block();
  bool begin_block();
  void add_line(const std::string& line);
  void start_block(const std::string& line);
  uint16_t channel_for(const std::string& name);

  LineReader lines_;
  int64_t char_time_ns_;
  std::string line_;
  std::optional<std::string> next_header_;  // the stamp line that ended the block before
  bool block_continues_ = false;            // the block before stopped at max_block_bytes
  Block block_;
  // Each channel's last block: its stamp, and where it was placed to end.
  struct LastBlock {
    int64_t stamp_ns = std::numeric_limits<int64_t>::min();
    int64_t end_ns = std::numeric_limits<int64_t>::min();
  };
  std::vector<LastBlock> last_blocks_;
  std::vector<ChannelInfo> channels_;
  std::map<std::string, uint16_t> channel_ids_;
};

}  // namespace modtap::captures
