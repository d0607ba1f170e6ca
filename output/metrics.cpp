#include "output/metrics.hpp"

#include <string_view>

#include "decoder/protocol/records.hpp"

namespace modtap::output {

namespace {

constexpr double ns_per_s = 1e9;

// Upper bounds of the latency buckets, in seconds: a turnaround of a few characters at
// 115200 baud up to the seconds a slow drive or a gateway takes.
constexpr double latency_bounds_s[] = {0.0005, 0.001, 0.002, 0.005, 0.01, 0.02, 0.05,
                                       0.1,    0.2,   0.5,   1,     2,    5};

class Exposition {
 public:
  explicit Exposition(fmt::memory_buffer& out) : out_(out) {}

  void family(std::string_view name, std::string_view type, std::string_view help) {
    fmt::format_to(fmt::appender(out_), "# HELP {} {}\n# TYPE {} {}\n", name, help, name, type);
  }
  // `labels` is already in the exposition's form: slave="3",fc="6" (or empty).
  template <typename Value>
  void sample(std::string_view name, std::string_view labels, Value value) {
    if (labels.empty()) {
      fmt::format_to(fmt::appender(out_), "{} {}\n", name, value);
    } else {
      fmt::format_to(fmt::appender(out_), "{}{{{}}} {}\n", name, labels, value);
    }
  }

