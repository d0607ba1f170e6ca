#include "captures/open_capture.hpp"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <string_view>
#include <vector>

#include <fmt/format.h>

#include "captures/hexlog_reader.hpp"
#include "captures/pcap_reader.hpp"
#include "captures/pcapng_format.hpp"
#include "captures/pcapng_reader.hpp"
#include "captures/raw_reader.hpp"

namespace modtap::captures {
namespace {

bool starts_with(std::span<const uint8_t> head, std::initializer_list<uint8_t> bytes) {
  return head.size() >= bytes.size() && std::equal(bytes.begin(), bytes.end(), head.begin());
}

bool classic_pcap(std::span<const uint8_t> head) {  // microseconds or nanoseconds, either order
  return starts_with(head, {0xD4, 0xC3, 0xB2, 0xA1}) ||
         starts_with(head, {0xA1, 0xB2, 0xC3, 0xD4}) ||
         starts_with(head, {0x4D, 0x3C, 0xB2, 0xA1}) || starts_with(head, {0xA1, 0xB2, 0x3C, 0x4D});
}

bool pcapng(std::span<const uint8_t> head) {  // a section header block (a palindrome: any order)
  uint32_t block_type = 0;
  if (head.size() >= sizeof block_type) std::memcpy(&block_type, head.data(), sizeof block_type);
  return block_type == pcapng::section_header_block;
}

bool zip(std::span<const uint8_t> head) {  // a .sr file is a zip
  return starts_with(head, {'P', 'K', 0x03, 0x04});
}

bool hexlog_header(std::span<const uint8_t> head) {
  const std::string text(head.begin(), head.end());
  return HexlogReader::is_header(text.substr(0, text.find_first_of("\r\n")));
}

bool nothing(std::span<const uint8_t>) {
  return false;  // raw bytes have no mark of their own
}

std::unique_ptr<ChunkSource> open_pcap(const std::string& path, const OpenOptions&) {
  return std::make_unique<PcapReader>(path);
}

std::unique_ptr<ChunkSource> open_pcapng(const std::string& path, const OpenOptions& options) {
  return std::make_unique<PcapngReader>(path, options.serial.char_time_ns());
}

std::unique_ptr<ChunkSource> open_sigrok(const std::string& path, const OpenOptions& options) {
  SigrokOptions sigrok = options.sigrok;
  sigrok.format = options.serial;
  return std::make_unique<SigrokReader>(path, sigrok);
}

std::unique_ptr<ChunkSource> open_hexlog(const std::string& path, const OpenOptions& options) {
  return std::make_unique<HexlogReader>(path, options.serial.char_time_ns());
}

std::unique_ptr<ChunkSource> open_raw(const std::string& path, const OpenOptions&) {
  return std::make_unique<RawReader>(path);
}

// Each kind of capture: its --format, how its first bytes tell it, the names that tell it
// when they do not, and its reader. Where --format names a format, its first kind whose
// bytes match is read, else its first kind (which then says what is wrong with the file).
struct CaptureKind {
  Format format;
  bool (*recognises)(std::span<const uint8_t> head);
  std::array<std::string_view, 2> extensions;
  std::unique_ptr<ChunkSource> (*open)(const std::string& path, const OpenOptions& options);
};

constexpr CaptureKind capture_kinds[] = {
    {Format::pcap, classic_pcap, {".pcap", ".pcapng"}, open_pcap},
    {Format::pcap, pcapng, {}, open_pcapng},
    {Format::sigrok, zip, {".sr"}, open_sigrok},
    {Format::hexlog, hexlog_header, {".log"}, open_hexlog},
    {Format::raw, nothing, {".bin", ".raw"}, open_raw},
};

Format by_extension(const std::string& path) {
  for (const CaptureKind& kind : capture_kinds)
    for (std::string_view extension : kind.extensions)
      if (!extension.empty() && path.ends_with(extension)) return kind.format;
  return Format::automatic;
}

const CaptureKind& kind_of(Format format, std::span<const uint8_t> head) {
  const CaptureKind* first = nullptr;
  for (const CaptureKind& kind : capture_kinds) {
    if (kind.format != format) continue;
    if (kind.recognises(head)) return kind;
    if (!first) first = &kind;
  }
  return *first;
}

std::vector<uint8_t> file_head(const std::string& path) {
  std::unique_ptr<FILE, int (*)(FILE*)> file(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!file) throw CaptureError(fmt::format("{}: cannot open: {}", path, std::strerror(errno)));
  std::vector<uint8_t> head(capture_head_size);
  head.resize(std::fread(head.data(), 1, head.size(), file.get()));
  return head;
}

// What no reader can take, said plainly before any reader tries.
void check_readable(const std::string& path) {
  std::error_code error;
  if (std::filesystem::is_directory(path, error))
    throw CaptureError(fmt::format("{}: is a directory, not a capture file", path));
  const auto size = std::filesystem::file_size(path, error);
  if (!error && size == 0 && std::filesystem::is_regular_file(path, error))
    throw CaptureError(fmt::format("{}: the file is empty", path));
}

}  // namespace

Format detect_format(const std::string& path) {
  return detect_format(file_head(path), path);
}

Format detect_format(std::span<const uint8_t> head, const std::string& path) {
  for (const CaptureKind& kind : capture_kinds)
    if (kind.recognises(head)) return kind.format;
  const Format guess = by_extension(path);
  if (guess != Format::automatic) return guess;
  throw CaptureError(
      fmt::format("{}: offset 0: cannot tell the capture format from its content or name; "
                  "give --format raw|hexlog|pcap|sigrok",
                  path));
}

std::unique_ptr<ChunkSource> open_reader(const std::string& path, std::span<const uint8_t> head,
                                         Format format, const OpenOptions& options) {
  return kind_of(format, head).open(path, options);
}

std::unique_ptr<ChunkSource> open_capture(const std::string& path, const OpenOptions& options) {
  check_readable(path);
  const std::vector<uint8_t> head = file_head(path);
  const Format format =
      options.format == Format::automatic ? detect_format(head, path) : options.format;
  return open_reader(path, head, format, options);
}

}  // namespace modtap::captures
