// What every capture reader offers: timed chunks of serial bytes, exactly as recorded.
#pragma once

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "decoder/protocol/records.hpp"

namespace modtap::captures {

// A capture that cannot be read: the message names the file and the offset or line.
class CaptureError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class ChunkSource {
 public:
  virtual ~ChunkSource() = default;
  // The next chunk, valid until the next call; false at the end. Throws CaptureError.
  virtual bool next(Chunk& chunk) = 0;
  virtual ClockQuality clock() const = 0;
  // True when t_ns counts from the Unix epoch, false when from the start of the capture.
  virtual bool absolute_time() const = 0;
  virtual const std::vector<ChannelInfo>& channels() const = 0;
  // Characters whose parity bit was wrong so far, where the source sees parity bits at all
  // (a logic analyzer does; a serial port or a file of bytes does not).
  virtual uint64_t parity_errors() const { return 0; }
  // How many bytes of its file the reader has taken so far, where that tells how far it is
  // (a progress bar's numerator); nothing where the file is not read straight through.
  virtual std::optional<uint64_t> file_position() const { return std::nullopt; }
};

}  // namespace modtap::captures
