// A progress bar on the terminal for a long file review: how much of the file is read, how
// fast, how long is left. On standard error, redrawn in place about four times a second, and
// wiped at the end so what follows (the statistics, an error) starts on a clean line.
#pragma once

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <string>

namespace modtap::tools {

class ProgressBar {
 public:
  ProgressBar(std::FILE* terminal, uint64_t total_bytes);
  ~ProgressBar() { finish(); }
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  // Cheap enough to call per chunk: it looks at the clock only every few hundred calls (a
  // packet each) or every 64 KiB (a raw file's reads).
  void update(uint64_t bytes_done) {
    if (++calls_ % 256 == 0 || bytes_done - looked_at_ >= (1 << 16)) redraw_if_due(bytes_done);
  }
  void finish();

  // "[########------------]  42% of 1.2 GB, 85.3 MB/s, 7 s left": what draw() prints.
  static std::string line(uint64_t done, uint64_t total, double seconds, int width = 24);

 private:
  using Clock = std::chrono::steady_clock;
  void redraw_if_due(uint64_t bytes_done);
  void draw(uint64_t bytes_done);

  std::FILE* terminal_;
  uint64_t total_;
  uint64_t calls_ = 0;
  uint64_t looked_at_ = 0;  // bytes done when the clock was last looked at
  Clock::time_point start_ = Clock::now(), next_draw_ = start_;
  bool finished_ = false;
};

}  // namespace modtap::tools
