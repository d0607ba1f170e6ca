// A minimal pcapng writer: one section, interfaces with a name and nanosecond time stamps,
// enhanced packet blocks with direction flags and a comment. libpcap reads pcapng but writes
// only pcap, which has no interfaces, no direction and no comments; see docs/pcapng.md.
#pragma once

#include <cstdint>
#include <cstdio>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "captures/output_file.hpp"

namespace modtap::captures {

enum class PacketDirection : uint8_t { unknown = 0, inbound = 1, outbound = 2 };

class PcapngWriter {
 public:
  // Throws WriteError when the file cannot be created or written. "-" is standard output.
  // `live`: a reader follows the file as it grows (a FIFO, a pipe), so the header and every
  // packet are flushed at once.
  explicit PcapngWriter(const std::string& path, bool live = false);
  PcapngWriter(const PcapngWriter&) = delete;
  PcapngWriter& operator=(const PcapngWriter&) = delete;

  // Returns the interface id for the packets that follow.
  uint32_t add_interface(int link_type, std::string_view name, std::string_view comment = {});
  void write_packet(uint32_t interface, int64_t t_ns, std::span<const uint8_t> data,
                    PacketDirection direction, std::string_view comment);
  void flush();
  uint64_t bytes_written() const { return file_.bytes_written(); }
  // Writes out what is buffered and closes the file, reporting any failure.
  void close();

 private:
  void write_section_header();
  class Block;  // one block being built
  void write_block(Block& block);

  OutputFile file_;
  std::vector<uint8_t> block_;  // the block being built, kept to reuse its memory
  bool live_ = false;
  uint32_t interfaces_ = 0;
};

}  // namespace modtap::captures
