#include "captures/raw_reader.hpp"

#include <unistd.h>

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

// What is there, up to a block: a file gives a block at a time, a pipe (a FIFO, standard
// input) the bytes written so far, as a port does, rather than waiting for a block to fill.
bool RawReader::next(Chunk& chunk) {
  ssize_t n = 0;
  do {
    n = ::read(fileno(file_.get()), block_.data(), block_.size());
  } while (n < 0 && errno == EINTR);
  if (n < 0)
    throw CaptureError(
        fmt::format("{}: offset {}: read error: {}", path_, offset_, std::strerror(errno)));
  if (n == 0) return false;
  chunk = {0, 0, {block_.data(), static_cast<size_t>(n)}};
  offset_ += static_cast<uint64_t>(n);
  return true;
}

}  // namespace modtap::captures
