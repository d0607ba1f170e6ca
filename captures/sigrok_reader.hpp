// Logic-analyzer captures (.sr): sigrok-cli's UART decoder turns each probed line into bytes
// with exact sample positions, which become one-byte chunks merged in time order.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "captures/chunk_source.hpp"
#include "decoder/protocol/serial_format.hpp"

namespace modtap::captures {

struct SigrokLine {
  std::string role;  // "tx" (the master's transmit line), "rx" (its receive line) or "bus"
  std::string name;  // the channel's name in the capture
};

struct SigrokOptions {
  std::vector<SigrokLine> lines;  // empty: one "bus" line on the capture's first channel
  bool invert = false;
  SerialFormat format;
  std::string program = "sigrok-cli";
};

// What `sigrok-cli --show` says of a capture. Throws CaptureError naming `path` when it
// gives no sample rate.
struct SigrokShape {
  uint64_t samplerate = 0;
  std::vector<std::string> channels;
};
SigrokShape parse_sigrok_show(const std::string& text, const std::string& path);
// The logic channels of a capture, by name, as `sigrok-cli --show` lists them.
std::vector<std::string> sigrok_channel_names(const std::string& path,
                                              const std::string& program = "sigrok-cli");

// One line of the UART decoder's output: where the data bits start, and the byte.
struct SigrokByte {
  uint64_t sample = 0;
  uint8_t value = 0;
};
std::optional<SigrokByte> parse_sigrok_byte(const char* line);

// Parses "tx=NAME,rx=NAME" or "bus=NAME"; throws std::invalid_argument.
std::vector<SigrokLine> parse_sigrok_channels(const std::string& spec);

class SigrokReader final : public ChunkSource {
 public:
  SigrokReader(const std::string& path, const SigrokOptions& options);
  ~SigrokReader() override;

  bool next(Chunk& chunk) override;
  ClockQuality clock() const override { return ClockQuality::per_byte; }
  bool absolute_time() const override { return false; }
  const std::vector<ChannelInfo>& channels() const override { return channels_; }

  uint64_t samplerate() const { return samplerate_; }
  uint64_t parity_errors() const override { return parity_errors_; }

 private:
  struct Stream;
  bool refill(Stream& stream);

  std::string path_;
  SigrokOptions options_;
  uint64_t samplerate_ = 0;
  std::vector<std::unique_ptr<Stream>> streams_;
  std::vector<ChannelInfo> channels_;
  uint8_t byte_ = 0;
  uint64_t parity_errors_ = 0;
};

}  // namespace modtap::captures
