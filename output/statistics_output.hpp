// The statistics as a technician reads them (-T stats) and as a program does (--stats FILE,
// one JSON object; docs/output.md lists its keys).
#pragma once

#include <fmt/format.h>

#include <span>

#include "decoder/analysis/bus_problems.hpp"
#include "decoder/analysis/bus_statistics.hpp"
#include "decoder/protocol/register_numbering.hpp"
#include "output/output.hpp"

namespace modtap::output {

// The problems, first, come from find_problems.
void print_statistics(Output& out, const BusStatistics& stats, std::span<const Problem> problems,
                      RegisterBase base = RegisterBase::hex);

// `complete` is false when the input ended in an error: the numbers cover what was read.
void append_statistics_json(fmt::memory_buffer& out, const BusStatistics& stats,
                            std::span<const Problem> problems, bool complete);

// The problems as a JSON array, as --stats, the metrics and MQTT give them.
void append_problems_json(fmt::memory_buffer& out, std::span<const Problem> problems);

}  // namespace modtap::output
