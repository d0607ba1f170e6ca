#include "tools/modtap/capture_conditions.hpp"

#include <cstdlib>
#include <stdexcept>

#include <fmt/format.h>

namespace modtap::tools {
namespace {

// One "key:value" of -a or -b, its value a number above 0.
struct Condition {
  std::string key;
  double number = 0;
  bool positive = false;
  bool whole = false;

  explicit Condition(const std::string& text) {
    const auto colon = text.find(':');
    key = text.substr(0, colon);
    const std::string value = colon == std::string::npos ? "" : text.substr(colon + 1);
    char* end = nullptr;
    number = std::strtod(value.c_str(), &end);
    positive = !value.empty() && *end == '\0' && number > 0 && number < 1e15;
    whole = positive && number == static_cast<double>(static_cast<uint64_t>(number));
  }
  int64_t seconds_ns() const { return static_cast<int64_t>(number * 1e9); }
  uint64_t count() const { return static_cast<uint64_t>(number); }
};

}  // namespace

Autostop parse_autostop(const std::vector<std::string>& conditions) {
  Autostop stop;
  for (const auto& text : conditions) {
    const Condition c(text);
    if (c.key == "duration" && c.positive) {
      stop.duration_ns = c.seconds_ns();
    } else if (c.key == "filesize" && c.whole) {
      stop.filesize_bytes = c.count() * 1000;
    } else if (c.key == "frames" && c.whole) {
      stop.frames = c.count();
    } else {
      throw std::invalid_argument(
          fmt::format("-a {}: give duration:SECONDS, filesize:KB or frames:N, each above 0", text));
    }
  }
  return stop;
}

std::optional<std::string> autostop_met(const Autostop& stop, int64_t elapsed_ns,
                                        uint64_t written_bytes) {
  if (stop.duration_ns && elapsed_ns >= *stop.duration_ns)
    return fmt::format("duration:{:g}", static_cast<double>(*stop.duration_ns) / 1e9);
  if (stop.filesize_bytes && written_bytes >= *stop.filesize_bytes)
    return fmt::format("filesize:{}", *stop.filesize_bytes / 1000);
  return std::nullopt;
}

captures::RingLimits parse_ring_buffer(const std::vector<std::string>& conditions) {
  captures::RingLimits ring;
  for (const auto& text : conditions) {
    const Condition c(text);
    if (c.key == "duration" && c.positive) {
      ring.duration_ns = c.seconds_ns();
    } else if (c.key == "filesize" && c.whole) {
      ring.filesize_bytes = c.count() * 1000;
    } else if (c.key == "files" && c.whole) {
      ring.files = c.count();
    } else {
      throw std::invalid_argument(
          fmt::format("-b {}: give duration:SECONDS, filesize:KB or files:N, each above 0", text));
    }
  }
  if (ring.files && !ring.rotates())
    throw std::invalid_argument(
        "-b files:N keeps the newest files of a ring: give -b duration:S or -b filesize:KB too");
  return ring;
}

}  // namespace modtap::tools
