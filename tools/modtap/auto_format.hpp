// --baud auto / --parity auto on a capture file: read its start under each candidate format
// and keep the best, saying why on stderr.
#pragma once

#include <optional>
#include <string>

#include "captures/open_capture.hpp"
#include "decoder/analyzer.hpp"

namespace modtap::tools {

// `analyzer` holds everything but the format; `open` the file's reading options. A fixed baud
// or parity narrows the search to itself.
decoder::SerialFormat choose_file_format(const std::string& path, captures::OpenOptions open,
                                         decoder::AnalyzerOptions analyzer,
                                         std::optional<uint32_t> baud,
                                         std::optional<decoder::Parity> parity);

}  // namespace modtap::tools
