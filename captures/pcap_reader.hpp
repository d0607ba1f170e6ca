// pcap and pcapng files through libpcap, link types DLT_USER0..15: each packet is a timed chunk
// of serial bytes, which may hold a whole frame, part of one, or several.
#pragma once

#include <string>

#include "captures/chunk_source.hpp"

struct pcap;

namespace modtap::captures {

class PcapReader final : public ChunkSource {
 public:
  explicit PcapReader(const std::string& path);
  ~PcapReader() override;

  bool next(decoder::Chunk& chunk) override;
  decoder::ClockQuality clock() const override { return decoder::ClockQuality::per_chunk; }
  bool absolute_time() const override { return true; }
  const std::vector<decoder::ChannelInfo>& channels() const override { return channels_; }
  std::optional<uint64_t> file_position() const override { return offset_; }

 private:
  // Where the next record starts, counted rather than asked of the file: a pipe cannot say.
  static constexpr uint64_t file_header_size = 24, record_header_size = 16;
  uint64_t offset_ = file_header_size;

  std::string path_;
  pcap* handle_ = nullptr;
  uint64_t packets_ = 0;
  std::vector<decoder::ChannelInfo> channels_;
};

}  // namespace modtap::captures
