// A buffered writer for sinks: records are appended with fmt::format_to and written out about
// every 64 KiB, so there is no string and no system call per record. What is printed for
// every record uses FMT_COMPILE, so its format is not parsed again per record. Writes are checked
// (captures::OutputFile): a failure throws WriteError.
#pragma once

#include <fmt/compile.h>
#include <fmt/format.h>

#include "captures/output_file.hpp"

namespace modtap::output {

class Output {
 public:
  explicit Output(captures::OutputFile& file) : file_(&file) {}
  // Into memory only: the owner takes buffer()'s content and clears it.
  Output() = default;
  ~Output() {
    try {
      flush();
    } catch (const captures::WriteError&) {
      // Unwinding already: the failure that matters is being reported.
    }
  }
  Output(const Output&) = delete;
  Output& operator=(const Output&) = delete;

  fmt::memory_buffer& buffer() { return buffer_; }
  template <typename... Args>
  void print(fmt::format_string<Args...> format, Args&&... args) {
    fmt::format_to(fmt::appender(buffer_), format, std::forward<Args>(args)...);
  }
  // With FMT_COMPILE("..."): parsed at compile time, for the lines printed per record.
  template <typename Compiled, typename... Args>
  requires fmt::detail::is_compiled_string<Compiled>::value void print(const Compiled& format,
                                                                       Args&&... args) {
    fmt::format_to(fmt::appender(buffer_), format, std::forward<Args>(args)...);
  }
  // Called after each record: writes only when enough has gathered, or always when live.
  void end_record() {
    if (file_ && (buffer_.size() >= (1 << 16) || line_buffered_)) flush();
  }
  void flush() {
    if (!file_) return;
    file_->write(std::string_view(buffer_.data(), buffer_.size()));
    buffer_.clear();
    file_->flush();
  }
  void set_line_buffered(bool on) { line_buffered_ = on; }

 private:
  captures::OutputFile* file_ = nullptr;
  fmt::memory_buffer buffer_;
  bool line_buffered_ = false;
};

}  // namespace modtap::output
