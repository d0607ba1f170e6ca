#include "output/svg_plot.hpp"

#include <gtest/gtest.h>

#include <regex>
#include <string>

namespace modtap::output {
namespace {

TEST(PlainNumber, WritesATickAsAPersonDoes) {
  EXPECT_EQ(plain_number(1'500'000), "1500000");
  EXPECT_EQ(plain_number(0.25), "0.25");
  EXPECT_EQ(plain_number(0.1 + 0.2), "0.3");
  EXPECT_EQ(plain_number(-0.0), "0");
  EXPECT_EQ(plain_number(-32768), "-32768");
  EXPECT_EQ(plain_number(49.95), "49.95");
}

struct TickText {
  double x;
  std::string anchor, text;
};

std::vector<TickText> ticks(const std::string& svg) {
  std::vector<TickText> found;
  const std::regex tick(
      R"re(<text class="tick" x="([-0-9.]+)" y="[-0-9.]+" text-anchor="(\w+)">([^<]*)</text>)re");
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), tick); it != std::sregex_iterator();
       ++it)
    found.push_back({std::stod((*it)[1]), (*it)[2], (*it)[3]});
  return found;
}

// Long tick labels (a counter's millions, a clock time at the right end, a marker at the edge)
// stay inside the chart, and the y labels clear the rotated axis title left of them.
TEST(SvgPlot, EveryTickLabelFitsInsideTheChart) {
  PlotFrame frame;
  frame.width = 440;
  frame.x_min = 0;
  frame.x_max = 60;
  frame.x_ticks = {0, 20, 40, 60};
  frame.x_tick_text = [](double x) { return fmt::format("22:14:{:02.0f}.000", x); };
  frame.y_ticks = round_ticks(-1'234'567, 1'500'000, 4);
  frame.y_min = frame.y_ticks.front();
  frame.y_max = frame.y_ticks.back();
  frame.y_label = "count";
  fmt::memory_buffer out;
  SvgPlot plot(out, frame, "a counter");
  plot.marker(60, "p99 marker");
  plot.finish();
  const auto texts = ticks(fmt::to_string(out));
  ASSERT_EQ(texts.size(), frame.x_ticks.size() + frame.y_ticks.size() + 1);
  constexpr double char_width = 7.2, y_title_right = 18;  // DejaVu Sans at 11 px; x=12 ± 6
  for (const TickText& t : texts) {
    const double width = static_cast<double>(t.text.size()) * char_width;
    const double from = t.anchor == "end" ? t.x - width : t.x - width / 2;
    EXPECT_GE(from, t.anchor == "end" ? y_title_right : 0.0) << t.text;
    EXPECT_LE(from + width, frame.width) << t.text;
    EXPECT_FALSE(std::regex_search(t.text, std::regex("[0-9]e[-+]"))) << t.text;  // no exponent
  }
}

}  // namespace
}  // namespace modtap::output
