// The log of `jpnevulator --read --timing-print`: a "YYYY-MM-DD HH:MM:SS.uuuuuu:" line
// (followed by the tty's name when several are read), then the bytes as hex on the next lines.
#pragma once

#include <map>
#include <string>

#include "captures/chunk_source.hpp"
#include "captures/line_reader.hpp"

namespace modtap::captures {

class HexlogReader final : public ChunkSource {
 public:
  // `char_time_ns` places a block's bytes after its time stamp, which marks the first read.
  HexlogReader(const std::string& path, int64_t char_time_ns);

  bool next(Chunk& chunk) override;
  ClockQuality clock() const override { return ClockQuality::per_chunk; }
  bool absolute_time() const override { return true; }
  const std::vector<ChannelInfo>& channels() const override { return channels_; }
  std::optional<uint64_t> file_position() const override { return lines_.bytes_read(); }

  // Whether a line is a jpnevulator time stamp line (used to recognise the format).
  static bool is_header(const std::string& line);

 private:
  void start_block(const std::string& line);
  uint16_t channel_for(const std::string& name);

  LineReader lines_;
  int64_t char_time_ns_;
  std::string line_;
  std::vector<uint8_t> bytes_;
  std::vector<ChannelInfo> channels_;
  std::map<std::string, uint16_t> channel_ids_;
  bool in_block_ = false;
  uint16_t channel_ = 0;
  int64_t block_start_ns_ = 0;
  uint64_t block_bytes_ = 0;
};

}  // namespace modtap::captures
