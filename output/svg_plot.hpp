// Charts for the report as inline SVG: a plot area with axes, ticks at round numbers, bars,
// lines and bands, styled by CSS classes the page defines. A report is read offline and mailed
// on, so it draws its charts itself rather than load a charting script.
#pragma once

#include <functional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <fmt/format.h>

namespace modtap::output {

// Round tick values (1, 2 or 5 times a power of ten apart) from `low` to at least `high`; the
// last tick is where an axis that must show `high` ends.
std::vector<double> round_ticks(double low, double high, int about = 5);
// Ticks for a logarithmic axis: 1, 2 and 5 times the powers of ten within [low, high], or only
// the powers of ten over a range of more than a thousand.
std::vector<double> log_ticks(double low, double high);

// A tick's number as a person writes it: no exponent, and no more decimals than it has
// (1500000, 0.25, 49.5).
std::string plain_number(double value);

struct PlotFrame {
  double width = 880, height = 220;
  double x_min = 0, x_max = 1;
  double y_min = 0, y_max = 1;
  bool x_log = false;
  std::vector<double> x_ticks, y_ticks;
  std::string x_label, y_label;
  std::function<std::string(double)> x_tick_text = plain_number;
  std::function<std::string(double)> y_tick_text = plain_number;
};

// One chart: the constructor opens the <svg> and draws the axes, finish() closes it.
class SvgPlot {
 public:
  SvgPlot(fmt::memory_buffer& out, PlotFrame frame, std::string_view title);
  void bar(double x0, double x1, double y0, double y1, std::string_view css_class);
  void line(const std::vector<std::pair<double, double>>& points, std::string_view css_class);
  // The area between `low` and `high`, drawn over the same x values.
  void band(const std::vector<std::pair<double, double>>& low,
            const std::vector<std::pair<double, double>>& high, std::string_view css_class);
  // A round mark at a point: a value read once, which no line joins to another.
  void dot(double x, double y, std::string_view css_class);
  // A dashed vertical line at x, labelled at its top (a percentile on a histogram).
  void marker(double x, std::string_view label);
  void finish();

 private:
  // The widest a character of the ticks' font (11 px) draws: DejaVu Sans's digits are 0.64 em.
  static constexpr double char_width = 7.2;
  static constexpr double right = 16, top = 12, bottom = 40;
  static constexpr double y_label_space = 24;  // the rotated y label, left of the tick labels
  // Charts whose tick labels are short all start their plot here, so stacked ones line up.
  static constexpr double least_left = 64;
  // A tick's text centred at x, moved in as far as it must to stay inside the chart.
  double fit_centred(double x, std::string_view text) const;
  double to_x(double x) const;
  double to_y(double y) const;
  void axes();

  fmt::memory_buffer& out_;
  PlotFrame frame_;
  double left_;  // room for the y axis's label and its widest tick label
};

// Text for HTML: & < > " escaped.
void append_html(fmt::memory_buffer& out, std::string_view text);

}  // namespace modtap::output
