// pcapng files, read block by block. libpcap 1.10 gives neither a packet's interface nor its
// comment, so through it a two-channel file reads as one channel and modtap's own files lose
// the timing they were written with. Classic pcap has a reader of its own (pcap_reader).
#pragma once

#include <cstdint>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "captures/chunk_source.hpp"

namespace modtap::captures {

class PcapngReader final : public ChunkSource {
 public:
  // `char_time_ns` places the first byte of a packet modtap wrote (see pcapng_sink.hpp).
  PcapngReader(const std::string& path, int64_t char_time_ns);

  bool next(Chunk& chunk) override;
  // What the file says of its writer's clock (modtap's own), else one time per packet.
  ClockQuality clock() const override { return clock_; }
  bool absolute_time() const override { return true; }
  const std::vector<ChannelInfo>& channels() const override { return channels_; }
  std::optional<uint64_t> file_position() const override { return position_; }

  // The largest block read; beyond it a length is taken to lie, not allocated.
  static constexpr uint32_t max_block = 16 << 20;

 private:
  struct Interface {
    int link_type = 0;
    uint64_t ticks_per_second = 1'000'000;  // if_tsresol; microseconds unless it says
    uint16_t channel = 0;
    bool modtap = false;  // written by modtap: stamps mark a packet's first byte
    int64_t char_ns = 0;  // a character's time, as modtap wrote it (0: not said)
  };
  bool read_block(uint32_t& type);       // its body in body_
  size_t read(void* into, size_t size);  // counts what it read in position_
  bool describes(uint32_t type);
  void interface_description();
  bool packet(uint32_t type, Chunk& chunk);
  uint16_t u16(size_t at) const;  // of body_, in the section's byte order
  uint32_t u32(size_t at) const;
  template <typename Visit>
  void options(size_t at, Visit visit) const;
  [[noreturn]] void fail(const std::string& what) const;

  std::string path_;
  int64_t char_time_ns_;
  std::unique_ptr<FILE, int (*)(FILE*)> file_;
  uint64_t offset_ = 0;                // of the block being read
  uint64_t position_ = 0;              // bytes read so far
  std::optional<uint32_t> held_type_;  // a packet block read ahead, in body_
  bool swapped_ = false;               // the section's byte order is not this machine's
  bool have_section_ = false;
  std::vector<uint8_t> body_;  // the current block's body, reused
  std::vector<Interface> interfaces_;
  std::vector<ChannelInfo> channels_;
  std::vector<uint8_t> bytes_;  // the chunk's bytes
  ClockQuality clock_ = ClockQuality::per_chunk;
  // A packet modtap wrote goes out as its first byte at that byte's end, then the rest at the
  // record's end (per-byte clocks: each byte alone, spread evenly up to the end).
  size_t rest_at_ = 0;
  int64_t first_end_ns_ = 0;
  int64_t rest_end_ns_ = 0;
  uint16_t rest_channel_ = 0;
};

}  // namespace modtap::captures
