#include "captures/raw_reader.hpp"

#include <cerrno>
#include <cstring>

#include <fmt/format.h>

namespace modtap::captures {

namespace {
constexpr size_t block_size = 1 << 16;
}

RawReader::RawReader(const std::string& path)
    : path_(path), file_(std::fopen(path.c_str(), "rb"), &std::fclose), block_(block_size) {
  if (!file_) throw CaptureError(fmt::format("{}: cannot open: {}", path, std::strerror(errno)));
  channels_.push_back({path, ChannelRole::bus});
}

bool RawReader::next(Chunk& chunk) {
  const size_t n = std::fread(block_.data(), 1, block_.size(), file_.get());
  if (n == 0) {
    if (std::ferror(file_.get()))
      throw CaptureError(fmt::format("{}: offset {}: read error", path_, offset_));
    return false;
  }
  chunk = {0, 0, {block_.data(), n}};
  offset_ += n;
  return true;
}

}  // namespace modtap::captures