 private:
  fmt::memory_buffer& out_;
};

// The slaves, with what each exchange count of theirs is, per function code.
void exchange_family(Exposition& e, const BusStatistics& s, std::string_view name,
                     std::string_view help, uint64_t ExchangeCounts::*count) {
  e.family(name, "counter", help);
  s.for_each_slave([&](uint8_t address, const SlaveStatistics& slave) {
    for (const auto& [fc, counts] : slave.by_function)
      e.sample(name, fmt::format("slave=\"{}\",fc=\"{}\"", address, fc), counts.*count);
  });
}

void latency_histogram(Exposition& e, const BusStatistics& s) {
  constexpr std::string_view name = "modtap_response_latency_seconds";
  e.family(name, "histogram",
           "Time from the end of a request to the start of its good response, per slave");
  s.for_each_slave([&](uint8_t address, const SlaveStatistics& slave) {
    const auto& latency = slave.latency_ns;
    for (double bound : latency_bounds_s)
      e.sample("modtap_response_latency_seconds_bucket",
               fmt::format("slave=\"{}\",le=\"{}\"", address, bound),
               latency.count_at_most(static_cast<uint64_t>(bound * ns_per_s)));
    e.sample("modtap_response_latency_seconds_bucket",
             fmt::format("slave=\"{}\",le=\"+Inf\"", address), latency.count());
    e.sample("modtap_response_latency_seconds_sum", fmt::format("slave=\"{}\"", address),
             static_cast<double>(latency.sum()) / ns_per_s);
    e.sample("modtap_response_latency_seconds_count", fmt::format("slave=\"{}\"", address),
             latency.count());
  });
}

// The exchange counts each slave has per function code: the metric, its help, the count.
struct ExchangeFamily {
  std::string_view name;
  std::string_view help;
  uint64_t ExchangeCounts::*count;
};
constexpr ExchangeFamily exchange_families[] = {
    {"modtap_requests_total", "Requests to a slave with a good check, per function code",
     &ExchangeCounts::requests},
    {"modtap_responses_total", "Responses from a slave with a good check, per function code",
     &ExchangeCounts::responses},
    {"modtap_timeouts_total",
     "Requests a slave left unanswered past the time-out, per function code",
     &ExchangeCounts::timeouts},
    {"modtap_retries_total", "Requests sent again after no answer, per slave and function code",
     &ExchangeCounts::retries},
};

void per_slave(Exposition& e, const BusStatistics& s) {
  for (const ExchangeFamily& family : exchange_families)
    exchange_family(e, s, family.name, family.help, family.count);
  // A frame's function code may be as corrupted as its check: bad checks are counted per slave.
  e.family("modtap_bad_checks_total", "counter",
           "Frames to or from a slave with a wrong CRC or LRC");
  s.for_each_slave([&](uint8_t address, const SlaveStatistics& slave) {
    e.sample("modtap_bad_checks_total", fmt::format("slave=\"{}\"", address),
             slave.counts.bad_checks);
  });
  e.family("modtap_exceptions_total", "counter", "Exception responses of a slave, per code");
  s.for_each_slave([&](uint8_t address, const SlaveStatistics& slave) {
    for (const auto& [code, count] : slave.exceptions_by_code)
      e.sample("modtap_exceptions_total", fmt::format("slave=\"{}\",code=\"{}\"", address, code),
               count);
  });
  latency_histogram(e, s);
  e.family("modtap_last_frame_timestamp_seconds", "gauge",
           "When the last frame to or from a slave began, in seconds since the Unix epoch");
  s.for_each_slave([&](uint8_t address, const SlaveStatistics& slave) {
    e.sample("modtap_last_frame_timestamp_seconds", fmt::format("slave=\"{}\"", address),
             static_cast<double>(slave.last_frame_ns) / ns_per_s);
  });
}

void bus_wide(Exposition& e, const BusStatistics& s) {
  e.family("modtap_frames_total", "counter", "Frames seen, with a good check or not");
  e.sample("modtap_frames_total", "", s.frames);
  e.family("modtap_frame_bytes_total", "counter", "Bytes in frames");
  e.sample("modtap_frame_bytes_total", "", s.frame_bytes);
  e.family("modtap_noise_bytes_total", "counter", "Bytes that were no frame");
  e.sample("modtap_noise_bytes_total", "", s.noise_bytes);
  e.family("modtap_noise_records_total", "counter", "Runs of noise, by why they are noise");
  for (size_t reason = 0; reason < s.noise_by_reason.size(); ++reason)
    e.sample("modtap_noise_records_total",
             fmt::format("reason=\"{}\"", to_string(static_cast<NoiseReason>(reason))),
             s.noise_by_reason[reason]);
  e.family("modtap_line_busy_seconds_total", "counter",
           "Wire time of every byte seen, from the character format: its rate is the bus load");
  const auto bytes = static_cast<double>(s.frame_bytes + s.noise_bytes);
  e.sample("modtap_line_busy_seconds_total", "",
           bytes * static_cast<double>(s.format().char_time_ns()) / ns_per_s);
  if (const auto load = s.bus_load()) {
    e.family("modtap_bus_load_ratio", "gauge",
             "Share of the time since the first byte the wire carried characters");
    e.sample("modtap_bus_load_ratio", "", *load);
  }
  e.family("modtap_broadcasts_total", "counter", "Requests to slave 0, which no slave answers");
  e.sample("modtap_broadcasts_total", "", s.broadcasts);
  e.family("modtap_stray_bad_checks_total", "counter",
           "Frames with a bad check at addresses no good frame ever named (a corrupted address)");
  e.sample("modtap_stray_bad_checks_total", "", s.stray_bad_checks());
  e.family("modtap_findings_total", "counter",
           "Records with each finding (docs/output.md lists them), frames and noise alike");
  const auto registry = finding_registry();
  for (size_t slot = 0; slot < registry.size(); ++slot)
    e.sample("modtap_findings_total", fmt::format("finding=\"{}\"", registry[slot].name),
             s.findings[slot].count);
}

// One sample a problem found now: a series that appears when the diagnosis finds it and goes
// when it no longer does, so an alert rule is `modtap_problem > 0`.
void problems_family(Exposition& e, std::span<const Problem> problems) {
  e.family("modtap_problem", "gauge",
           "A problem the diagnosis finds now, per kind and slave (none: the whole bus); "
           "1 while found (docs/output.md)");
  for (const Problem& p : problems) {
    const std::string slave = p.slave ? fmt::format("slave=\"{}\",", *p.slave) : "";
    e.sample("modtap_problem",
             fmt::format("kind=\"{}\",{}severity=\"{}\"", problem_info(p.kind).name, slave,
                         to_string(p.severity)),
             1);
  }
}

}  // namespace

void append_metrics(fmt::memory_buffer& out, std::string_view version,
                    const BusStatistics& statistics, std::span<const Problem> problems,
                    const PortHealth& ports) {
  Exposition e(out);
  e.family("modtap_build_info", "gauge", "modtap's version, as a label; always 1");
  e.sample("modtap_build_info", fmt::format("version=\"{}\"", version), 1);
  bus_wide(e, statistics);
  per_slave(e, statistics);
  problems_family(e, problems);
  if (ports.ports.load() > 0) {
    e.family("modtap_ports_open", "gauge",
             "Ports modtap reads now, of those it listens on (an unplugged one is not)");
    e.sample("modtap_ports_open", "", ports.open.load());
  }
  e.family("modtap_port_read_errors_total", "counter",
           "Reads from a port that failed (an adapter unplugged)");
  e.sample("modtap_port_read_errors_total", "", ports.read_errors.load());
  e.family("modtap_port_reconnects_total", "counter", "Ports that came back (--reconnect)");
  e.sample("modtap_port_reconnects_total", "", ports.reconnects.load());
}

}  // namespace modtap::output
