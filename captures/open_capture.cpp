#include "captures/open_capture.hpp"

#include <array>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <stdexcept>

#include <fmt/format.h>

#include "captures/hexlog_reader.hpp"
#include "captures/pcap_reader.hpp"
#include "captures/pcapng_reader.hpp"
#include "captures/raw_reader.hpp"

namespace modtap::captures {
namespace {

bool ends_with(const std::string& s, const char* suffix) {
  const size_t n = std::strlen(suffix);
  return s.size() >= n && s.compare(s.size() - n, n, suffix) == 0;
}

Format by_extension(const std::string& path) {
  if (ends_with(path, ".pcap") || ends_with(path, ".pcapng")) return Format::pcap;
  if (ends_with(path, ".sr")) return Format::sigrok;
  if (ends_with(path, ".log")) return Format::hexlog;
  if (ends_with(path, ".bin") || ends_with(path, ".raw")) return Format::raw;
  return Format::automatic;
}

}  // namespace

Format detect_format(const std::string& path) {
  std::unique_ptr<FILE, int (*)(FILE*)> file(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!file) throw CaptureError(fmt::format("{}: cannot open: {}", path, std::strerror(errno)));
  std::array<uint8_t, 64> head{};
  const size_t n = std::fread(head.data(), 1, head.size(), file.get());
  return detect_format({head.data(), n}, path);
}

Format detect_format(std::span<const uint8_t> head, const std::string& path) {
  auto magic = [&](std::initializer_list<uint8_t> bytes) {
    return head.size() >= bytes.size() && std::equal(bytes.begin(), bytes.end(), head.begin());
  };
  if (magic({0xD4, 0xC3, 0xB2, 0xA1}) || magic({0xA1, 0xB2, 0xC3, 0xD4}) ||
      magic({0x4D, 0x3C, 0xB2, 0xA1}) || magic({0xA1, 0xB2, 0x3C, 0x4D}) ||
      magic({0x0A, 0x0D, 0x0D, 0x0A}))
    return Format::pcap;
  if (magic({'P', 'K', 0x03, 0x04})) return Format::sigrok;  // a .sr file is a zip
  const std::string text(head.begin(), head.end());
  if (HexlogReader::is_header(text.substr(0, text.find_first_of("\r\n")))) return Format::hexlog;
  const Format guess = by_extension(path);
  if (guess != Format::automatic) return guess;
  throw CaptureError(
      fmt::format("{}: offset 0: cannot tell the capture format from its content or name; "
                  "give --format raw|hexlog|pcap|sigrok",
                  path));
}

namespace {

// What no reader can take, said plainly before any reader tries.
void check_readable(const std::string& path) {
  std::error_code error;
  if (std::filesystem::is_directory(path, error))
    throw CaptureError(fmt::format("{}: is a directory, not a capture file", path));
  const auto size = std::filesystem::file_size(path, error);
  if (!error && size == 0 && std::filesystem::is_regular_file(path, error))
    throw CaptureError(fmt::format("{}: the file is empty", path));
}

bool is_pcapng(const std::string& path) {
  std::unique_ptr<FILE, int (*)(FILE*)> file(std::fopen(path.c_str(), "rb"), &std::fclose);
  uint8_t magic[4] = {};
  return file && std::fread(magic, 1, 4, file.get()) == 4 && magic[0] == 0x0A && magic[1] == 0x0D &&
         magic[2] == 0x0D && magic[3] == 0x0A;
}

}  // namespace

std::unique_ptr<ChunkSource> open_capture(const std::string& path, const OpenOptions& options) {
  check_readable(path);
  const Format format = options.format == Format::automatic ? detect_format(path) : options.format;
  switch (format) {
    case Format::raw:
      return std::make_unique<RawReader>(path);
    case Format::hexlog:
      return std::make_unique<HexlogReader>(path, options.serial.char_time_ns());
    case Format::pcap:
      if (is_pcapng(path))
        return std::make_unique<PcapngReader>(path, options.serial.char_time_ns());
      return std::make_unique<PcapReader>(path);
    case Format::sigrok: {
      SigrokOptions sigrok = options.sigrok;
      sigrok.format = options.serial;
      return std::make_unique<SigrokReader>(path, sigrok);
    }
    case Format::automatic:
      break;
  }
  throw CaptureError(path + ": no reader");
}

}  // namespace modtap::captures
