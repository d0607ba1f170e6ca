#include "output/report.hpp"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <functional>
#include <map>
#include <optional>
#include <set>

#include <fmt/chrono.h>

#include "decoder/protocol/format_probe.hpp"
#include "output/render.hpp"
#include "output/svg_plot.hpp"
#include "output/text_sink.hpp"

namespace modtap::output {

namespace {

constexpr std::string_view style = R"(
body { font: 14px/1.4 "DejaVu Sans", Arial, sans-serif; color: #1d2733; margin: 0; background: #f4f6f8; }
main { max-width: 960px; margin: 0 auto; padding: 16px 24px 48px; background: #fff; }
h1 { font-size: 22px; margin: 8px 0 2px; } h2 { font-size: 17px; margin: 28px 0 8px; border-bottom: 1px solid #d5dbe1; }
h3 { font-size: 15px; margin: 16px 0 4px; } summary { cursor: pointer; color: #5a6673; margin: 6px 0; }
.meta { color: #5a6673; margin: 0 0 12px; }
.broken { background: #fdecea; border: 1px solid #d64541; padding: 8px 12px; }
.cards { display: grid; grid-template-columns: repeat(4, 1fr); gap: 8px; }
.card { border: 1px solid #d5dbe1; border-radius: 4px; padding: 6px 10px; }
.card .value { font-size: 20px; font-weight: bold; } .card .name { color: #5a6673; font-size: 12px; }
.card.trouble { border-color: #d64541; } .card.trouble .value { color: #b03a2e; }
table { border-collapse: collapse; width: 100%; font-size: 13px; }
th, td { padding: 3px 6px; border-bottom: 1px solid #e3e7eb; text-align: right; white-space: nowrap; }
th { background: #eef1f4; white-space: normal; vertical-align: bottom; }
td.text, th.text { text-align: left; white-space: normal; }
figure { margin: 8px 0; } figcaption { font-size: 13px; color: #5a6673; }
.severity { font-weight: bold; } .error { color: #b03a2e; } .warning { color: #b9770e; } .note { color: #5a6673; }
.charts { display: grid; grid-template-columns: 1fr 1fr; gap: 4px 16px; }
svg.chart { max-width: 100%; height: auto; font-size: 11px; }
.grid { stroke: #e3e7eb; } .axis { stroke: #5a6673; } .marker { stroke: #1d2733; stroke-dasharray: 3 3; }
.tick { fill: #5a6673; } .label { fill: #1d2733; }
.traffic { fill: #9db7d5; } .latency { fill: #2f6fb0; }
.timeouts { fill: #e8a33d; } .exceptions { fill: #8e5bb5; } .bad { fill: #d64541; } .noise { fill: #7f8c8d; }
.value-line { fill: none; stroke: #1b7f5f; stroke-width: 2; } .value-band { fill: #bfe3d6; }
.legend span { display: inline-block; width: 10px; height: 10px; margin: 0 4px 0 12px; }
.legend .timeouts { background: #e8a33d; } .legend .exceptions { background: #8e5bb5; }
.legend .bad { background: #d64541; } .legend .noise { background: #7f8c8d; }
footer { color: #5a6673; font-size: 12px; margin-top: 32px; }
.problem { border-left: 5px solid #5a6673; background: #f8f9fa; padding: 6px 12px; margin: 8px 0; }
.problem.error { border-color: #d64541; } .problem.warning { border-color: #e8a33d; }
.problem.error, .problem.warning, tr.error, tr.warning { color: inherit; }
.problem .sentence { font-size: 15px; } .problem .severity { margin-right: 6px; }
.problem .advice, .problem .seen { margin-top: 3px; } .problem .seen { color: #5a6673; font-size: 13px; }
.healthy { border-left: 5px solid #1b7f5f; background: #f8f9fa; padding: 6px 12px; }
tr.error td { background: #fdecea; } tr.warning td { background: #fef5e7; }
pre.records { font-size: 12px; white-space: pre-wrap; background: #f4f6f8; padding: 8px; }
pre.records span:target { background: #fff3b0; }
.state-0 { fill: #2f6fb0; background: #2f6fb0; } .state-1 { fill: #e8a33d; background: #e8a33d; }
.state-2 { fill: #1b7f5f; background: #1b7f5f; } .state-3 { fill: #8e5bb5; background: #8e5bb5; }
.state-4 { fill: #d64541; background: #d64541; } .state-5 { fill: #7f8c8d; background: #7f8c8d; }
.state-6 { fill: #9db7d5; background: #9db7d5; } .state-7 { fill: #c2a15a; background: #c2a15a; }
.value-dot { fill: #1b7f5f; }
)";
// The colours of state bands: a register of more states than this reuses them.
constexpr size_t state_colours = 8;

std::string milliseconds(uint64_t ns, int decimals = 1) {
  return fmt::format("{}", Fixed{static_cast<int64_t>(ns), 6, decimals});
}

// "250 ms", "1.5 s", "10 min": a bin's width as a chart's axis names it.
std::string duration_text(int64_t ns) {
  if (ns < 1'000'000'000) return fmt::format("{:g} ms", static_cast<double>(ns) / 1e6);
  if (ns < 120'000'000'000) return fmt::format("{:g} s", static_cast<double>(ns) / 1e9);
  if (ns < 7'200'000'000'000) return fmt::format("{:.3g} min", static_cast<double>(ns) / 6e10);
  return fmt::format("{:.3g} h", static_cast<double>(ns) / 3.6e12);
}

// A capture's time axis in the unit that keeps its numbers short.
struct TimeUnit {
  double seconds;
  const char* name;
};
TimeUnit time_unit(double span_s) {
  if (span_s <= 180) return {1, "s"};
  if (span_s <= 3 * 3600) return {60, "min"};
  if (span_s <= 3 * 86400) return {3600, "h"};
  return {86400, "days"};
}

// How a chart's time axis reads: clock time (UTC) when the capture is dated, else the time
// since its first record in the unit that keeps the numbers short.
struct TimeAxis {
  TimeUnit unit;
  std::optional<int64_t> origin_ns;  // the first bin's start, when the capture is dated
};

// The capture's clock time of `t_ns`, as the page's header writes it.
std::string clock_time(int64_t t_ns, const char* format = "%Y-%m-%d %H:%M:%S") {
  const auto seconds = static_cast<std::time_t>(seconds_and_micros(t_ns).second);
  return fmt::format(fmt::runtime(fmt::format("{{:{}}}", format)), fmt::gmtime(seconds));
}

// A number the statistics hold, as an element that names the key --stats gives it; `scale`
// turns what is shown into the statistic's unit (a millisecond shown is 1000 of latency_us).
void stat_element(fmt::memory_buffer& out, std::string_view tag, std::string_view css_class,
                  std::string_view key, std::string_view shown, double scale) {
  auto put = fmt::appender(out);
  fmt::format_to(put, "<{}", tag);
  if (!css_class.empty()) fmt::format_to(put, " class=\"{}\"", css_class);
  fmt::format_to(put, " data-stat=\"{}\"", key);
  if (scale != 1) fmt::format_to(put, " data-scale=\"{:g}\"", scale);
  fmt::format_to(put, ">{}</{}>", shown, tag);
}

void stat_cell(fmt::memory_buffer& out, std::string_view key, std::string_view shown,
               double scale = 1, std::string_view css_class = {}) {
  stat_element(out, "td", css_class, key, shown, scale);
}

void card(fmt::memory_buffer& out, std::string_view key, std::string_view name,
          std::string_view shown, bool trouble, double scale = 1) {
  fmt::format_to(fmt::appender(out), "<div class=\"card{}\">", trouble ? " trouble" : "");
  stat_element(out, "div", "value", key, shown, scale);
  fmt::format_to(fmt::appender(out), "<div class=\"name\">{}</div></div>\n", name);
}

void append_head(fmt::memory_buffer& out, const BusStatistics& s, const ReportInfo& info) {
  auto put = fmt::appender(out);
  fmt::format_to(put,
                 "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
                 "<title>modtap report: ");
  append_html(out, info.capture);
  fmt::format_to(put,
                 "</title>\n<style>{}</style></head>\n<body><main>\n<h1>Modbus bus report</h1>\n"
                 "<p class=\"meta\">",
                 style);
  append_html(out, info.capture);
  fmt::format_to(put, " · {} · clock {}", describe(s.format()),
                 clock_text(s.clock(), s.read_lag_ns()));
  if (s.dated())
    fmt::format_to(put, " · {} to {} UTC", clock_time(*s.first_t_ns), clock_time(*s.last_t_ns));
  out.append(std::string_view("</p>\n"));
  if (!info.complete)
    out.append(std::string_view(
        "<p class=\"broken\">The capture broke off: these numbers cover what was read before "
        "the break.</p>\n"));
}

void append_summary(fmt::memory_buffer& out, const BusStatistics& s) {
  out.append(std::string_view("<h2>Summary</h2>\n<div class=\"cards\">\n"));
  const double duration = s.duration_s();
  card(out, "duration_s", "seconds of traffic", fmt::format("{:.3f}", duration), false);
  card(out, "frames", "frames", fmt::format("{}", s.frames), false);
  if (duration > 0 && s.clock() != ClockQuality::none)  // without a clock, time is nominal
    card(out, "frames_per_s", "frames a second",
         fmt::format("{:.1f}", static_cast<double>(s.frames) / duration), false);
  if (auto load = s.bus_load())
    card(out, "bus_load", "bus load (% of wire time)", fmt::format("{:.1f}", 100 * *load), false,
         0.01);
  card(out, "requests", "requests", fmt::format("{}", s.requests), false);
  card(out, "responses", "responses", fmt::format("{}", s.responses), false);
  card(out, "timeouts", "time-outs", fmt::format("{}", s.timeouts), s.timeouts > 0);
  card(out, "exceptions", "exception responses", fmt::format("{}", s.exceptions), s.exceptions > 0);
  card(out, "bad_checks", "bad CRC/LRC", fmt::format("{}", s.bad_checks), s.bad_checks > 0);
  card(out, "retries", "retries", fmt::format("{}", s.retries), s.retries > 0);
  card(out, "noise_bytes", "noise bytes", fmt::format("{}", s.noise_bytes), s.noise_bytes > 0);
  if (s.latency_ns.count())
    card(out, "latency_us.p99", "latency p99 (ms)", milliseconds(s.latency_ns.percentile(99)),
         false, 1000);
  out.append(std::string_view("</div>\n"));
}

// A record a problem cites: a link to its line on this page where the page holds it.
void append_record_link(fmt::memory_buffer& out, uint64_t index, const CitedLines& lines) {
  if (lines.count(index)) {
    fmt::format_to(fmt::appender(out), "<a href=\"#record-{0}\">#{0}</a> ", index);
  } else {
    fmt::format_to(fmt::appender(out), "#{} ", index);
  }
}

// The conclusions, first: each faulty device, what it does wrong, what to check, where it shows.
void append_problems(fmt::memory_buffer& out, const BusStatistics& s,
                     std::span<const Problem> problems, const CitedLines& lines) {
  out.append(std::string_view("<h2>Problems</h2>\n"));
  if (problems.empty()) {
    out.append(std::string_view(
        "<p class=\"healthy\">No problem found: no slave fails to answer or answers too slowly, "
        "no answers arrive damaged or collide, no request is refused again and again, and the "
        "line carries no noise worth acting on.</p>\n"));
    return;
  }
  auto put = fmt::appender(out);
  for (size_t i = 0; i < problems.size(); ++i) {
    const Problem& p = problems[i];
    const std::string_view severity = to_string(p.severity);
    fmt::format_to(put,
                   "<div class=\"problem {0}\" id=\"problem-{1}\" data-problem=\"{2}\" "
                   "data-slave=\"{3}\">\n<div class=\"sentence\"><span class=\"severity "
                   "{0}\">{0}</span>",
                   severity, i + 1, problem_info(p.kind).name,
                   p.slave ? fmt::format("{}", *p.slave) : "bus");
    append_html(out, p.text);
    out.append(std::string_view("</div>\n<div class=\"advice\"><b>What to check:</b> "));
    append_html(out, p.advice);
    fmt::format_to(put, "</div>\n<div class=\"seen\">First seen {}", moment_text(s, p.since_ns));
    if (!p.first_records.empty()) {
      out.append(std::string_view("; records "));
      for (uint64_t index : p.first_records) append_record_link(out, index, lines);
    }
    out.append(std::string_view("</div>\n</div>\n"));
  }
}

// Findings as rows: severity, name, count, meaning, the first records that show them.
void append_finding_table(fmt::memory_buffer& out, const BusStatistics& s,
                          std::span<const size_t> slots) {
  const auto registry = finding_registry();
  out.append(std::string_view(
      "<table><tr><th class=\"text\">severity</th><th class=\"text\">finding</th><th>count</th>"
      "<th class=\"text\">what it means</th><th class=\"text\">first records</th></tr>\n"));
  auto put = fmt::appender(out);
  for (size_t slot : slots) {
    const FindingInfo& info = registry[slot];
    const FindingCount& f = s.findings[slot];
    const std::string_view severity = to_string(info.severity);
    fmt::format_to(put, "<tr><td class=\"text severity {0}\">{0}</td><td class=\"text\">{1}</td>",
                   severity, info.name);
    stat_cell(out, fmt::format("diagnostics.{}.count", info.name), fmt::format("{}", f.count));
    out.append(std::string_view("<td class=\"text\">"));
    append_html(out, info.title);
    out.append(std::string_view("</td><td class=\"text\">"));
    for (uint64_t index : f.first_records()) fmt::format_to(put, "#{} ", index);
    out.append(std::string_view("</td></tr>\n"));
  }
  out.append(std::string_view("</table>\n"));
}

// The findings, errors first: what to look at, and in which records.
void append_findings(fmt::memory_buffer& out, const BusStatistics& s) {
  std::vector<size_t> slots;
  for (size_t slot = 0; slot < s.findings.size(); ++slot)
    if (s.findings[slot].count) slots.push_back(slot);
  out.append(std::string_view("<h2>What to look at</h2>\n"));
  if (slots.empty()) {
    out.append(
        std::string_view("<p>No findings: every frame is as the standard and the models "
                         "say it should be.</p>\n"));
    return;
  }
  const auto registry = finding_registry();
  std::stable_sort(slots.begin(), slots.end(), [&](size_t a, size_t b) {
    if (registry[a].severity != registry[b].severity)
      return registry[a].severity > registry[b].severity;
    return s.findings[a].count > s.findings[b].count;
  });
  // Errors and warnings in view; the notes (poll jitter, broadcasts, exceptions a model
  // explains) folded under a line that names them.
  const auto notes = std::find_if(slots.begin(), slots.end(), [&](size_t slot) {
    return registry[slot].severity == Severity::note;
  });
  if (notes != slots.begin()) append_finding_table(out, s, {slots.begin(), notes});
  if (notes == slots.end()) return;
  out.append(std::string_view("<details><summary>"));
  const char* separator = "";
  uint64_t noted = 0;
  for (auto it = notes; it != slots.end(); ++it) noted += s.findings[*it].count;
  fmt::format_to(fmt::appender(out), "{}: ", counted(noted, "note", "notes"));
  for (auto it = notes; it != slots.end(); ++it)
    fmt::format_to(fmt::appender(out), "{}{} {}", std::exchange(separator, ", "),
                   registry[*it].name, s.findings[*it].count);
  out.append(std::string_view("</summary>\n"));
  append_finding_table(out, s, {notes, slots.end()});
  out.append(std::string_view("</details>\n"));
}

std::string exceptions_text(const SlaveStatistics& slave) {
  std::string text = fmt::format("{}", slave.counts.exceptions);
  const char* separator = " (";
  for (const auto& [code, count] : slave.exceptions_by_code) {
    text += fmt::format("{}{:02X}H ×{}", separator, code, count);
    separator = ", ";
  }
  if (!slave.exceptions_by_code.empty()) text += ")";
  return text;
}

// Each slave's gravest problem, and where the page states it.
struct SlaveProblem {
  Severity severity;
  size_t number;  // problem-N
};
std::map<uint8_t, SlaveProblem> slave_problems(std::span<const Problem> problems) {
  std::map<uint8_t, SlaveProblem> by_slave;
  for (size_t i = 0; i < problems.size(); ++i) {
    const Problem& p = problems[i];
    if (p.slave && !by_slave.count(*p.slave)) by_slave[*p.slave] = {p.severity, i + 1};
  }
  return by_slave;  // problems come gravest first
}

void append_slave_row(fmt::memory_buffer& out, uint8_t address, const SlaveStatistics& slave,
                      const SlaveProblem* problem) {
  const ExchangeCounts& c = slave.counts;
  const std::string key = fmt::format("slaves.{}.", address);
  if (problem) {
    fmt::format_to(fmt::appender(out), "<tr class=\"{}\"><td><a href=\"#problem-{}\">{}</a></td>",
                   to_string(problem->severity), problem->number, address);
  } else {
    fmt::format_to(fmt::appender(out), "<tr><td>{}</td>", address);
  }
  stat_cell(out, key + "requests", fmt::format("{}", c.requests));
  stat_cell(out, key + "responses", fmt::format("{}", c.responses));
  stat_cell(out, key + "timeouts", fmt::format("{}", c.timeouts));
  stat_cell(out, key + "timeout_rate", fmt::format("{:.1f}%", 100 * c.timeout_rate()), 0.01);
  stat_cell(out, key + "exceptions", exceptions_text(slave), 1, "text");
  stat_cell(out, key + "bad_checks", fmt::format("{}", c.bad_checks));
  stat_cell(out, key + "retries", fmt::format("{}", c.retries));
  const Histogram& latency = slave.latency_ns;
  if (latency.count()) {
    for (auto [name, p] : {std::pair{"p50", 50.0}, {"p95", 95.0}, {"p99", 99.0}})
      stat_cell(out, key + "latency_us." + name, milliseconds(latency.percentile(p)), 1000);
    stat_cell(out, key + "latency_us.max", milliseconds(latency.max()), 1000);
  } else {
    out.append(std::string_view("<td>-</td><td>-</td><td>-</td><td>-</td>"));
  }
  const Histogram& poll = slave.poll_interval_ns;
  if (poll.count()) {
    stat_cell(out, key + "poll_interval_ms.median", milliseconds(poll.percentile(50), 0));
    stat_cell(out, key + "poll_interval_ms.p95", milliseconds(poll.percentile(95), 0));
  } else {
    out.append(std::string_view("<td>-</td><td>-</td>"));
  }
  out.append(std::string_view("</tr>\n"));
}

void append_slaves(fmt::memory_buffer& out, const BusStatistics& s,
                   std::span<const Problem> problems) {
  out.append(std::string_view("<h2>Slaves</h2>\n"));
  const auto& all = s.addresses();
  if (all.size() == s.stray_addresses()) {  // no address is a slave
    out.append(std::string_view("<p>No slave: no frame with a good check named one.</p>\n"));
    return;
  }
  const auto faulty = slave_problems(problems);
  if (!faulty.empty())
    out.append(std::string_view(
        "<p class=\"meta\">A slave with a problem is shaded, red for an error and amber for a "
        "warning; its number leads to the problem.</p>\n"));
  out.append(std::string_view(
      "<table><tr><th>slave</th><th>requests</th><th>responses</th><th>time-outs</th>"
      "<th>rate</th><th class=\"text\">exceptions</th><th>bad checks</th><th>retries</th>"
      "<th>latency ms p50</th><th>p95</th><th>p99</th><th>max</th><th>poll ms p50</th>"
      "<th>p95</th></tr>\n"));
  s.for_each_slave([&](uint8_t address, const SlaveStatistics& slave) {
    const auto problem = faulty.find(address);
    append_slave_row(out, address, slave, problem == faulty.end() ? nullptr : &problem->second);
  });
  out.append(std::string_view("</table>\n"));
  if (const size_t stray = s.stray_addresses())
    fmt::format_to(fmt::appender(out),
                   "<p class=\"meta\">{} more {} appeared only in frames with a bad check "
                   "(<span data-stat=\"stray_bad_checks\">{}</span> {}): not counted as "
                   "slaves.</p>\n",
                   stray, stray == 1 ? "address" : "addresses", s.stray_bad_checks(),
                   s.stray_bad_checks() == 1 ? "bad check" : "bad checks");
}

// One slave's response times: bars over a linear axis, or a logarithmic one when the slowest
// answer took ten times the fastest, so both the usual answers and the stragglers show.
void append_latency_chart(fmt::memory_buffer& out, uint8_t address, const Histogram& h) {
  constexpr int bars = 40;
  // Answers faster than 10 us are one clock tick (bytes read in one chunk) and share a bar.
  const double low_ms = std::max(static_cast<double>(h.min()), 1e4) / 1e6;
  const double high_ms = std::max(static_cast<double>(h.max()) / 1e6, low_ms * 1.02);
  PlotFrame frame;
  frame.width = 440;
  frame.height = 200;
  frame.x_log = high_ms / low_ms >= 10;
  const auto edge = [&](int i) {
    const double at = static_cast<double>(i) / bars;
    return frame.x_log ? low_ms * std::pow(high_ms / low_ms, at) : low_ms + (high_ms - low_ms) * at;
  };
  std::vector<uint64_t> counts(bars);
  uint64_t below = 0, tallest = 1;
  for (int i = 0; i < bars; ++i) {
    const uint64_t upto =
        i + 1 == bars ? h.count() : h.count_at_most(static_cast<uint64_t>(edge(i + 1) * 1e6));
    counts[i] = upto - below;
    below = upto;
    tallest = std::max(tallest, counts[i]);
  }
  frame.x_min = low_ms;
  frame.x_max = high_ms;
  frame.x_ticks = frame.x_log ? log_ticks(low_ms, high_ms) : round_ticks(low_ms, high_ms, 4);
  std::erase_if(frame.x_ticks, [&](double x) { return x < low_ms || x > high_ms; });
  frame.y_ticks = round_ticks(0, static_cast<double>(tallest), 4);
  frame.y_max = frame.y_ticks.back();
  frame.x_label = "response latency (ms)";
  frame.y_label = "responses";
  SvgPlot plot(out, std::move(frame), fmt::format("slave {} latency histogram", address));
  for (int i = 0; i < bars; ++i)
    plot.bar(edge(i), edge(i + 1), 0, static_cast<double>(counts[i]), "latency");
  plot.marker(static_cast<double>(h.percentile(50)) / 1e6, "p50");
  plot.marker(static_cast<double>(h.percentile(99)) / 1e6, "p99");
  plot.finish();
}

// A histogram per slave; on a bus of many slaves, those with the slowest answers (p99). The
// caption counts the answers the clock timed against all the slave gave in time.
void append_latency(fmt::memory_buffer& out, const BusStatistics& s) {
  constexpr size_t charted = 32;
  std::vector<std::pair<uint8_t, const SlaveStatistics*>> slaves;
  for (const auto& [address, slave] : s.addresses())
    if (slave->good && slave->latency_ns.count()) slaves.emplace_back(address, slave.get());
  if (slaves.empty()) return;
  const size_t all = slaves.size();
  if (all > charted) {
    std::stable_sort(slaves.begin(), slaves.end(), [](const auto& a, const auto& b) {
      return a.second->latency_ns.percentile(99) > b.second->latency_ns.percentile(99);
    });
    slaves.resize(charted);
    std::sort(slaves.begin(), slaves.end());
  }
  out.append(std::string_view("<h2>Response latency</h2>\n"));
  auto put = fmt::appender(out);
  if (all > charted)
    fmt::format_to(put,
                   "<p class=\"meta\">The {} of {} slaves with the slowest answers (p99).</p>\n",
                   charted, all);
  if (std::any_of(slaves.begin(), slaves.end(), [](const auto& slave) {
        return slave.second->latency_ns.count() < slave.second->counts.answered_in_time();
      }))
    out.append(std::string_view(
        "<p class=\"meta\">Only the answers the clock timed: on a clock per read, an answer "
        "read together with its request has no time of its own.</p>\n"));
  out.append(std::string_view("<div class=\"charts\">\n"));
  for (const auto& [address, slave] : slaves) {
    const Histogram& h = slave->latency_ns;
    const uint64_t answers = slave->counts.answered_in_time();
    const std::string key = fmt::format("slaves.{}.latency_us.", address);
    const auto stat = [&](std::string_view name, std::string shown, double scale) {
      stat_element(out, "span", {}, key + std::string(name), shown, scale);
    };
    fmt::format_to(put, "<figure><figcaption>slave {}: ", address);
    stat("count", fmt::format("{}", h.count()), 1);
    if (h.count() < answers) {
      fmt::format_to(put, " of {} answers timed", answers);
    } else {
      out.append(std::string_view(h.count() == 1 ? " answer" : " answers"));
    }
    out.append(std::string_view(", p50 "));
    stat("p50", milliseconds(h.percentile(50)), 1000);
    out.append(std::string_view(" ms, p99 "));
    stat("p99", milliseconds(h.percentile(99)), 1000);
    out.append(std::string_view(" ms, max "));
    stat("max", milliseconds(h.max()), 1000);
    out.append(std::string_view(" ms</figcaption>\n"));
    append_latency_chart(out, address, h);
    out.append(std::string_view("</figure>\n"));
  }
  out.append(std::string_view("</div>\n"));
}

TimeAxis time_axis(const BusTimeline& timeline, const BusStatistics& s) {
  // Clock time says little of a few seconds: they read better as seconds from the start.
  const bool clock = s.dated() && timeline.span_s() >= 10;
  return {time_unit(timeline.span_s()), clock ? timeline.origin_ns() : std::nullopt};
}

// Ticks at round times of the clock (10 s, 5 min, an hour, a day), about 4 to 8 of them.
void clock_ticks(PlotFrame& frame, int64_t origin_ns, TimeUnit unit) {
  static constexpr int64_t steps_s[] = {1,     2,     5,     10,    15,     30,    60,
                                        120,   300,   600,   900,   1800,   3600,  7200,
                                        10800, 21600, 43200, 86400, 172800, 604800};
  const double span_s = frame.x_max * unit.seconds;
  int64_t step = steps_s[std::size(steps_s) - 1];
  for (int64_t candidate : steps_s) {
    if (span_s / static_cast<double>(candidate) <= 8) {
      step = candidate;
      break;
    }
  }
  const double origin_s = static_cast<double>(origin_ns) / 1e9;
  const auto first = static_cast<int64_t>(std::ceil(origin_s / static_cast<double>(step))) * step;
  for (int64_t t = first; static_cast<double>(t) <= origin_s + span_s; t += step)
    frame.x_ticks.push_back((static_cast<double>(t) - origin_s) / unit.seconds);
  const char* format = step >= 86400    ? "%Y-%m-%d"
                       : span_s > 86400 ? "%m-%d %H:%M"
                       : step >= 60     ? "%H:%M"
                                        : "%H:%M:%S";
  frame.x_tick_text = [origin_s, unit, format](double x) {
    return clock_time(std::llround(origin_s + x * unit.seconds) * 1'000'000'000, format);
  };
  frame.x_label = "time (UTC)";
}

// A frame of the capture's time for a chart.
PlotFrame time_frame(const BusTimeline& timeline, const TimeAxis& axis) {
  PlotFrame frame;
  frame.x_max = std::max(timeline.span_s() / axis.unit.seconds, 1e-9);
  if (axis.origin_ns) {
    clock_ticks(frame, *axis.origin_ns, axis.unit);
    return frame;
  }
  frame.x_ticks = round_ticks(0, frame.x_max, 8);
  std::erase_if(frame.x_ticks, [&](double x) { return x > frame.x_max * (1 + 1e-9); });
  frame.x_label = fmt::format("time since the first record ({})", axis.unit.name);
  return frame;
}

void append_traffic_chart(fmt::memory_buffer& out, const BusTimeline& timeline,
                          const TimeAxis& axis) {
  const auto& bins = timeline.traffic();
  const double bin_s = timeline.bin_s();
  const double width = bin_s / axis.unit.seconds;
  double highest = 1;
  for (const TrafficBin& bin : bins)
    highest = std::max(highest, static_cast<double>(bin.frames) / bin_s);
  PlotFrame frame = time_frame(timeline, axis);
  frame.y_ticks = round_ticks(0, highest, 4);
  frame.y_max = frame.y_ticks.back();
  frame.y_label = "frames/s";
  SvgPlot plot(out, std::move(frame), "frames a second over time");
  for (size_t i = 0; i < bins.size(); ++i)
    plot.bar(static_cast<double>(i) * width, static_cast<double>(i + 1) * width, 0,
             static_cast<double>(bins[i].frames) / bin_s, "traffic");
  plot.finish();
}

void append_trouble_chart(fmt::memory_buffer& out, const BusTimeline& timeline,
                          const TimeAxis& axis) {
  const auto& bins = timeline.traffic();
  const double width = timeline.bin_s() / axis.unit.seconds;
  uint64_t highest = 1;
  for (const TrafficBin& bin : bins) highest = std::max(highest, bin.trouble());
  PlotFrame frame = time_frame(timeline, axis);
  frame.y_ticks = round_ticks(0, static_cast<double>(highest), 4);
  frame.y_max = frame.y_ticks.back();
  frame.y_label = fmt::format("per {}", duration_text(timeline.bin_ns()));
  SvgPlot plot(out, std::move(frame), "time-outs, exceptions, bad checks and noise over time");
  for (size_t i = 0; i < bins.size(); ++i) {
    const double x0 = static_cast<double>(i) * width, x1 = x0 + width;
    double base = 0;
    for (auto [count, css] : {std::pair{bins[i].timeouts, "timeouts"},
                              {bins[i].exceptions, "exceptions"},
                              {bins[i].bad_checks, "bad"},
                              {bins[i].noise_records, "noise"}}) {
      plot.bar(x0, x1, base, base + static_cast<double>(count), css);
      base += static_cast<double>(count);
    }
  }
  plot.finish();
}

void append_timeline(fmt::memory_buffer& out, const BusTimeline& timeline, const TimeAxis& axis,
                     ClockQuality clock) {
  if (timeline.traffic().empty()) return;
  out.append(std::string_view("<h2>Over time</h2>\n"));
  if (clock == ClockQuality::none)
    out.append(std::string_view(
        "<p class=\"meta\">The capture has no clock: its times are nominal, the bytes laid end "
        "to end at the line's speed.</p>\n"));
  append_traffic_chart(out, timeline, axis);
  const auto& bins = timeline.traffic();
  if (std::none_of(bins.begin(), bins.end(), [](const TrafficBin& b) { return b.trouble() > 0; })) {
    out.append(std::string_view(
        "<p>No time-outs, exceptions, bad checks or noise in the whole capture.</p>\n"));
    return;
  }
  append_trouble_chart(out, timeline, axis);
  out.append(std::string_view(
      "<p class=\"legend\"><span class=\"timeouts\"></span>time-outs<span "
      "class=\"exceptions\"></span>exceptions<span class=\"bad\"></span>bad checks<span "
      "class=\"noise\"></span>noise records</p>\n"));
}

void append_outage_table(fmt::memory_buffer& out, const BusStatistics& s,
                         std::span<const Outage> outages) {
  auto put = fmt::appender(out);
  out.append(std::string_view(
      "<table><tr><th>slave</th><th class=\"text\">silent from</th><th>first unanswered "
      "record</th><th>time-outs</th><th class=\"text\">back at</th></tr>\n"));
  for (const Outage& outage : outages) {
    fmt::format_to(put,
                   "<tr><td>{}</td><td class=\"text\">{}</td><td>#{}</td><td>{}</td><td "
                   "class=\"text\">{}</td></tr>\n",
                   outage.slave, moment_text(s, outage.silent_from_ns), outage.first_request,
                   outage.timeouts,
                   outage.back_ns ? moment_text(s, *outage.back_ns) : "not by the end");
  }
  out.append(std::string_view("</table>\n"));
}

// The silences in the order they began: the first few in view, the rest folded.
void append_outages(fmt::memory_buffer& out, const BusStatistics& s) {
  constexpr size_t in_view = 10;
  if (s.outage_count() == 0) return;
  fmt::format_to(fmt::appender(out),
                 "<h2>Slaves that stopped answering</h2>\n<p><span "
                 "data-stat=\"outage_count\">{}</span> {} a slave left {} or more requests in "
                 "a row unanswered.</p>\n",
                 s.outage_count(), s.outage_count() == 1 ? "time" : "times", silent_after_timeouts);
  const std::span<const Outage> outages = s.outages();
  append_outage_table(out, s, outages.first(std::min(in_view, outages.size())));
  if (outages.size() > in_view) {
    fmt::format_to(fmt::appender(out), "<details><summary>{} more</summary>\n",
                   outages.size() - in_view);
    append_outage_table(out, s, outages.subspan(in_view));
    out.append(std::string_view("</details>\n"));
  }
  if (s.outage_count() > outages.size())
    fmt::format_to(fmt::appender(out), "<p class=\"meta\">The first {} are listed.</p>\n",
                   outages.size());
}

// The states a register took over time, as one band coloured by the state last read in each
// stretch (a state lasts until another is read), and a legend of the states' texts.
void append_state_band(fmt::memory_buffer& out, const BusTimeline& timeline, const TimeAxis& axis,
                       const FollowedSeries& series, const std::string& title) {
  std::map<double, size_t> colour;  // by value, in the order of the states' values
  for (const auto& [value, text] : series.states) colour.emplace(value, colour.size());
  std::vector<size_t> read;  // the bins that hold a reading
  for (size_t i = 0; i < series.bins.size(); ++i)
    if (series.bins[i].count && colour.count(series.bins[i].last)) read.push_back(i);
  PlotFrame frame = time_frame(timeline, axis);
  frame.height = 90;
  frame.y_label = "state";
  const double width = timeline.bin_s() / axis.unit.seconds;
  SvgPlot plot(out, std::move(frame), title);
  for (size_t r = 0; r < read.size();) {
    const double state = series.bins[read[r]].last;
    size_t next = r + 1;
    while (next < read.size() && series.bins[read[next]].last == state) ++next;
    const size_t end = next < read.size() ? read[next] : read[next - 1] + 1;
    plot.bar(static_cast<double>(read[r]) * width, static_cast<double>(end) * width, 0, 1,
             fmt::format("state-{}", colour[state] % state_colours));
    r = next;
  }
  plot.finish();
  out.append(std::string_view("<p class=\"legend\">"));
  for (const auto& [value, text] : series.states) {
    fmt::format_to(fmt::appender(out), "<span class=\"state-{}\"></span>",
                   colour[value] % state_colours);
    append_html(out, fmt::format("{} ({:g})", text, value));
  }
  out.append(std::string_view("</p>\n"));
}

// A register's values over time: the last in each stretch as a line, its range as a band, and a
// dot where a single reading gives no line.
void append_value_chart(fmt::memory_buffer& out, const BusTimeline& timeline, const TimeAxis& axis,
                        const FollowedSeries& series, const std::string& title) {
  const double width = timeline.bin_s() / axis.unit.seconds;
  std::vector<std::pair<double, double>> low, high, last;
  double lowest = INFINITY, highest = -INFINITY;
  for (size_t i = 0; i < series.bins.size(); ++i) {
    const ValueBin& bin = series.bins[i];
    if (!bin.count) continue;
    const double x = (static_cast<double>(i) + 0.5) * width;
    low.emplace_back(x, bin.min);
    high.emplace_back(x, bin.max);
    last.emplace_back(x, bin.last);
    lowest = std::min(lowest, bin.min);
    highest = std::max(highest, bin.max);
  }
  PlotFrame frame = time_frame(timeline, axis);
  if (highest - lowest < 1e-9) lowest -= 1, highest += 1;
  frame.y_ticks = round_ticks(lowest, highest, 4);
  frame.y_min = frame.y_ticks.front();
  frame.y_max = frame.y_ticks.back();
  frame.y_label = series.unit.empty() ? "value" : series.unit;
  SvgPlot plot(out, std::move(frame), title);
  plot.band(low, high, "value-band");
  plot.line(last, "value-line");
  if (last.size() == 1) plot.dot(last[0].first, last[0].second, "value-dot");
  plot.finish();
}

void append_followed_chart(fmt::memory_buffer& out, const BusTimeline& timeline,
                           const TimeAxis& axis, const RegisterKey& key,
                           const FollowedSeries& series, RegisterBase base) {
  uint64_t readings = 0;
  const ValueBin* latest = nullptr;
  for (const ValueBin& bin : series.bins) {
    readings += bin.count;
    if (bin.count) latest = &bin;
  }
  if (!latest) return;
  const std::string title = fmt::format("slave {} {} {}", key.slave,
                                        RegisterNumber{key.table, key.address, base}, series.name);
  out.append(std::string_view("<figure><figcaption>"));
  append_html(out, title);
  if (!series.unit.empty()) append_html(out, fmt::format(" ({})", series.unit));
  if (readings == 1) {
    const auto state = series.states.find(latest->last);
    append_html(out, fmt::format(": read once, {}", state == series.states.end()
                                                        ? fmt::format("{:g}", latest->last)
                                                        : state->second));
  }
  out.append(std::string_view("</figcaption>\n"));
  if (series.stateful && !series.states.empty()) {
    append_state_band(out, timeline, axis, series, title);
  } else {
    append_value_chart(out, timeline, axis, series, title);
  }
  out.append(std::string_view("</figure>\n"));
}

void append_followed(fmt::memory_buffer& out, const BusTimeline& timeline, const TimeAxis& axis,
                     const ReportInfo& info) {
  if (timeline.followed().empty() && info.unseen_follow.empty()) return;
  out.append(std::string_view(
      "<h2>Followed registers</h2>\n<p class=\"meta\">The line is the last value in each stretch "
      "of time; the band spans its lowest and highest. A register whose values have names is a "
      "band of its states: each lasts until another is read.</p>\n"));
  for (const auto& [key, series] : timeline.followed())
    append_followed_chart(out, timeline, axis, key, series, info.register_base);
  if (timeline.followed_not_kept())
    fmt::format_to(fmt::appender(out),
                   "<p class=\"meta\">Only the first {} followed registers are drawn.</p>\n",
                   BusTimeline::max_followed);
  for (const std::string& item : info.unseen_follow) {
    out.append(std::string_view("<p class=\"meta\">"));
    append_html(out, item);
    out.append(std::string_view(": followed, but no frame read or wrote it.</p>\n"));
  }
}

// A register's value as the page shows it: its last, or one end of its range in its unit.
std::string register_text(const LastValue& last, const RegisterKey& key,
                          std::optional<double> instead = std::nullopt) {
  RegisterValue reg = last.as_register(key.table, key.address);
  if (instead) {
    reg.value = *instead;
    reg.text = {};
  }
  fmt::memory_buffer text;
  append_value_text(text, reg);
  return fmt::to_string(text);
}

void append_text_cell(fmt::memory_buffer& out, std::string_view text) {
  out.append(std::string_view("<td class=\"text\">"));
  append_html(out, text);
  out.append(std::string_view("</td>"));
}

// One slave's named registers: those whose value moved, each with its range and how often it
// changed; then, folded, those that held one value throughout (a drive's parameters, read
// again and again, would otherwise fill the page).
void append_slave_registers(fmt::memory_buffer& out, uint8_t slave,
                            std::span<const std::pair<const RegisterKey*, const LastValue*>> regs,
                            RegisterBase base) {
  auto put = fmt::appender(out);
  const auto moved = [](const auto& reg) { return reg.second->changes > 0; };
  const auto held =
      static_cast<size_t>(std::count_if(regs.begin(), regs.end(), std::not_fn(moved)));
  fmt::format_to(put, "<h3>Slave {}</h3>\n", slave);
  if (held < regs.size()) {
    out.append(std::string_view(
        "<table><tr><th>address</th><th class=\"text\">register</th><th class=\"text\">last "
        "value</th><th class=\"text\">lowest</th><th class=\"text\">highest</th><th>changes</th>"
        "<th>reads</th></tr>\n"));
    for (const auto& [key, last] : regs) {
      if (!last->changes) continue;
      fmt::format_to(put, "<tr><td>{}</td>", RegisterNumber{key->table, key->address, base});
      append_text_cell(out, last->name);
      append_text_cell(out, register_text(*last, *key));
      const bool ranged = last->text.empty() && last->lowest <= last->highest;
      append_text_cell(out, ranged ? register_text(*last, *key, last->lowest) : "");
      append_text_cell(out, ranged ? register_text(*last, *key, last->highest) : "");
      fmt::format_to(put, "<td>{}</td><td>{}</td></tr>\n", last->changes, last->reads);
    }
    out.append(std::string_view("</table>\n"));
  }
  if (held == 0) return;
  // Open when there is little else to see of this slave.
  fmt::format_to(put, "<details{}><summary>{} that did not change</summary>\n",
                 held == regs.size() && held <= 12 ? " open" : "",
                 counted(held, "register", "registers"));
  out.append(std::string_view(
      "<table><tr><th>address</th><th class=\"text\">register</th><th class=\"text\">value</th>"
      "<th>reads</th></tr>\n"));
  for (const auto& [key, last] : regs) {
    if (last->changes) continue;
    fmt::format_to(put, "<tr><td>{}</td>", RegisterNumber{key->table, key->address, base});
    append_text_cell(out, last->name);
    append_text_cell(out, register_text(*last, *key));
    fmt::format_to(put, "<td>{}</td></tr>\n", last->reads);
  }
  out.append(std::string_view("</table>\n</details>\n"));
}

// The named registers' values, slave by slave: the drives' state as the master last saw it,
// and what moved while it watched.
void append_registers(fmt::memory_buffer& out, const BusStatistics& s, RegisterBase base) {
  constexpr size_t shown = 400;
  std::map<uint8_t, std::vector<std::pair<const RegisterKey*, const LastValue*>>> by_slave;
  size_t named = 0;
  for (const auto& [key, last] : s.registers) {
    if (last.name.empty()) continue;
    if (named++ < shown) by_slave[key.slave].emplace_back(&key, &last);
  }
  if (named == 0) return;
  out.append(std::string_view(
      "<h2>Register values</h2>\n<p class=\"meta\">As the bus last carried them: first those "
      "that changed while modtap listened, with the range of their values; then those that did "
      "not change.</p>\n"));
  for (const auto& [slave, regs] : by_slave) append_slave_registers(out, slave, regs, base);
  if (named > shown)
    fmt::format_to(fmt::appender(out),
                   "<p class=\"meta\">The first {} of {} named registers; every one is in the "
                   "statistics file (--stats).</p>\n",
                   shown, named);
}

// The lines of the records the problems cite, as `modtap -r` prints them, each a link target.
void append_cited_records(fmt::memory_buffer& out, std::span<const Problem> problems,
                          const CitedLines& lines) {
  std::set<uint64_t> cited;
  for (const Problem& p : problems)
    for (uint64_t index : p.first_records)
      if (lines.count(index)) cited.insert(index);
  if (cited.empty()) return;
  out.append(std::string_view(
      "<h2>The records behind the problems</h2>\n<p class=\"meta\">As <code>modtap -r</code> "
      "prints them, each after the request it answers; a time-out stands under the number of its "
      "request.</p>\n<pre "
      "class=\"records\">"));
  for (uint64_t index : cited) {
    std::string_view text = lines.at(index);
    while (!text.empty() && text.back() == '\n') text.remove_suffix(1);
    if (index != *cited.begin()) out.push_back('\n');
    fmt::format_to(fmt::appender(out), "<span id=\"record-{}\">", index);
    append_html(out, text);
    out.append(std::string_view("</span>\n"));
  }
  out.append(std::string_view("</pre>\n"));
}

}  // namespace

void append_report(fmt::memory_buffer& out, const BusStatistics& stats, const BusTimeline& timeline,
                   std::span<const Problem> problems, const CitedLines& cited,
                   const ReportInfo& info) {
  const TimeAxis axis = time_axis(timeline, stats);
  append_head(out, stats, info);
  append_problems(out, stats, problems, cited);
  append_summary(out, stats);
  append_findings(out, stats);
  append_slaves(out, stats, problems);
  append_timeline(out, timeline, axis, stats.clock());
  append_latency(out, stats);
  append_outages(out, stats);
  append_followed(out, timeline, axis, info);
  append_registers(out, stats, info.register_base);
  append_cited_records(out, problems, cited);
  out.append(std::string_view("<footer>modtap "));
  append_html(out, info.version);
  out.append(std::string_view(
      " · a passive listener: nothing on this page was asked of the bus, only heard on it."
      "</footer>\n</main></body></html>\n"));
}

}  // namespace modtap::output
