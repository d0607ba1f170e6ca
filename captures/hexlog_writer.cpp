#include "captures/hexlog_writer.hpp"

#include <cerrno>
#include <cstring>
#include <ctime>

#include <fmt/format.h>

#include "captures/chunk_source.hpp"

namespace modtap::captures {

HexlogWriter::HexlogWriter(const std::string& path) : file_(path) {}

void HexlogWriter::write(const Chunk& chunk, const std::string& tty) {
  const std::time_t seconds = static_cast<std::time_t>(chunk.t_ns / 1'000'000'000);
  std::tm tm{};
  localtime_r(&seconds, &tm);
  fmt::memory_buffer& out = line_;
  out.clear();
  fmt::format_to(std::back_inserter(out), "{:04}-{:02}-{:02} {:02}:{:02}:{:02}.{:06}:{}{}\n",
                 tm.tm_year + 1900, tm.tm_mon + 1, tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec,
                 chunk.t_ns % 1'000'000'000 / 1000, tty.empty() ? "" : " ", tty);
  for (size_t i = 0; i < chunk.bytes.size(); ++i)
    fmt::format_to(std::back_inserter(out), "{:02X}{}", chunk.bytes[i],
                   (i % 16 == 15 || i + 1 == chunk.bytes.size()) ? "\n" : " ");
  file_.write({out.data(), out.size()});
}

}  // namespace modtap::captures
