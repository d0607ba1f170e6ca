// A classic pcap of timed chunks with a DLT_USER link type, one chunk a packet, written through
// libpcap: the bus simulator hands its traffic to tshark and to modtap's own pcap reader in a
// file written by the library other tools read with. modtap itself does not link libpcap.
#pragma once

#include <string>

#include "decoder/protocol/records.hpp"

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

  void write(const Chunk& chunk);  // t_ns: nanoseconds since the epoch

 private:
  pcap* dead_ = nullptr;
  pcap_dumper* dumper_ = nullptr;
  std::string path_;
};

}  // namespace modtap::captures
