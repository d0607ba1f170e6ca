#include "tools/modtap/stats_sink.hpp"

#include <algorithm>

#include "decoder/register_meaning.hpp"

namespace modtap::tools {

using namespace decoder;

void StatsSink::on_frame(const Frame& frame) {
  auto& s = stats_;
  ++s.frames;
  s.frame_bytes += frame.raw.size();
  s.bad_checks += !frame.check_ok;
  s.requests += frame.role == Role::request;
  s.responses += frame.role == Role::response;
  s.unknown_roles += frame.role == Role::unknown;
  s.exceptions += frame.is_exception();
  s.broadcasts += (frame.findings & finding_broadcast) != 0;
  s.unsolicited += (frame.findings & finding_unsolicited) != 0;
  s.mismatches += (frame.findings & (finding_length_mismatch | finding_echo_mismatch)) != 0;
  if (frame.latency_ns) {
    s.latency_sum_ns += *frame.latency_ns;
    s.latency_max_ns = std::max(s.latency_max_ns, *frame.latency_ns);
    ++s.latency_count;
  }
  if (frame.slave() != 0 && frame.check_ok) count_slave(frame);
  if (frame.meaning)
    for (const RuleFinding& finding : frame.meaning->findings)
      ++s.model_findings[std::string(to_string(finding.kind))];
}

// Only frames with a good check: a corrupted address byte would invent slaves.
void StatsSink::count_slave(const Frame& frame) {
  SlaveStats& slave = stats_.slaves[frame.slave()];
  slave.requests += frame.role == Role::request;
  slave.responses += frame.role == Role::response;
  slave.exceptions += frame.is_exception();
  if (frame.latency_ns) {
    slave.latency_sum_ns += *frame.latency_ns;
    slave.latency_max_ns = std::max(slave.latency_max_ns, *frame.latency_ns);
    ++slave.latency_count;
  }
}

void StatsSink::on_noise(const Noise& noise) {
  ++stats_.noise_records;
  stats_.noise_bytes += noise.raw.size();
}

void print_stats(Output& out, const BusStats& s) {
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
  if (s.unanswered) out.print("unanswered at end of capture  {}\n", s.unanswered);
  out.print("noise records   {} ({} bytes)\n", s.noise_records, s.noise_bytes);
  out.print("bytes           {} ({:.3f}% in frames)\n", bytes,
            bytes ? 100.0 * static_cast<double>(s.frame_bytes) / static_cast<double>(bytes) : 0.0);
  if (s.latency_count) {
    out.print("latency         mean {:.3f} ms, max {:.3f} ms over {} pairs\n",
              static_cast<double>(s.latency_sum_ns) / static_cast<double>(s.latency_count) / 1e6,
              static_cast<double>(s.latency_max_ns) / 1e6, s.latency_count);
  }
  if (!s.slaves.empty())
    out.print("slave  requests  responses  exceptions  timeouts  latency mean/max ms\n");
  for (const auto& [id, slave] : s.slaves) {
    out.print("{:5}  {:8}  {:9}  {:10}  {:8}", id, slave.requests, slave.responses,
              slave.exceptions, slave.timeouts);
    if (slave.latency_count)
      out.print("  {:.3f} / {:.3f}",
                static_cast<double>(slave.latency_sum_ns) /
                    static_cast<double>(slave.latency_count) / 1e6,
                static_cast<double>(slave.latency_max_ns) / 1e6);
    out.print("\n");
  }
  if (!s.model_findings.empty()) out.print("model findings\n");
  for (const auto& [kind, count] : s.model_findings) out.print("  {:<20}  {}\n", kind, count);
  out.flush();
}

}  // namespace modtap::tools
