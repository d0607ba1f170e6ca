// Reads text lines with a bound on their length, so a binary file fed to a text reader gives
// an error instead of an unbounded line.
#pragma once

#include <cstdio>
#include <memory>
#include <string>

namespace modtap::captures {

class LineReader {
 public:
  explicit LineReader(const std::string& path);
  // False at the end of the file. Throws CaptureError when a line is longer than max_line.
  bool next(std::string& line);
  uint64_t line_number() const { return line_number_; }
  uint64_t bytes_read() const { return bytes_read_; }
  const std::string& path() const { return path_; }

  static constexpr size_t max_line = 1 << 16;

 private:
  std::string path_;
  std::unique_ptr<FILE, int (*)(FILE*)> file_;
  uint64_t line_number_ = 0;
  uint64_t bytes_read_ = 0;
};

}  // namespace modtap::captures
