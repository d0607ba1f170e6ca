#include "tools/modtap/progress.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

namespace modtap::tools {

namespace {

std::string bytes_text(double bytes) {
  if (bytes < 1e3) return fmt::format("{:.0f} B", bytes);
  if (bytes < 1e6) return fmt::format("{:.1f} kB", bytes / 1e3);
  if (bytes < 1e9) return fmt::format("{:.1f} MB", bytes / 1e6);
  return fmt::format("{:.2f} GB", bytes / 1e9);
}

std::string time_left_text(double seconds) {
  if (seconds < 60) return fmt::format("{:.0f} s left", std::ceil(seconds));
  if (seconds < 3600) return fmt::format("{:.0f} min left", std::ceil(seconds / 60));
  return fmt::format("{:.1f} h left", seconds / 3600);
}

}  // namespace

ProgressBar::ProgressBar(std::FILE* terminal, uint64_t total_bytes)
    : terminal_(terminal), total_(std::max<uint64_t>(total_bytes, 1)) {
  draw(0);
}

std::string ProgressBar::line(uint64_t done, uint64_t total, double seconds, int width) {
  const double share = std::clamp(static_cast<double>(done) / static_cast<double>(total), 0.0, 1.0);
  const int filled = static_cast<int>(share * width);
  std::string text =
      fmt::format("[{}{}]", std::string(filled, '#'), std::string(width - filled, '-'));
  text += fmt::format(" {:3.0f}% of {}", 100 * share, bytes_text(static_cast<double>(total)));
  if (seconds > 0.2 && done > 0) {
    const double rate = static_cast<double>(done) / seconds;
    text += fmt::format(", {}/s", bytes_text(rate));
    if (done < total) text += ", " + time_left_text(static_cast<double>(total - done) / rate);
  }
  return text;
}

void ProgressBar::redraw_if_due(uint64_t bytes_done) {
  looked_at_ = bytes_done;
  const auto now = Clock::now();
  if (now < next_draw_) return;
  next_draw_ = now + std::chrono::milliseconds(250);
  draw(bytes_done);
}

void ProgressBar::draw(uint64_t bytes_done) {
  const double seconds = std::chrono::duration<double>(Clock::now() - start_).count();
  // \r and erase-line redraw in place; a failed write to a terminal is not worth stopping for.
  fmt::print(terminal_, "\r\033[K{}", line(bytes_done, total_, seconds));
  std::fflush(terminal_);
}

void ProgressBar::finish() {
  if (finished_) return;
  finished_ = true;
  fmt::print(terminal_, "\r\033[K");
  std::fflush(terminal_);
}

}  // namespace modtap::tools
