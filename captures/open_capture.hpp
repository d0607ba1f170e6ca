// Picks the reader for a capture file: by its content first, then by its name.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "captures/chunk_source.hpp"
#include "captures/sigrok_reader.hpp"
#include "decoder/protocol/serial_format.hpp"

namespace modtap::captures {

enum class Format { automatic, raw, hexlog, pcap, sigrok };

struct OpenOptions {
  Format format = Format::automatic;
  SerialFormat serial;
  SigrokOptions sigrok;
};

// How many first bytes tell a capture's format.
inline constexpr size_t capture_head_size = 64;

// What the file's first bytes (or, failing that, its extension) say it is. Throws
// CaptureError when neither tells.
Format detect_format(const std::string& path);
// The same from a file's first capture_head_size bytes (or fewer, when it is shorter), for a
// stream.
Format detect_format(std::span<const uint8_t> head, const std::string& path);
// The reader of `format` for the file at `path` whose first bytes are `head` (pcap or pcapng,
// both --format pcap, by their first bytes).
std::unique_ptr<ChunkSource> open_reader(const std::string& path, std::span<const uint8_t> head,
                                         Format format, const OpenOptions& options);

std::unique_ptr<ChunkSource> open_capture(const std::string& path, const OpenOptions& options);

}  // namespace modtap::captures

template <>
struct modtap::EnumNames<modtap::captures::Format> {
  static constexpr std::array<std::string_view, 5> names{"auto", "raw", "hexlog", "pcap", "sigrok"};
};
