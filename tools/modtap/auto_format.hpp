// --baud auto / --parity auto on a capture file: read its start under each candidate format
// and keep the best, saying why on stderr.
#pragma once

#include <optional>
#include <string>

#include "captures/open_capture.hpp"
#include "decoder/analysis/bus_problems.hpp"
#include "decoder/protocol/analyzer.hpp"

namespace modtap::tools {

// `analyzer` holds everything but the format; `open` the file's reading options. A fixed baud
// or parity narrows the search to itself.
SerialFormat choose_file_format(const std::string& path, captures::OpenOptions open,
                                AnalyzerOptions analyzer, std::optional<uint32_t> baud,
                                std::optional<Parity> parity);

// Where the given settings read the capture's start poorly: a setting that reads it
// convincingly, with twice the bytes in frames with a good check (the settings-look-wrong
// problem names it). None without timing, where every setting reads alike.
std::optional<BetterSettings> better_format(const std::string& path, captures::OpenOptions open,
                                            AnalyzerOptions analyzer);

// The other transmission mode than the one `analyzer` was told, where the capture's start reads
// convincingly under it and did not under the one told: the setting a hint should name.
std::optional<ModeChoice> better_mode(const std::string& path, captures::OpenOptions open,
                                      AnalyzerOptions analyzer);

}  // namespace modtap::tools
