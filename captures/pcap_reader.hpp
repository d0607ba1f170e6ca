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

 private:
  uint64_t file_offset() const;

  std::string path_;
  pcap* handle_ = nullptr;
  uint64_t packets_ = 0;
  std::vector<decoder::ChannelInfo> channels_;
};

}  // namespace modtap::captures
