#include "captures/line_reader.hpp"

#include <cerrno>
#include <cstring>

#include <fmt/format.h>

#include "captures/chunk_source.hpp"

namespace modtap::captures {

LineReader::LineReader(const std::string& path)
    : path_(path), file_(std::fopen(path.c_str(), "rb"), &std::fclose) {
  if (!file_) throw CaptureError(fmt::format("{}: cannot open: {}", path, std::strerror(errno)));
}

bool LineReader::next(std::string& line) {
  line.clear();
  int c;
  bool any = false;
  while ((c = std::fgetc(file_.get())) != EOF) {
    any = true;
    ++bytes_read_;
    if (c == '\n') break;
    if (line.size() >= max_line)
      throw CaptureError(
          fmt::format("{}: line {}: longer than {} bytes", path_, line_number_ + 1, max_line));
    line.push_back(static_cast<char>(c));
  }
  if (!any) return false;
  if (!line.empty() && line.back() == '\r') line.pop_back();
  ++line_number_;
  return true;
}

}  // namespace modtap::captures
