// --save-raw: every chunk exactly as it was read, with its time, so that a capture can be read
// again later with other settings. FILE.pcapng (DLT_USER0, one packet a read, one interface a
// port) or a jpnevulator-style timed hex log for any other name (which keeps the two ports of
// a split tap apart when read back; libpcap does not say which interface a packet came on).
// With -b, a ring of such files, turned only between frames.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "captures/file_ring.hpp"
#include "captures/hexlog_writer.hpp"
#include "captures/pcapng_writer.hpp"
#include "decoder/protocol/records.hpp"

namespace modtap::captures {

class RawRecorder {
 public:
  // Throws WriteError when the file cannot be created or written.
  RawRecorder(const std::string& path, std::vector<ChannelInfo> channels,
              const RingLimits& limits = {});
  // `between_frames`: the analyzer holds no byte of an unfinished frame, so a new file of the
  // ring may begin here. On a bus that never pauses, one does after twice the limits anyway.
  void write(const Chunk& chunk, bool between_frames = true);
  void flush();
  void close();

 private:
  void begin_file(const std::string& path);
  void close_file();
  uint64_t bytes_in_file() const;

  std::vector<ChannelInfo> channels_;
  bool as_pcapng_;  // else a timed hex log
  FileRing ring_;
  std::unique_ptr<PcapngWriter> pcapng_;
  std::vector<uint32_t> interfaces_;
  std::unique_ptr<HexlogWriter> hexlog_;
};

}  // namespace modtap::captures
