#include "output/statistics_output.hpp"

#include <algorithm>
#include <ctime>

#include <fmt/chrono.h>

#include "decoder/models/register_meaning.hpp"
#include "decoder/protocol/format_probe.hpp"
#include "output/render.hpp"

namespace modtap::output {

namespace {

constexpr const char* noise_reasons[] = {"junk", "truncated", "glitch", "overlong", "bad-hex"};
constexpr const char* damages[] = {nullptr, "corrupted", "cut", "collision"};

double share(uint64_t part, uint64_t whole) {
  return whole ? static_cast<double>(part) / static_cast<double>(whole) : 0.0;
}

Fixed milliseconds(uint64_t ns) {
  return {static_cast<int64_t>(ns), 6, 3};
}
Fixed microseconds(uint64_t ns) {
  return {static_cast<int64_t>(ns), 3, 3};
}

// "2023-11-14 22:13:20 UTC" for times that are dates; a raw file's nominal times start at 0.
void print_span(Output& out, const BusStatistics& s) {
  if (!s.first_t_ns) return;
  if (s.clock() == ClockQuality::none) {
    out.print("{:<16}no clock (raw bytes): {:.3f} s of bytes laid end to end at {}\n", "capture",
              s.duration_s(), describe(s.format()));
    return;
  }
  out.print("{:<16}{:.3f} s", "capture", s.duration_s());
  if (s.dated()) {
    const auto first = static_cast<std::time_t>(seconds_and_micros(*s.first_t_ns).second);
    out.print(" from {:%Y-%m-%d %H:%M:%S} UTC", fmt::gmtime(first));
  }
  out.print(", {}, clock {}\n", describe(s.format()), clock_text(s.clock(), s.read_lag_ns()));
}

void print_breakdown(Output& out, const char* const* names, std::span<const uint64_t> counts) {
  const char* separator = " (";
  for (size_t i = 0; i < counts.size(); ++i) {
    if (!counts[i] || !names[i]) continue;
    out.print("{}{} {}", separator, names[i], counts[i]);
    separator = ", ";
  }
  if (separator[0] == ',') out.print(")");
}

// Milliseconds with `decimals` digits, right-aligned in `width`: the histogram is good to
// 1.6%, so a tenth of a millisecond says all a latency percentile knows.
void print_ms(Output& out, uint64_t ns, int decimals, int width) {
  char ms[32];
  const auto end = fmt::format_to(ms, "{}", Fixed{static_cast<int64_t>(ns), 6, decimals});
  out.print("{:>{}}", std::string_view(ms, static_cast<size_t>(end - ms)), width);
}

// One row per slave, in columns a 120-character terminal holds.
void print_slaves(Output& out, const BusStatistics& s) {
  const auto& all = s.addresses();
  if (all.size() == s.stray_addresses()) return;  // no address is a slave
  out.print(
      "\n                                                              "
      "       latency ms                 poll ms\n"
      "slave  requests  responses  timeouts   rate  excepts  bad  retries"
      "      p50     p95     p99     max      p50     p95\n");
  s.for_each_slave([&](uint8_t address, const SlaveStatistics& slave) {
    const ExchangeCounts& c = slave.counts;
    out.print("{:5}  {:8}  {:9}  {:8}  {:4.1f}%  {:7}  {:3}  {:7}  ", address, c.requests,
              c.responses, c.timeouts, 100 * c.timeout_rate(), c.exceptions, c.bad_checks,
              c.retries);
    const Histogram& latency = slave.latency_ns;
    if (latency.count()) {
      for (double p : {50.0, 95.0, 99.0}) print_ms(out, latency.percentile(p), 1, 8);
      print_ms(out, latency.max(), 1, 8);
    } else {
      out.print("{:>32}", "-");
    }
    const Histogram& poll = slave.poll_interval_ns;
    if (poll.count()) {
      print_ms(out, poll.percentile(50), 0, 9);
      print_ms(out, poll.percentile(95), 0, 8);
    }
    out.print("\n");
  });
  if (const size_t stray = s.stray_addresses())
    out.print("{} only in frames with a bad check ({}): not counted as slaves\n",
              counted(stray, "address", "addresses"),
              counted(s.stray_bad_checks(), "bad check", "bad checks"));
}

void print_findings(Output& out, const BusStatistics& s) {
  bool any = false;
  for (size_t slot = 0; slot < s.findings.size(); ++slot) {
    const FindingCount& f = s.findings[slot];
    if (!f.count) continue;
    if (!any) out.print("\nfindings                 count  first records\n");
    any = true;
    out.print("  {:<21}  {:5} ", finding_registry()[slot].name, f.count);
    for (uint64_t index : f.first_records()) out.print(" #{}", index);
    out.print("\n");
  }
}

// "slave 7 silent from 12.345 s (request #10), 5 time-outs, back at 15.678 s"
void print_outages(Output& out, const BusStatistics& s) {
  if (s.outage_count() == 0) return;
  out.print("\nslaves that stopped answering ({} or more time-outs in a row): {}\n",
            silent_after_timeouts, s.outage_count());
  const int64_t start = s.first_t_ns.value_or(0);
  for (const Outage& outage : s.outages()) {
    out.print("  slave {:<3} silent from {} s (request #{}), {} time-outs, ", outage.slave,
              Fixed{outage.silent_from_ns - start, 9, 3}, outage.first_request, outage.timeouts);
    if (outage.back_ns) {
      out.print("back at {} s\n", Fixed{*outage.back_ns - start, 9, 3});
    } else {
      out.print("not back by the end\n");
    }
  }
}

// The named registers' last values: the state of the drives as the master last saw it.
void print_registers(Output& out, const BusStatistics& s, RegisterBase base) {
  constexpr size_t shown = 100;
  size_t named = 0;
  for (const auto& [key, last] : s.registers) {
    if (last.name.empty()) continue;
    if (named++ == shown) break;
    if (named == 1) out.print("\nlast values (named registers; every one in --stats)\n");
    out.print("  slave {:<3} {:>6} {:<28} ", key.slave,
              RegisterNumber{key.table, key.address, base}, last.name);
    append_value_text(out.buffer(), last.as_register(key.table, key.address));  // as text does
    out.print("\n");
  }
  if (named > shown) out.print("  ... more in --stats\n");
}

// `text` broken into lines of at most `width` after `indent` spaces, the first line's indent
// already printed.
void print_wrapped(Output& out, std::string_view text, size_t indent, size_t width) {
  size_t column = 0;
  while (!text.empty()) {
    const size_t space = text.find(' ');
    const std::string_view word = text.substr(0, space);
    if (column && column + 1 + word.size() > width) {
      out.print("\n{:{}}", "", indent);
      column = 0;
    } else if (column) {
      out.print(" ");
      ++column;
    }
    out.print("{}", word);
    column += word.size();
    text = space == std::string_view::npos ? std::string_view{} : text.substr(space + 1);
  }
  out.print("\n");
}

// The conclusions first: each problem's sentence, then what to check.
void print_problems(Output& out, std::span<const Problem> problems) {
  if (problems.empty()) {
    out.print("{:<16}none found\n\n", "problems");
    return;
  }
  out.print("problems\n");
  for (const Problem& p : problems) {
    out.print("  {:<8}", to_string(p.severity));
    print_wrapped(out, p.text, 10, 90);
    out.print("{:10}advice: ", "");
    print_wrapped(out, p.advice, 18, 82);
  }
  out.print("\n");
}

}  // namespace

void print_statistics(Output& out, const BusStatistics& s, std::span<const Problem> problems,
                      RegisterBase base) {
  print_problems(out, problems);
  print_span(out, s);
  out.print("{:<16}{}", "frames", s.frames);
  if (s.duration_s() > 0 && s.clock() != ClockQuality::none)
    out.print(" ({:.1f} a second)", static_cast<double>(s.frames) / s.duration_s());
  if (auto load = s.bus_load()) out.print(", bus load {:.1f}%", 100 * *load);
  out.print("\n  {:<14}{} (broadcasts {}, retries {})\n", "requests", s.requests, s.broadcasts,
            s.retries);
  out.print("  {:<14}{} (exceptions {}, unsolicited {})\n", "responses", s.responses, s.exceptions,
            s.unsolicited);
  out.print("  {:<14}{}\n", "unknown role", s.unknown_roles);
  out.print("  {:<14}{}", "bad checks", s.bad_checks);
  print_breakdown(out, damages, s.damaged);
  out.print("\n{:<16}{}\n", "timeouts", s.timeouts);
  if (s.unanswered) out.print("unanswered at end of capture  {}\n", s.unanswered);
  out.print("{:<16}{}, {}", "noise", counted(s.noise_records, "record", "records"),
            counted(s.noise_bytes, "byte", "bytes"));
  print_breakdown(out, noise_reasons, s.noise_by_reason);
  const uint64_t bytes = s.frame_bytes + s.noise_bytes;
  out.print("\n{:<16}{} ({:.3f}% in frames)\n", "bytes", bytes, 100 * share(s.frame_bytes, bytes));
  if (const Histogram& h = s.latency_ns; h.count()) {
    auto ms = [](uint64_t ns) { return Fixed{static_cast<int64_t>(ns), 6, 1}; };
    out.print("{:<16}p50 {} ms, p95 {} ms, p99 {} ms, max {} ms over {} responses\n", "latency",
              ms(h.percentile(50)), ms(h.percentile(95)), ms(h.percentile(99)), ms(h.max()),
              h.count());
  }
  print_slaves(out, s);
  print_outages(out, s);
  print_registers(out, s, base);
  print_findings(out, s);
  out.flush();
}

namespace {

void append_counts(fmt::memory_buffer& out, const ExchangeCounts& c) {
  fmt::format_to(fmt::appender(out),
                 "\"requests\":{},\"responses\":{},\"timeouts\":{},\"exceptions\":{},"
                 "\"bad_checks\":{},\"retries\":{}",
                 c.requests, c.responses, c.timeouts, c.exceptions, c.bad_checks, c.retries);
}

void append_latency(fmt::memory_buffer& out, const Histogram& h) {
  if (!h.count()) {
    fmt::format_to(fmt::appender(out), "null");
    return;
  }
  fmt::format_to(
      fmt::appender(out), "{{\"min\":{},\"p50\":{},\"p95\":{},\"p99\":{},\"max\":{},\"count\":{}}}",
      microseconds(h.min()), microseconds(h.percentile(50)), microseconds(h.percentile(95)),
      microseconds(h.percentile(99)), microseconds(h.max()), h.count());
}

void append_breakdown(fmt::memory_buffer& out, const char* key, const char* const* names,
                      std::span<const uint64_t> counts) {
  fmt::format_to(fmt::appender(out), ",\"{}\":{{", key);
  bool first = true;
  for (size_t i = 0; i < counts.size(); ++i) {
    if (!names[i]) continue;
    fmt::format_to(fmt::appender(out), "{}\"{}\":{}", first ? "" : ",", names[i], counts[i]);
    first = false;
  }
  out.push_back('}');
}

void append_slave(fmt::memory_buffer& out, uint8_t address, const SlaveStatistics& slave) {
  auto put = fmt::appender(out);
  fmt::format_to(put, "{{\"slave\":{},", address);
  append_counts(out, slave.counts);
  fmt::format_to(put,
                 ",\"garbled\":{},\"late_responses\":{},\"timeout_rate\":{},"
                 "\"exceptions_by_code\":{{",
                 slave.counts.garbled, slave.counts.late, slave.counts.timeout_rate());
  bool first = true;
  for (const auto& [code, count] : slave.exceptions_by_code) {
    fmt::format_to(put, "{}\"{}\":{}", first ? "" : ",", code, count);
    first = false;
  }
  fmt::format_to(put, "}},\"latency_us\":");
  append_latency(out, slave.latency_ns);
  fmt::format_to(put, ",\"poll_interval_ms\":");
  if (slave.poll_interval_ns.count()) {
    fmt::format_to(put, "{{\"median\":{},\"p95\":{},\"count\":{}}}",
                   milliseconds(slave.poll_interval_ns.percentile(50)),
                   milliseconds(slave.poll_interval_ns.percentile(95)),
                   slave.poll_interval_ns.count());
  } else {
    fmt::format_to(put, "null");
  }
  fmt::format_to(put, ",\"by_fc\":{{");
  first = true;
  for (const auto& [fc, counts] : slave.by_function) {
    fmt::format_to(put, "{}\"{}\":{{", first ? "" : ",", fc);
    append_counts(out, counts);
    out.push_back('}');
    first = false;
  }
  fmt::format_to(put, "}},\"last_frame_ns\":{}}}", slave.last_frame_ns);
}

void append_diagnostics(fmt::memory_buffer& out, const BusStatistics& s) {
  auto put = fmt::appender(out);
  fmt::format_to(put, ",\"diagnostics\":{{");
  bool first = true;
  for (size_t slot = 0; slot < s.findings.size(); ++slot) {
    const FindingCount& f = s.findings[slot];
    if (!f.count) continue;
    const FindingInfo& info = finding_registry()[slot];
    fmt::format_to(put, "{}\"{}\":{{\"count\":{},\"severity\":\"{}\",\"first\":[", first ? "" : ",",
                   info.name, f.count, to_string(info.severity));
    const char* separator = "";
    for (uint64_t index : f.first_records())
      fmt::format_to(put, "{}{}", std::exchange(separator, ","), index);
    fmt::format_to(put, "]}}");
    first = false;
  }
  out.push_back('}');
}

// A JSON number, or null where there is none (no time, no clock).
void append_optional(fmt::memory_buffer& out, const char* key, std::optional<double> value) {
  if (value) {
    fmt::format_to(fmt::appender(out), ",\"{}\":{}", key, *value);
  } else {
    fmt::format_to(fmt::appender(out), ",\"{}\":null", key);
  }
}

// As a frame's JSON gives a register, with its slave, table and when it was last seen.
void append_registers(fmt::memory_buffer& out, const BusStatistics& s) {
  auto put = fmt::appender(out);
  fmt::format_to(put, ",\"registers\":[");
  bool first = true;
  for (const auto& [key, last] : s.registers) {
    fmt::format_to(put, "{}{{\"slave\":{},\"table\":\"{}\",\"t_ns\":{},", first ? "" : ",",
                   key.slave, to_string(key.table), last.t_ns);
    append_register_keys(out, last.as_register(key.table, key.address));
    fmt::format_to(put, ",\"reads\":{},\"changes\":{}", last.reads, last.changes);
    for (const auto& [name, bound] :
         {std::pair{"lowest", last.lowest}, {"highest", last.highest}}) {
      fmt::format_to(put, ",\"{}\":", name);
      if (last.lowest <= last.highest) {
        append_number(out, bound, last.decimals);
      } else {
        out.append(std::string_view("null"));
      }
    }
    out.push_back('}');
    first = false;
  }
  fmt::format_to(put, "],\"register_values_not_kept\":{}", s.register_values_not_kept);
}

void append_outages(fmt::memory_buffer& out, const BusStatistics& s) {
  auto put = fmt::appender(out);
  fmt::format_to(put, ",\"outage_count\":{},\"outages\":[", s.outage_count());
  bool first = true;
  for (const Outage& o : s.outages()) {
    fmt::format_to(put,
                   "{}{{\"slave\":{},\"first_request\":{},\"silent_from_ns\":{},\"timeouts\":{},"
                   "\"back_ns\":",
                   first ? "" : ",", o.slave, o.first_request, o.silent_from_ns, o.timeouts);
    if (o.back_ns) {
      fmt::format_to(put, "{}}}", *o.back_ns);
    } else {
      fmt::format_to(put, "null}}");
    }
    first = false;
  }
  out.push_back(']');
}

}  // namespace

void append_problems_json(fmt::memory_buffer& out, std::span<const Problem> problems) {
  auto put = fmt::appender(out);
  out.push_back('[');
  for (const Problem& p : problems) {
    if (&p != problems.data()) out.push_back(',');
    fmt::format_to(put, "{{\"problem\":\"{}\",\"slave\":", problem_info(p.kind).name);
    if (p.slave) {
      fmt::format_to(put, "{}", *p.slave);
    } else {
      fmt::format_to(put, "null");
    }
    fmt::format_to(put, ",\"severity\":\"{}\",\"since_ns\":{},\"evidence\":{{",
                   to_string(p.severity), p.since_ns);
    for (const auto& [name, value] : p.evidence)
      fmt::format_to(put, "{}\"{}\":{}", &name == &p.evidence.front().first ? "" : ",", name,
                     value);
    fmt::format_to(put, "}},\"text\":");
    append_json_string(out, p.text);
    fmt::format_to(put, ",\"advice\":");
    append_json_string(out, p.advice);
    fmt::format_to(put, ",\"first\":[{}]}}", fmt::join(p.first_records, ","));
  }
  out.push_back(']');
}

void append_statistics_json(fmt::memory_buffer& out, const BusStatistics& s,
                            std::span<const Problem> problems, bool complete) {
  auto put = fmt::appender(out);
  fmt::format_to(put,
                 "{{\"complete\":{},\"clock\":\"{}\",\"read_lag_ms\":{},\"serial\":\"{}\","
                 "\"problems\":",
                 complete, to_string(s.clock()), s.read_lag_ns() / 1e6, describe(s.format()));
  append_problems_json(out, problems);
  if (s.first_t_ns) {
    fmt::format_to(put, ",\"first_t_ns\":{},\"last_t_ns\":{}", *s.first_t_ns, *s.last_t_ns);
  } else {
    fmt::format_to(put, ",\"first_t_ns\":null,\"last_t_ns\":null");
  }
  const double duration = s.duration_s();
  fmt::format_to(put,
                 ",\"duration_s\":{},\"frames\":{},\"requests\":{},\"responses\":{},"
                 "\"unknown_roles\":{},\"bytes\":{},\"frame_bytes\":{},\"noise_bytes\":{},"
                 "\"noise_records\":{},\"bad_checks\":{},\"timeouts\":{},\"unanswered\":{},"
                 "\"exceptions\":{},\"broadcasts\":{},\"retries\":{},\"unsolicited\":{}",
                 duration, s.frames, s.requests, s.responses, s.unknown_roles,
                 s.frame_bytes + s.noise_bytes, s.frame_bytes, s.noise_bytes, s.noise_records,
                 s.bad_checks, s.timeouts, s.unanswered, s.exceptions, s.broadcasts, s.retries,
                 s.unsolicited);
  append_breakdown(out, "noise", noise_reasons, s.noise_by_reason);
  append_breakdown(out, "damaged", damages, s.damaged);
  append_optional(out, "bus_load", s.bus_load());
  append_optional(out, "frames_per_s",
                  duration > 0 && s.clock() != ClockQuality::none
                      ? std::optional(static_cast<double>(s.frames) / duration)
                      : std::nullopt);
  fmt::format_to(put, ",\"latency_us\":");
  append_latency(out, s.latency_ns);
  fmt::format_to(put, ",\"slaves\":[");
  bool first = true;
  s.for_each_slave([&](uint8_t address, const SlaveStatistics& slave) {
    if (!first) out.push_back(',');
    append_slave(out, address, slave);
    first = false;
  });
  fmt::format_to(put, "],\"stray_addresses\":{},\"stray_bad_checks\":{}", s.stray_addresses(),
                 s.stray_bad_checks());
  append_outages(out, s);
  append_registers(out, s);
  append_diagnostics(out, s);
  fmt::format_to(put, "}}\n");
}

}  // namespace modtap::output
