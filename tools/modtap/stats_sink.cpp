#include "tools/modtap/stats_sink.hpp"

namespace modtap::tools {

void print_stats(Output& out, const decoder::BusStats& s) {
  const uint64_t bytes = s.frame_bytes + s.noise_bytes;
  out.print("frames          {}\n", s.frames);
  out.print("  requests      {}\n", s.requests);
  out.print("  responses     {}\n", s.responses);
  out.print("  unknown role  {}\n", s.unknown_roles);
  out.print("  bad checks    {}\n", s.bad_checks);
  out.print("  exceptions    {}\n", s.exceptions);
  out.print("  broadcasts    {}\n", s.broadcasts);
  out.print("  unsolicited   {}\n", s.unsolicited);
  out.print("  mismatched    {}\n", s.mismatches);
  out.print("timeouts        {}\n", s.timeouts);
  out.print("noise records   {} ({} bytes)\n", s.noise_records, s.noise_bytes);
  out.print("bytes           {} ({:.3f}% in frames)\n", bytes,
            bytes ? 100.0 * static_cast<double>(s.frame_bytes) / static_cast<double>(bytes) : 0.0);
  if (s.latency_count) {
    out.print("latency         mean {:.3f} ms, max {:.3f} ms over {} pairs\n",
              static_cast<double>(s.latency_sum_ns) / static_cast<double>(s.latency_count) / 1e6,
              static_cast<double>(s.latency_max_ns) / 1e6, s.latency_count);
  }
  out.flush();
}

}  // namespace modtap::tools
