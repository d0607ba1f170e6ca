// A buffered writer for sinks: records are appended with fmt::format_to and written out about
// every 64 KiB, so there is no string and no system call per record.
#pragma once

#include <cstdio>

#include <fmt/format.h>

namespace modtap::tools {

class Output {
 public:
  explicit Output(FILE* file) : file_(file) {}
  ~Output() { flush(); }
  Output(const Output&) = delete;
  Output& operator=(const Output&) = delete;

  fmt::memory_buffer& buffer() { return buffer_; }
  template <typename... Args>
  void print(fmt::format_string<Args...> format, Args&&... args) {
    fmt::format_to(std::back_inserter(buffer_), format, std::forward<Args>(args)...);
  }
  // Called after each record: writes only when enough has gathered, or always when live.
  void end_record() {
    if (buffer_.size() >= (1 << 16) || line_buffered_) flush();
  }
  void flush() {
    if (buffer_.size()) std::fwrite(buffer_.data(), 1, buffer_.size(), file_);
    buffer_.clear();
    std::fflush(file_);
  }
  void set_line_buffered(bool on) { line_buffered_ = on; }

 private:
  FILE* file_;
  fmt::memory_buffer buffer_;
  bool line_buffered_ = false;
};

}  // namespace modtap::tools
