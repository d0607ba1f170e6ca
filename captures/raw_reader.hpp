// Bare bytes with no timing at all: framing goes by content alone.
#pragma once

#include <cstdio>
#include <memory>
#include <string>

#include "captures/chunk_source.hpp"

namespace modtap::captures {

class RawReader final : public ChunkSource {
 public:
  explicit RawReader(const std::string& path);

  bool next(Chunk& chunk) override;
  ClockQuality clock() const override { return ClockQuality::none; }
  bool absolute_time() const override { return false; }
  const std::vector<ChannelInfo>& channels() const override { return channels_; }
  std::optional<uint64_t> file_position() const override { return offset_; }

 private:
  std::string path_;
  std::unique_ptr<FILE, int (*)(FILE*)> file_;  // read with read(2), never through stdio
  std::vector<uint8_t> block_;
  uint64_t offset_ = 0;
  std::vector<ChannelInfo> channels_;
};

}  // namespace modtap::captures
