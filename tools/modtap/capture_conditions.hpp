// dumpcap's conditions for long captures: -a, when a run stops, and -b, when its files turn.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "captures/file_ring.hpp"

namespace modtap::tools {

// -a: stop after so long (capture time for a file, wall time on a port), once the -w files
// hold so many kilobytes (1000 bytes) together, or after so many frames.
struct Autostop {
  std::optional<int64_t> duration_ns;
  std::optional<uint64_t> filesize_bytes;
  std::optional<uint64_t> frames;
};

// "duration:S", "filesize:KB", "frames:N"; throws std::invalid_argument naming the condition.
Autostop parse_autostop(const std::vector<std::string>& conditions);

// The -a condition a run has met ("duration:60", "filesize:100"), after `elapsed_ns` with
// `written_bytes` in its -w files; none yet.
std::optional<std::string> autostop_met(const Autostop& stop, int64_t elapsed_ns,
                                        uint64_t written_bytes);

// "duration:S", "filesize:KB", "files:N"; throws std::invalid_argument naming the condition,
// or when files is given without a condition that turns a file.
captures::RingLimits parse_ring_buffer(const std::vector<std::string>& conditions);

}  // namespace modtap::tools
