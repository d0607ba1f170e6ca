// jpnevulator's timed hex log, as modtap writes it: the bus simulator's hex logs and
// --save-raw's.
#pragma once

#include <string>

#include <fmt/format.h>

#include "captures/output_file.hpp"
#include "protocol/records.hpp"

namespace modtap::captures {

class HexlogWriter {
 public:
  // `char_time_ns` lets the stamp name the block's first byte, as jpnevulator's read does.
  HexlogWriter(const std::string& path, int64_t char_time_ns);
  void write(const Chunk& chunk, const std::string& tty = {});
  void close() { file_.close(); }
  uint64_t bytes_written() const { return file_.bytes_written(); }

 private:
  OutputFile file_;
  fmt::memory_buffer line_;
  int64_t char_time_ns_;
};

}  // namespace modtap::captures
