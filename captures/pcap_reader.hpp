// Classic pcap files, link types DLT_USER0..15: each packet is a timed chunk of serial bytes,
// which may hold a whole frame, part of one, or several.
//
// Read here rather than through libpcap: pcap_next_ex made two locked freads a packet, 440
// instructions, as many as framing the frame it carries; a record read from a 64 KiB buffer
// costs about 100 (docs/performance.md). The format is fixed: a 24-byte file header,
// then a 16-byte header and the data for each packet.
#pragma once

#include <cstdint>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "captures/chunk_source.hpp"

namespace modtap::captures {

class PcapReader final : public ChunkSource {
 public:
  explicit PcapReader(const std::string& path);

  bool next(Chunk& chunk) override;
  // A time a packet, the packet holding several bytes; or, where the packets hold one byte each
  // stamped apart (a sniffer that stamps every byte), a time a byte.
  ClockQuality clock() const override { return clock_; }
  bool absolute_time() const override { return true; }
  const std::vector<ChannelInfo>& channels() const override { return channels_; }
  std::optional<uint64_t> file_position() const override { return offset_; }

  // The largest packet read, as libpcap's limit; beyond it a length is taken to lie.
  static constexpr uint32_t max_packet = 262'144;

 private:
  static constexpr uint64_t file_header_size = 24, record_header_size = 16;
  // At least `n` bytes buffered from `at_`, reading more as needed; fewer only at the end.
  size_t fill(size_t n);
  uint32_t u32(size_t at) const;  // of the buffer, in the file's byte order
  ClockQuality clock_of_first_packets() const;
  [[noreturn]] void fail(uint64_t offset, const std::string& what) const;
  [[noreturn]] void fail_in_record(const std::string& what) const;  // at the record being read

  std::string path_;
  std::unique_ptr<FILE, int (*)(FILE*)> file_;  // read with read(2), never through stdio
  std::vector<uint8_t> buffer_;
  size_t at_ = 0, end_ = 0;      // the unread bytes in buffer_
  bool swapped_ = false;         // the file's byte order is not this machine's
  uint64_t fraction_ns_ = 1000;  // nanoseconds in a unit of the time's fraction
  // Where the next record starts, counted rather than asked of the file: a pipe cannot say.
  uint64_t offset_ = file_header_size;
  uint64_t packets_ = 0;
  ClockQuality clock_ = ClockQuality::per_chunk;
  std::vector<ChannelInfo> channels_;
};

}  // namespace modtap::captures
