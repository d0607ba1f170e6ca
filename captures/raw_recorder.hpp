// --save-raw: every chunk exactly as it was read, with its time, so that a capture can be read
// again later with other settings. FILE.pcapng (DLT_USER0, one packet a read, one interface a
// port) or a jpnevulator-style timed hex log for any other name (which keeps the two ports of
// a split tap apart when read back; libpcap does not say which interface a packet came on).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "captures/chunk_writers.hpp"
#include "captures/pcapng_writer.hpp"
#include "decoder/records.hpp"

namespace modtap::captures {

class RawRecorder {
 public:
  // Throws WriteError when the file cannot be created or written.
  RawRecorder(const std::string& path, std::vector<decoder::ChannelInfo> channels,
              int64_t char_time_ns);
  void write(const decoder::Chunk& chunk);
  void flush();
  void close();

 private:
  std::vector<decoder::ChannelInfo> channels_;
  std::unique_ptr<PcapngWriter> pcapng_;
  std::vector<uint32_t> interfaces_;
  std::unique_ptr<HexlogWriter> hexlog_;
};

}  // namespace modtap::captures
