// Files of timed chunks, as other sniffers write them: pcap with a DLT_USER link type (one
// chunk a packet), and jpnevulator's timed hex log. Used by the bus simulator to hand its
// traffic to modtap's own readers and to tshark.
#pragma once

#include <string>

#include <fmt/format.h>

#include "captures/output_file.hpp"
#include "decoder/records.hpp"

struct pcap;
struct pcap_dumper;

namespace modtap::captures {

class PcapChunkWriter {
 public:
  // Throws CaptureError when the file cannot be created, WriteError when it cannot be written.
  PcapChunkWriter(const std::string& path, int dlt);
  ~PcapChunkWriter();
  PcapChunkWriter(const PcapChunkWriter&) = delete;
  PcapChunkWriter& operator=(const PcapChunkWriter&) = delete;

  void write(const decoder::Chunk& chunk);  // t_ns: nanoseconds since the epoch

 private:
  pcap* dead_ = nullptr;
  pcap_dumper* dumper_ = nullptr;
  std::string path_;
};

class HexlogWriter {
 public:
  // `char_time_ns` lets the stamp name the block's first byte, as jpnevulator's read does.
  HexlogWriter(const std::string& path, int64_t char_time_ns);
  void write(const decoder::Chunk& chunk, const std::string& tty = {});
  void close() { file_.close(); }
  uint64_t bytes_written() const { return file_.bytes_written(); }

 private:
  OutputFile file_;
  fmt::memory_buffer line_;
  int64_t char_time_ns_;
};

}  // namespace modtap::captures
