// --report FILE.html: one page a technician can mail to a customer, whole in itself (no
// network, no script, no font to fetch): the summary, what to look at, the slaves, latency
// histograms, trouble over time, outages, the followed registers and the bus's last values.
// Every number it shows is the one --stats writes, and carries that key (data-stat) so a test
// can hold the two side by side.
#pragma once

#include <string>

#include <fmt/format.h>

#include "decoder/bus_diagnostics.hpp"
#include "decoder/bus_statistics.hpp"
#include "decoder/bus_timeline.hpp"
#include "decoder/register_numbering.hpp"

namespace modtap::tools {

struct ReportInfo {
  std::string capture;   // the file read or the ports listened to
  std::string version;   // modtap's
  bool complete = true;  // false: the input broke off; the numbers cover what was read
  decoder::RegisterBase register_base = decoder::RegisterBase::hex;
};

void append_report(fmt::memory_buffer& out, const decoder::BusStatistics& stats,
                   const decoder::BusDiagnostics& diagnostics, const decoder::BusTimeline& timeline,
                   const ReportInfo& info);

}  // namespace modtap::tools
