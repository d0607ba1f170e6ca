// jpnevulator's timed hex log, as modtap writes it: the bus simulator's hex logs and
// --save-raw's.
#pragma once

#include <string>

#include <fmt/format.h>

#include "captures/output_file.hpp"
#include "decoder/protocol/records.hpp"

namespace modtap::captures {

class HexlogWriter {
 public:
  // Each chunk is a block stamped with its end, as jpnevulator stamps a read when it returns.
  explicit HexlogWriter(const std::string& path);
  void write(const Chunk& chunk, const std::string& tty = {});
  void close() { file_.close(); }
  uint64_t bytes_written() const { return file_.bytes_written(); }

 private:
  OutputFile file_;
  fmt::memory_buffer line_;
};

}  // namespace modtap::captures
