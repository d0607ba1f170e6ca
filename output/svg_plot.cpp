#include "output/svg_plot.hpp"

#include <algorithm>
#include <cmath>

namespace modtap::output {

std::vector<double> round_ticks(double low, double high, int about) {
  if (!(high > low)) high = low + 1;
  const double raw = (high - low) / about;
  const double power = std::pow(10.0, std::floor(std::log10(raw)));
  const double mantissa = raw / power;
  const double step = (mantissa < 1.5 ? 1 : mantissa < 3 ? 2 : mantissa < 7 ? 5 : 10) * power;
  std::vector<double> ticks;
  const double first = std::floor(low / step) * step;
  for (double t = first;; t += step) {
    ticks.push_back(std::abs(t) < step * 1e-9 ? 0 : t);  // no "-0" from rounding
    if (t >= high - step * 1e-9) break;
  }
  return ticks;
}

std::string plain_number(double value) {
  for (int decimals = 0; decimals < 6; ++decimals) {
    const double scale = std::pow(10.0, decimals);
    if (std::abs(std::round(value * scale) - value * scale) < 1e-6 * scale)
      return fmt::format("{:.{}f}", value == 0 ? 0.0 : value, decimals);  // no "-0"
  }
  return fmt::format("{:.6f}", value);
}

std::vector<double> log_ticks(double low, double high) {
  std::vector<double> ticks;
  // Over more than three powers of ten, 2 and 5 would crowd the labels.
  const std::vector<double> steps =
      high / low > 1000 ? std::vector{1.0} : std::vector{1.0, 2.0, 5.0};
  for (double power = std::pow(10.0, std::floor(std::log10(low))); power <= high; power *= 10)
    for (double m : steps)
      if (m * power >= low * (1 - 1e-9) && m * power <= high * (1 + 1e-9))
        ticks.push_back(m * power);
  return ticks;
}

void append_html(fmt::memory_buffer& out, std::string_view text) {
  for (char c : text) {
    switch (c) {
      case '&':
        out.append(std::string_view("&amp;"));
        break;
      case '<':
        out.append(std::string_view("&lt;"));
        break;
      case '>':
        out.append(std::string_view("&gt;"));
        break;
      case '"':
        out.append(std::string_view("&quot;"));
        break;
      default:
        out.push_back(c);
    }
  }
}

SvgPlot::SvgPlot(fmt::memory_buffer& out, PlotFrame frame, std::string_view title)
    : out_(out), frame_(std::move(frame)) {
  size_t widest = 0;
  for (double y : frame_.y_ticks) widest = std::max(widest, frame_.y_tick_text(y).size());
  left_ = std::max(least_left, y_label_space + 6 + static_cast<double>(widest) * char_width);
  fmt::format_to(fmt::appender(out_),
                 "<svg class=\"chart\" viewBox=\"0 0 {0} {1}\" width=\"{0}\" height=\"{1}\" "
                 "role=\"img\"><title>",
                 frame_.width, frame_.height);
  append_html(out_, title);
  out_.append(std::string_view("</title>\n"));
  axes();
}

double SvgPlot::to_x(double x) const {
  const auto position = [&](double v) { return frame_.x_log ? std::log10(v) : v; };
  const double from = position(frame_.x_min), to = position(frame_.x_max);
  const double share = to > from ? (position(x) - from) / (to - from) : 0.5;
  return left_ + std::clamp(share, 0.0, 1.0) * (frame_.width - left_ - right);
}

double SvgPlot::to_y(double y) const {
  const double span = frame_.y_max - frame_.y_min;
  const double share = span > 0 ? (y - frame_.y_min) / span : 0;
  return top + (1 - std::clamp(share, 0.0, 1.0)) * (frame_.height - top - bottom);
}

double SvgPlot::fit_centred(double x, std::string_view text) const {
  const double half = static_cast<double>(text.size()) * char_width / 2;
  return std::clamp(x, half, std::max(half, frame_.width - half));
}

void SvgPlot::axes() {
  auto put = fmt::appender(out_);
  const double x0 = left_, x1 = frame_.width - right, y0 = frame_.height - bottom, y1 = top;
  for (double y : frame_.y_ticks) {
    fmt::format_to(put,
                   "<line class=\"grid\" x1=\"{:.1f}\" x2=\"{:.1f}\" y1=\"{:.1f}\" y2=\"{:.1f}\"/>",
                   x0, x1, to_y(y), to_y(y));
    fmt::format_to(put, "<text class=\"tick\" x=\"{:.1f}\" y=\"{:.1f}\" text-anchor=\"end\">",
                   x0 - 6, to_y(y) + 4);
    append_html(out_, frame_.y_tick_text(y));
    out_.append(std::string_view("</text>"));
  }
  for (double x : frame_.x_ticks) {
    fmt::format_to(put,
                   "<line class=\"axis\" x1=\"{:.1f}\" x2=\"{:.1f}\" y1=\"{:.1f}\" y2=\"{:.1f}\"/>",
                   to_x(x), to_x(x), y0, y0 + 4);
    const std::string text = frame_.x_tick_text(x);
    fmt::format_to(put, "<text class=\"tick\" x=\"{:.1f}\" y=\"{:.1f}\" text-anchor=\"middle\">",
                   fit_centred(to_x(x), text), y0 + 16);
    append_html(out_, text);
    out_.append(std::string_view("</text>"));
  }
  fmt::format_to(
      put,
      "<line class=\"axis\" x1=\"{0:.1f}\" x2=\"{1:.1f}\" y1=\"{2:.1f}\" y2=\"{2:.1f}\"/>"
      "<line class=\"axis\" x1=\"{0:.1f}\" x2=\"{0:.1f}\" y1=\"{2:.1f}\" y2=\"{3:.1f}\"/>\n",
      x0, x1, y0, y1);
  fmt::format_to(put, "<text class=\"label\" x=\"{:.1f}\" y=\"{:.1f}\" text-anchor=\"middle\">",
                 (x0 + x1) / 2, frame_.height - 6);
  append_html(out_, frame_.x_label);
  fmt::format_to(put,
                 "</text><text class=\"label\" x=\"12\" y=\"{:.1f}\" text-anchor=\"middle\" "
                 "transform=\"rotate(-90 12 {:.1f})\">",
                 (y0 + y1) / 2, (y0 + y1) / 2);
  append_html(out_, frame_.y_label);
  out_.append(std::string_view("</text>\n"));
}

void SvgPlot::bar(double x0, double x1, double y0, double y1, std::string_view css_class) {
  const double left_x = to_x(x0), right_x = to_x(x1), top_y = to_y(y1), bottom_y = to_y(y0);
  if (bottom_y - top_y <= 0) return;
  fmt::format_to(
      fmt::appender(out_),
      "<rect class=\"{}\" x=\"{:.1f}\" y=\"{:.1f}\" width=\"{:.1f}\" height=\"{:.1f}\"/>",
      css_class, left_x, top_y, std::max(1.0, right_x - left_x), bottom_y - top_y);
}

void SvgPlot::line(const std::vector<std::pair<double, double>>& points,
                   std::string_view css_class) {
  if (points.empty()) return;
  fmt::format_to(fmt::appender(out_), "<polyline class=\"{}\" points=\"", css_class);
  for (const auto& [x, y] : points)
    fmt::format_to(fmt::appender(out_), "{:.1f},{:.1f} ", to_x(x), to_y(y));
  out_.append(std::string_view("\"/>\n"));
}

void SvgPlot::band(const std::vector<std::pair<double, double>>& low,
                   const std::vector<std::pair<double, double>>& high, std::string_view css_class) {
  if (low.empty()) return;
  fmt::format_to(fmt::appender(out_), "<polygon class=\"{}\" points=\"", css_class);
  for (const auto& [x, y] : high)
    fmt::format_to(fmt::appender(out_), "{:.1f},{:.1f} ", to_x(x), to_y(y));
  for (auto it = low.rbegin(); it != low.rend(); ++it)
    fmt::format_to(fmt::appender(out_), "{:.1f},{:.1f} ", to_x(it->first), to_y(it->second));
  out_.append(std::string_view("\"/>\n"));
}

void SvgPlot::dot(double x, double y, std::string_view css_class) {
  fmt::format_to(fmt::appender(out_),
                 "<circle class=\"{}\" cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"4\"/>\n", css_class, to_x(x),
                 to_y(y));
}

void SvgPlot::marker(double x, std::string_view label) {
  fmt::format_to(
      fmt::appender(out_),
      "<line class=\"marker\" x1=\"{0:.1f}\" x2=\"{0:.1f}\" y1=\"{1:.1f}\" y2=\"{2:.1f}\"/>"
      "<text class=\"tick\" x=\"{4:.1f}\" y=\"{3:.1f}\" text-anchor=\"middle\">",
      to_x(x), frame_.height - bottom, top + 10, top + 6, fit_centred(to_x(x), label));
  append_html(out_, label);
  out_.append(std::string_view("</text>\n"));
}

void SvgPlot::finish() {
  out_.append(std::string_view("</svg>\n"));
}

}  // namespace modtap::output
