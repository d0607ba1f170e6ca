// A capture read from standard input or a pipe (`modtap -r -`, `cat x.pcap | modtap -r -`).
// A pipe can be read only once, so its first bytes are taken here to tell the format, and a
// thread hands them to the reader ahead of the rest through a pipe of modtap's own: memory
// stays bounded by the pipe's buffer, however long the stream.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "captures/open_capture.hpp"

namespace modtap::captures {

// Whether `path` names standard input ("-") or a pipe, which cannot be read twice.
bool is_piped(const std::string& path);

// Opens the stream `path` names; errors and channel names say "standard input" for "-".
std::unique_ptr<ChunkSource> open_piped_capture(const std::string& path,
                                                const OpenOptions& options);

}  // namespace modtap::captures
