#include "tools/top/top_screen.hpp"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

namespace modtap::top {
namespace {

size_t columns_of(const std::string& text) {
  return static_cast<size_t>(
      std::count_if(text.begin(), text.end(), [](char c) { return (c & 0xC0) != 0x80; }));
}

SlaveRow row(uint8_t address, uint64_t requests, uint64_t timeouts) {
  SlaveRow r;
  r.address = address;
  r.model = "nta5000";
  r.requests = requests;
  r.answered_in_time = requests - timeouts;
  r.timeouts = timeouts;
  r.p50_ms = 3.1;
  r.p99_ms = 4.9;
  return r;
}

Snapshot bus() {
  Snapshot s;
  s.source = "port /dev/ttyUSB0";
  s.settings = "19200 8E1, as given";
  s.clock = "per-chunk";
  s.state = "live";
  s.frames = 1200;
  s.slaves = {row(1, 100, 0), row(2, 100, 3), row(3, 100, 100)};
  s.slaves[2].problem = "no-response";
  s.slaves[2].severity = Severity::error;
  s.problems = {{Severity::error, 0, "Slave 3 never answers: 100 requests, all timed out", 3}};
  for (int i = 0; i < 50; ++i) s.transactions.push_back("line " + std::to_string(i));
  return s;
}

const ScreenLine* line_starting(const std::vector<ScreenLine>& lines, const std::string& start) {
  for (const auto& line : lines)
    if (line.text.rfind(start, 0) == 0) return &line;
  return nullptr;
}

TEST(TopScreen, FillsTheTerminalExactlyWhateverItsSize) {
  for (const auto& [width, height] :
       {std::pair<size_t, size_t>{80, 24}, {132, 40}, {40, 10}, {20, 3}, {200, 60}}) {
    const auto lines = lay_out(bus(), {}, width, height);
    ASSERT_EQ(lines.size(), height) << width << "x" << height;
    for (const auto& line : lines) EXPECT_EQ(columns_of(line.text), width) << line.text;
  }
}

TEST(TopScreen, ALargerTerminalShowsMoreOfThePanel) {
  const auto small = lay_out(bus(), {}, 80, 24);
  const auto large = lay_out(bus(), {}, 80, 50);
  const auto count = [](const auto& lines) {
    return std::count_if(lines.begin(), lines.end(),
                         [](const ScreenLine& l) { return l.text.rfind("line ", 0) == 0; });
  };
  EXPECT_GT(count(large), count(small));
  // The newest line is the panel's last, at any size.
  EXPECT_EQ(line_starting(small, "line 49") != nullptr, true);
  EXPECT_EQ(line_starting(large, "line 49") != nullptr, true);
}

TEST(TopScreen, AFaultySlavesRowNamesItsProblemInItsColour) {
  const auto lines = lay_out(bus(), ViewState{}, 100, 24);
  const ScreenLine* faulty = line_starting(lines, "    3 nta5000");
  ASSERT_NE(faulty, nullptr);
  EXPECT_NE(faulty->text.find("no-response"), std::string::npos);
  EXPECT_EQ(faulty->look, Look::error);
  const ScreenLine* healthy = line_starting(lines, "    2 nta5000");
  ASSERT_NE(healthy, nullptr);
  EXPECT_EQ(healthy->look, Look::plain);
  EXPECT_EQ(line_starting(lines, "    1 nta5000")->look, Look::selected);  // the cursor's row
  EXPECT_NE(line_starting(lines, "latest problem: Slave 3 never answers"), nullptr);
}

TEST(TopScreen, SeenCountsFromASlavesLastAnswerAndSaysNeverWithADash) {
  Snapshot s = bus();
  s.now_ns = 100'000'000'000;
  s.slaves[0].last_answer_ns = 75'000'000'000;
  s.slaves[1].last_answer_ns = 100'000'000'000;
  const auto lines = lay_out(s, ViewState{}, 100, 24);
  const auto seen = [&](const char* start) {
    const std::string& text = line_starting(lines, start)->text;
    std::istringstream cells(text);
    std::vector<std::string> words{std::istream_iterator<std::string>(cells), {}};
    return words.at(10);
  };
  EXPECT_EQ(seen("    1 nta5000"), "25s");
  EXPECT_EQ(seen("    2 nta5000"), "0s");
  EXPECT_EQ(seen("    3 nta5000"), "-");
}

TEST(TopScreen, SortsByAColumnEitherWayWithTheAddressBreakingTies) {
  auto rows = bus().slaves;
  rows.push_back(row(4, 100, 3));
  sort_rows(rows, Column::timeouts, true);
  std::vector<int> order;
  for (const auto& r : rows) order.push_back(r.address);
  EXPECT_EQ(order, (std::vector<int>{3, 2, 4, 1}));
  sort_rows(rows, Column::answered, false);
  order.clear();
  for (const auto& r : rows) order.push_back(r.address);
  EXPECT_EQ(order, (std::vector<int>{3, 2, 4, 1}));
  sort_rows(rows, Column::slave, false);
  EXPECT_EQ(rows.front().address, 1);
}

TEST(TopScreen, TheSortedColumnsTitleIsMarked) {
  ViewState view;
  view.sort = Column::timeouts;
  const auto lines = lay_out(bus(), view, 80, 24);
  const ScreenLine* heading = line_starting(lines, "slave");
  ASSERT_NE(heading, nullptr);
  ASSERT_GT(heading->mark_width, 0u);
  const std::string marked = heading->text.substr(heading->mark_begin, heading->mark_width);
  EXPECT_EQ(marked.substr(marked.find_first_not_of(' ')), "t/o");
  EXPECT_NE(lines[3].text.find("sorted by t/o"), std::string::npos);
}

TEST(TopScreen, TheCursorsRowStaysOnScreenInALongTable) {
  Snapshot s = bus();
  s.slaves.clear();
  for (uint8_t a = 1; a <= 60; ++a) s.slaves.push_back(row(a, 10, 0));
  ViewState view;
  view.cursor = 59;
  const auto lines = lay_out(s, view, 80, 24);
  const auto selected = std::find_if(lines.begin(), lines.end(),
                                     [](const ScreenLine& l) { return l.look == Look::selected; });
  ASSERT_NE(selected, lines.end());
  EXPECT_EQ(selected->text.rfind("   60 ", 0), 0u) << selected->text;
}

// At 80x24 a table of 60 slaves shows some: a line says how many more there are, on which side,
// and the arrow keys bring them.
TEST(TopScreen, RowsThatDoNotFitAreCountedAboveAndBelow) {
  Snapshot s = bus();
  s.slaves.clear();
  for (uint8_t a = 1; a <= 60; ++a) s.slaves.push_back(row(a, 10, 0));
  ViewState view;
  for (const size_t cursor : {size_t{0}, size_t{30}, size_t{59}}) {
    view.cursor = cursor;
    const auto lines = lay_out(s, view, 80, 24);
    size_t rows = 0;
    for (const auto& line : lines)
      rows += line.text.rfind("   ", 0) == 0 && line.text.size() > 5 &&
              std::isdigit(static_cast<unsigned char>(line.text[4]));
    const ScreenLine* more = nullptr;
    for (const auto& line : lines)
      if (line.text.find(" more slaves: ") != std::string::npos) more = &line;
    ASSERT_NE(more, nullptr);
    int above = -1, below = -1, hidden = -1;
    ASSERT_EQ(std::sscanf(more->text.c_str(), " %d more slaves: %d above, %d below", &hidden,
                          &above, &below),
              3)
        << more->text;
    EXPECT_EQ(static_cast<size_t>(hidden) + rows, 60u) << more->text;
    EXPECT_EQ(above + below, hidden);
    EXPECT_EQ(above == 0, cursor == 0) << more->text;
    EXPECT_EQ(below == 0, cursor == 59) << more->text;
  }
  // All of them fit on a tall terminal: no such line.
  for (const auto& line : lay_out(s, view, 80, 200))
    EXPECT_EQ(line.text.find(" more slaves: "), std::string::npos);
}

// More problems than fit: the count of the others, and the cursor's slave's own first.
TEST(TopScreen, TheCursorsSlavesProblemsComeFirstAndTheRestAreCounted) {
  Snapshot s = bus();
  s.problems.clear();
  for (uint8_t a = 1; a <= 3; ++a)
    for (int k = 0; k < 4; ++k)
      s.problems.push_back({Severity::warning, 0, fmt::format("Slave {} problem {}", a, k), a});
  ViewState view;
  view.cursor = 2;  // slave 3
  const auto lines = lay_out(s, view, 80, 24);
  const auto heading = std::find_if(lines.begin(), lines.end(), [](const ScreenLine& l) {
    return l.text.rfind("problems (12)", 0) == 0;
  });
  ASSERT_NE(heading, lines.end());
  EXPECT_EQ(heading[1].text.rfind("  Slave 3 problem 0", 0), 0u) << heading[1].text;
  const auto more = std::find_if(heading, lines.end(), [](const ScreenLine& l) {
    return l.text.rfind("  +", 0) == 0 && l.text.find(" more ") != std::string::npos;
  });
  ASSERT_NE(more, lines.end());
  const size_t shown = static_cast<size_t>(more - heading) - 1;
  EXPECT_EQ(more->text.rfind(fmt::format("  +{} more", 12 - shown), 0), 0u) << more->text;
}

TEST(TopScreen, AChosenSlaveShowsItsRegistersAndTransactions) {
  Snapshot s = bus();
  s.registers = {{"frequency_command", "50.00 Hz", {}}, {"status", "Run, Forward", {}}};
  ViewState view;
  view.chosen = 3;
  const auto lines = lay_out(s, view, 80, 30);
  EXPECT_NE(line_starting(lines, "registers of slave 3"), nullptr);
  EXPECT_NE(line_starting(lines, "transactions of slave 3"), nullptr);
  const ScreenLine* frequency = line_starting(lines, "  frequency_command");
  ASSERT_NE(frequency, nullptr);
  EXPECT_NE(frequency->text.find("50.00 Hz"), std::string::npos);
}

TEST(TopScreen, PlainTextHasNoKeysToName) {
  ViewState view;
  view.keys = false;
  const auto lines = lay_out(bus(), view, 80, 24);
  EXPECT_EQ(lines.size(), 24u);
  EXPECT_EQ(line_starting(lines, "q quit"), nullptr);
  EXPECT_NE(line_starting(lay_out(bus(), {}, 80, 24), "q quit"), nullptr);
}

TEST(TopScreen, TheHelpNamesEveryKey) {
  ViewState view;
  view.help = true;
  std::string all;
  for (const auto& line : lay_out(bus(), view, 80, 30)) all += line.text + "\n";
  for (const char* key : {"up/down", "Enter", "Esc", "< >", "r ", "p, space", "/", "w", "q"})
    EXPECT_NE(all.find(key), std::string::npos) << key;
}

TEST(Sparkline, ScalesValuesIntoRisingBarsTheNewestLast) {
  EXPECT_EQ(sparkline({0, 1, 2, 3, 4, 5, 6, 7}, 8, true), "▁▂▃▄▅▆▇█");
  EXPECT_EQ(sparkline({0, 7}, 8, false), "_@");
  EXPECT_EQ(sparkline({5, 5, 5}, 8, false), "===");   // flat: the middle
  EXPECT_EQ(sparkline({100, 0, 7}, 2, false), "_@");  // the newest two, scaled by themselves
  EXPECT_EQ(sparkline({}, 8, true), "");
}

}  // namespace
}  // namespace modtap::top
