// What `modtap top` shows, as lines: a snapshot of the bus (the statistics, the problems and
// the latest records, taken once a second) laid out for a terminal of any size. Pure: the
// curses screen and the plain-text fallback (top_view.hpp) only draw these lines.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "decoder/protocol/findings.hpp"

namespace modtap::top {

// The slave table's columns, in the order they show.
enum class Column : uint8_t {
  slave,
  model,
  requests,
  answered,
  timeouts,
  retries,
  exceptions,
  bad_checks,
  p50,
  p99,
  last_seen,
  problem,
};
inline constexpr size_t column_count = 12;

struct SlaveRow {
  uint8_t address = 0;
  std::string model;
  uint64_t requests = 0, timeouts = 0, retries = 0, exceptions = 0, bad_checks = 0;
  uint64_t answered_in_time = 0;          // answers the master got: late ones are time-outs to it
  std::optional<double> p50_ms, p99_ms;   // none: no latency measured
  std::optional<int64_t> last_answer_ns;  // none: it never answered
  std::string problem;  // the worst problem's kind (problem_info's name); empty: none
  Severity severity = Severity::note;

  std::optional<double> answered_percent() const;
};

struct ProblemLine {
  Severity severity = Severity::warning;
  int64_t since_ns = 0;
  std::string text;
  std::optional<uint8_t> slave;  // none: the bus's
};

// A register's last value; for a followed one, its values at the snapshots before.
struct RegisterLine {
  std::string name, value;  // value with its unit and text
  std::vector<double> history;
};

struct Snapshot {
  std::string source;    // the port or the file
  std::string settings;  // "19200 8E1, as given"
  std::string clock;     // how the source times bytes
  std::string state;     // "live", "replay x4", "end of capture"
  double running_s = 0;
  double frames_per_s = 0;
  std::optional<double> bus_load;  // 0-1; none without a clock
  uint64_t frames = 0, bad_checks = 0, noise_records = 0, noise_bytes = 0;
  std::vector<SlaveRow> slaves;
  std::vector<ProblemLine> problems;      // newest first
  std::vector<std::string> transactions;  // oldest first
  std::vector<RegisterLine> registers;    // --follow's, or the chosen slave's
  std::string writing;                    // the `w` file and its packets; empty: none
  std::string filter;                     // the `/` filter; empty: none
  int64_t now_ns = 0;                     // the latest record's time: "seen" counts back to it
};

// What the person at the keyboard chose.
struct ViewState {
  Column sort = Column::slave;
  bool descending = false;
  size_t cursor = 0;              // the table row the arrow keys are on
  std::optional<uint8_t> chosen;  // Enter: the panel shows this slave only
  bool paused = false;
  bool help = false;
  std::optional<std::string> typing;  // the `/` prompt's text while it is typed
  std::string message;                // feedback on the last key (a filter's error, a file)
  bool unicode = true;                // the terminal speaks UTF-8: block sparklines
  bool keys = true;                   // keys are read: a footer names them
};

enum class Look : uint8_t { plain, title, heading, selected, warning, error, dim };
struct ScreenLine {
  std::string text;
  Look look = Look::plain;
  size_t mark_begin = 0, mark_width = 0;  // columns shown reversed: the sorted column's title
};

void sort_rows(std::vector<SlaveRow>& rows, Column by, bool descending);
// The screen: exactly `height` lines of at most `width` columns.
std::vector<ScreenLine> lay_out(const Snapshot& snapshot, const ViewState& view, size_t width,
                                size_t height);
// `values` scaled into `width` characters of rising bars, the newest last: block elements
// when the terminal speaks UTF-8, else ASCII.
std::string sparkline(const std::vector<double>& values, size_t width, bool unicode);
std::string_view column_title(Column column);

}  // namespace modtap::top
