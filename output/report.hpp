// --report FILE.html: one page a technician can mail to a customer, whole in itself (no
// network, no script, no font to fetch): the problems found, the summary, what to look at, the
// slaves, latency histograms, trouble over time, outages, the followed registers, the bus's last
// values and the records the problems cite.
// Every number it shows is the one --stats writes, and carries that key (data-stat) so a test
// can hold the two side by side.
#pragma once

#include <cstdint>
#include <map>
#include <span>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "decoder/analysis/bus_problems.hpp"
#include "decoder/analysis/bus_statistics.hpp"
#include "decoder/analysis/bus_timeline.hpp"
#include "decoder/protocol/register_numbering.hpp"

namespace modtap::output {

struct ReportInfo {
  std::string capture;   // the file read or the ports listened to
  std::string version;   // modtap's
  bool complete = true;  // false: the input broke off; the numbers cover what was read
  RegisterBase register_base = RegisterBase::hex;
  std::vector<std::string> unseen_follow;  // --follow items no frame read or wrote
};

// The lines of the records problems cite, by the index they cite (CitedRecords).
using CitedLines = std::map<uint64_t, std::string>;

void append_report(fmt::memory_buffer& out, const BusStatistics& stats, const BusTimeline& timeline,
                   std::span<const Problem> problems, const CitedLines& cited,
                   const ReportInfo& info);

}  // namespace modtap::output
