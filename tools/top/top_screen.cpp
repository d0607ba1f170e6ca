#include "tools/top/top_screen.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <tuple>
#include <utility>

#include <fmt/format.h>

namespace modtap::top {
namespace {

// Columns a UTF-8 text takes: every character here (the sparkline's blocks, arrows) takes one.
size_t columns_of(std::string_view text) {
  return static_cast<size_t>(
      std::count_if(text.begin(), text.end(), [](char c) { return (c & 0xC0) != 0x80; }));
}

// `text` cut or padded with spaces to exactly `width` columns.
std::string fit(std::string_view text, size_t width) {
  std::string out;
  size_t used = 0;
  for (size_t i = 0; i < text.size(); ++i) {
    const bool starts_character = (text[i] & 0xC0) != 0x80;
    if (starts_character && used == width) break;
    used += starts_character;
    out += text[i];
  }
  out.append(width - used, ' ');
  return out;
}

std::string right(std::string_view text, size_t width) {
  const size_t used = columns_of(text);
  return used >= width ? fit(text, width) : std::string(width - used, ' ') + std::string(text);
}

std::string count_text(uint64_t n) {
  return n >= 10'000'000 ? fmt::format("{}M", n / 1'000'000) : fmt::format("{}", n);
}

std::string ms_text(std::optional<double> ms) {
  if (!ms) return "-";
  return *ms < 10     ? fmt::format("{:.2f}", *ms)
         : *ms < 1000 ? fmt::format("{:.1f}", *ms)
                      : fmt::format("{:.0f}", *ms);
}

std::string age_text(int64_t ns) {
  const int64_t s = std::max<int64_t>(0, ns / 1'000'000'000);
  if (s < 100) return fmt::format("{}s", s);
  if (s < 6000) return fmt::format("{}m", s / 60);
  return fmt::format("{}h", s / 3600);
}

double severity_rank(const SlaveRow& row) {
  return row.problem.empty() ? -1.0 : static_cast<double>(row.severity);
}

// One column of the slave table: its title, width (0: the rest of the line), what a cell shows,
// and the number it sorts by (higher is worse or more where that reads naturally).
struct ColumnSpec {
  std::string_view title;
  size_t width;
  bool align_right;
  std::string (*cell)(const SlaveRow&, int64_t now_ns);
  double (*key)(const SlaveRow&);
};

constexpr std::array<ColumnSpec, column_count> columns{{
    {"slave", 5, true, [](const SlaveRow& r, int64_t) { return fmt::format("{}", r.address); },
     [](const SlaveRow& r) { return double(r.address); }},
    {"model", 7, false, [](const SlaveRow& r, int64_t) { return r.model.empty() ? "-" : r.model; },
     nullptr},
    {"reqs", 6, true, [](const SlaveRow& r, int64_t) { return count_text(r.requests); },
     [](const SlaveRow& r) { return double(r.requests); }},
    {"ans%", 4, true,
     [](const SlaveRow& r, int64_t) {
       const auto share = r.answered_percent();
       return share ? fmt::format("{:.0f}", std::floor(*share)) : std::string("-");
     },
     [](const SlaveRow& r) { return r.answered_percent().value_or(101.0); }},
    {"t/o", 4, true, [](const SlaveRow& r, int64_t) { return count_text(r.timeouts); },
     [](const SlaveRow& r) { return double(r.timeouts); }},
    {"retry", 5, true, [](const SlaveRow& r, int64_t) { return count_text(r.retries); },
     [](const SlaveRow& r) { return double(r.retries); }},
    {"exc", 4, true, [](const SlaveRow& r, int64_t) { return count_text(r.exceptions); },
     [](const SlaveRow& r) { return double(r.exceptions); }},
    {"bad", 4, true, [](const SlaveRow& r, int64_t) { return count_text(r.bad_checks); },
     [](const SlaveRow& r) { return double(r.bad_checks); }},
    {"p50ms", 5, true, [](const SlaveRow& r, int64_t) { return ms_text(r.p50_ms); },
     [](const SlaveRow& r) { return r.p50_ms.value_or(-1); }},
    {"p99ms", 5, true, [](const SlaveRow& r, int64_t) { return ms_text(r.p99_ms); },
     [](const SlaveRow& r) { return r.p99_ms.value_or(-1); }},
    {"seen", 4, true,
     [](const SlaveRow& r, int64_t now) {
       return r.last_answer_ns ? age_text(now - *r.last_answer_ns) : std::string("-");
     },
     [](const SlaveRow& r) {  // higher: silent for longer, or never heard
       return r.last_answer_ns ? -double(*r.last_answer_ns) : 1e30;
     }},
    {"problem", 0, false, [](const SlaveRow& r, int64_t) { return r.problem; }, severity_rank},
}};

const ColumnSpec& spec(Column column) {
  return columns[static_cast<size_t>(column)];
}

// A row of the table, or its heading (no row); `sorted` gets where the sorted column is.
std::string table_line(const SlaveRow* row, Column sort, int64_t now_ns, size_t width,
                       std::pair<size_t, size_t>* sorted = nullptr) {
  std::string line;
  for (size_t i = 0; i < column_count; ++i) {
    const ColumnSpec& c = columns[i];
    const size_t room = c.width ? c.width : width > line.size() ? width - line.size() : 0;
    if (sorted && static_cast<size_t>(sort) == i) *sorted = {line.size(), room};
    const std::string text = row ? c.cell(*row, now_ns) : std::string(c.title);
    line += c.align_right ? right(text, room) : fit(text, room);
    if (c.width) line += ' ';
  }
  return line;
}

Look look_of(const SlaveRow& row) {
  if (row.problem.empty()) return Look::plain;
  return row.severity == Severity::error ? Look::error : Look::warning;
}

Look look_of(Severity severity) {
  return severity == Severity::error ? Look::error : Look::warning;
}

std::string duration_text(double s) {
  const auto total = static_cast<int64_t>(s);
  return fmt::format("{}:{:02}:{:02}", total / 3600, total / 60 % 60, total % 60);
}

std::string numbers_line(const Snapshot& s) {
  const std::string load =
      s.bus_load ? fmt::format("load {:.0f}%", 100 * *s.bus_load) : std::string("load -");
  return fmt::format("up {}  {:.0f} frames/s  {}  {} frames  {} bad checks  {} noise ({} B)",
                     duration_text(s.running_s), s.frames_per_s, load, s.frames, s.bad_checks,
                     s.noise_records, s.noise_bytes);
}

std::string status_line(const Snapshot& s, const ViewState& view) {
  if (view.typing) return "filter (-Y syntax, Enter to apply, empty to clear): " + *view.typing;
  std::vector<std::string> parts;
  if (view.paused) parts.push_back("PAUSED (p: resume)");
  if (!view.message.empty()) parts.push_back(view.message);
  if (!s.filter.empty()) parts.push_back("filter: " + s.filter);
  if (!s.writing.empty()) parts.push_back(s.writing);
  parts.push_back(
      fmt::format("sorted by {}{}", column_title(view.sort), view.descending ? ", down" : ""));
  std::string line;
  for (const auto& part : parts) line += (line.empty() ? "" : "  |  ") + part;
  return line;
}

constexpr std::string_view help_text[] = {
    "keys",
    "  up/down, j/k   choose a slave in the table",
    "  Enter          show only that slave's transactions and registers",
    "  Esc            show every slave again",
    "  < >            sort by the column left or right of the current one",
    "  r              reverse the sort",
    "  p, space       pause the screen (the capture goes on)",
    "  /              a display filter for the transactions (-Y syntax)",
    "  w              start or stop writing what follows to a pcapng file",
    "  ?              this help; any key closes it",
    "  q              quit",
    "",
    "A row's colour is its slave's worst problem: red an error, yellow a warning.",
    "ans% answers in time to requests (late ones are time-outs), t/o time-outs, exc",
    "exceptions, bad bad checks and garbled answers, p50ms p99ms the latency from a",
    "request's end to its answer's start, seen how long ago the slave last answered.",
};

constexpr std::string_view footer =
    "q quit  ? help  up/down choose  Enter slave  < > sort  r reverse  p pause  / filter  "
    "w write";

struct Lines {
  std::vector<ScreenLine> lines;
  size_t width, height;

  size_t left() const { return height > lines.size() ? height - lines.size() : 0; }
  void add(std::string_view text, Look look = Look::plain) {
    if (lines.size() < height) lines.push_back({fit(text, width), look});
  }
};

// The table's rows on screen: as many as `room`, scrolled so that the cursor shows.
void add_table(Lines& out, const Snapshot& s, const ViewState& view, size_t room) {
  std::pair<size_t, size_t> sorted;
  out.add(table_line(nullptr, view.sort, s.now_ns, out.width, &sorted), Look::heading);
  if (!out.lines.empty())
    std::tie(out.lines.back().mark_begin, out.lines.back().mark_width) = sorted;
  if (s.slaves.empty()) {
    out.add("  no slave seen yet", Look::dim);
    return;
  }
  // Rows that do not fit are said, on a line of their own, above or below those shown.
  const size_t rows = s.slaves.size() <= room ? room : std::max<size_t>(1, room - 1);
  const size_t cursor = std::min(view.cursor, s.slaves.size() - 1);
  const size_t first = cursor >= rows ? cursor - rows + 1 : 0;
  const size_t last = std::min(s.slaves.size(), first + rows);
  for (size_t i = first; i < last; ++i) {
    const bool selected = i == cursor;
    out.add(table_line(&s.slaves[i], view.sort, s.now_ns, out.width),
            selected ? Look::selected : look_of(s.slaves[i]));
  }
  if (first > 0 || last < s.slaves.size())
    out.add(fmt::format("  {} more slaves: {} above, {} below (up/down)",
                        s.slaves.size() - (last - first), first, s.slaves.size() - last),
            Look::dim);
}

// The problems of the slave the cursor is on first, so the arrow keys bring any slave's into
// view; then the others, newest first. Those that do not fit are counted.
void add_problems(Lines& out, const Snapshot& s, const ViewState& view, size_t room) {
  out.add(fmt::format("problems ({})", s.problems.size()), Look::heading);
  if (s.problems.empty()) out.add("  none seen", Look::dim);
  std::vector<const ProblemLine*> order;
  for (const ProblemLine& p : s.problems) order.push_back(&p);
  if (!s.slaves.empty()) {
    const uint8_t on = s.slaves[std::min(view.cursor, s.slaves.size() - 1)].address;
    std::stable_partition(order.begin(), order.end(),
                          [on](const ProblemLine* p) { return p->slave == on; });
  }
  const size_t shown = order.size() <= room ? order.size() : std::max<size_t>(1, room - 1);
  for (size_t i = 0; i < shown; ++i) out.add("  " + order[i]->text, look_of(order[i]->severity));
  if (shown < order.size())
    out.add(fmt::format("  +{} more (up/down on a slave's row shows its own first)",
                        order.size() - shown),
            Look::dim);
}

void add_panel(Lines& out, const Snapshot& s, const ViewState& view) {
  if (!s.registers.empty()) {
    out.add(view.chosen ? fmt::format("registers of slave {}", *view.chosen) : "followed registers",
            Look::heading);
    const size_t room = std::max<size_t>(1, out.left() / 2);
    size_t name_width = 0;
    for (const auto& reg : s.registers) name_width = std::max(name_width, columns_of(reg.name));
    name_width = std::min<size_t>(name_width, 24);
    for (size_t i = 0; i < s.registers.size() && i < room; ++i) {
      const RegisterLine& reg = s.registers[i];
      std::string line = "  " + fit(reg.name, name_width) + "  " + right(reg.value, 18);
      if (reg.history.size() > 1) line += "  " + sparkline(reg.history, 40, view.unicode);
      out.add(line);
    }
  }
  out.add(view.chosen ? fmt::format("transactions of slave {} (Esc: every slave)", *view.chosen)
                      : std::string("latest transactions"),
          Look::heading);
  const size_t room = out.left();
  const size_t shown = std::min(room, s.transactions.size());
  for (size_t i = s.transactions.size() - shown; i < s.transactions.size(); ++i)
    out.add(s.transactions[i]);
}

}  // namespace

std::optional<double> SlaveRow::answered_percent() const {
  if (requests == 0) return std::nullopt;
  return 100.0 * static_cast<double>(std::min(answered_in_time, requests)) /
         static_cast<double>(requests);
}

std::string_view column_title(Column column) {
  return spec(column).title;
}

void sort_rows(std::vector<SlaveRow>& rows, Column by, bool descending) {
  const ColumnSpec& c = spec(by);
  std::stable_sort(rows.begin(), rows.end(), [&](const SlaveRow& a, const SlaveRow& b) {
    const bool less = c.key ? c.key(a) < c.key(b) : a.model < b.model;
    const bool greater = c.key ? c.key(b) < c.key(a) : b.model < a.model;
    if (!less && !greater) return a.address < b.address;
    return descending ? greater : less;
  });
}

std::string sparkline(const std::vector<double>& values, size_t width, bool unicode) {
  static constexpr std::array<std::string_view, 8> blocks{"▁", "▂", "▃", "▄", "▅", "▆", "▇", "█"};
  static constexpr std::string_view ascii = "_.-=+*#@";
  if (values.empty() || width == 0) return {};
  const size_t first = values.size() > width ? values.size() - width : 0;
  const auto [low, high] = std::minmax_element(values.begin() + first, values.end());
  const double span = *high - *low;
  std::string out;
  for (size_t i = first; i < values.size(); ++i) {
    const size_t level =
        span > 0 ? std::min<size_t>(7, static_cast<size_t>((values[i] - *low) / span * 7.999)) : 3;
    out += unicode ? blocks[level] : std::string_view(&ascii[level], 1);
  }
  return out;
}

std::vector<ScreenLine> lay_out(const Snapshot& s, const ViewState& view, size_t width,
                                size_t height) {
  const bool footer_shown = view.keys && height > 0;
  Lines out{{}, width, footer_shown ? height - 1 : height};
  out.add(fmt::format("modtap top  {}  {}  {}  clock {}", s.state, s.source, s.settings, s.clock),
          Look::title);
  out.add(numbers_line(s));
  if (s.problems.empty())
    out.add("latest problem: none", Look::dim);
  else
    out.add("latest problem: " + s.problems.front().text, look_of(s.problems.front().severity));
  out.add(status_line(s, view), view.typing ? Look::selected : Look::plain);
  if (view.help) {
    for (std::string_view line : help_text) out.add(line);
  } else {
    const size_t body = out.left();
    add_table(out, s, view, std::max<size_t>(2, body * 2 / 5));
    add_problems(out, s, view, std::max<size_t>(1, body / 5));
    add_panel(out, s, view);
  }
  while (out.lines.size() < out.height) out.add("");
  if (footer_shown) out.lines.push_back({fit(footer, width), Look::dim});
  return std::move(out.lines);
}

}  // namespace modtap::top
