#include "captures/file_ring.hpp"

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <stdexcept>

#include <fmt/format.h>

namespace modtap::captures {

std::string ring_file_name(const std::string& path, uint64_t number, int64_t t_ns) {
  const std::filesystem::path p(path);
  const std::string extension = p.extension().string();
  const std::string prefix = path.substr(0, path.size() - extension.size());
  const std::time_t seconds = static_cast<std::time_t>(t_ns / 1'000'000'000);
  std::tm local{};
  localtime_r(&seconds, &local);
  char stamp[16];
  std::strftime(stamp, sizeof stamp, "%Y%m%d%H%M%S", &local);
  return fmt::format("{}_{:05}_{}{}", prefix, number, stamp, extension);
}

FileRing::FileRing(std::string path, RingLimits limits) : path_(std::move(path)), limits_(limits) {}

bool FileRing::past(int64_t t_ns, uint64_t bytes, int factor) const {
  if (number_ == 0) return true;
  return (limits_.duration_ns && t_ns - started_ns_ >= factor * *limits_.duration_ns) ||
         (limits_.filesize_bytes && bytes >= factor * *limits_.filesize_bytes);
}

std::string FileRing::begin(int64_t t_ns) {
  ++number_;
  started_ns_ = t_ns;
  if (!limits_.rotates()) return path_;
  kept_.push_back(ring_file_name(path_, number_, t_ns));
  while (limits_.files && kept_.size() > *limits_.files) {
    if (std::remove(kept_.front().c_str()) != 0 && errno != ENOENT)
      throw std::runtime_error(fmt::format("{}: cannot remove the oldest file of the ring: {}",
                                           kept_.front(), std::strerror(errno)));
    kept_.pop_front();
  }
  return kept_.back();
}

std::string FileRing::begin_now() {
  const auto now = std::chrono::system_clock::now().time_since_epoch();
  return begin(std::chrono::duration_cast<std::chrono::nanoseconds>(now).count());
}

}  // namespace modtap::captures
