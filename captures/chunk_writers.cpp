#include "captures/chunk_writers.hpp"

#include <pcap/pcap.h>

#include <cerrno>
#include <cstring>
#include <ctime>

#include <fmt/format.h>

#include "captures/chunk_source.hpp"

namespace modtap::captures {

PcapChunkWriter::PcapChunkWriter(const std::string& path, int dlt) : path_(path) {
  dead_ = pcap_open_dead_with_tstamp_precision(dlt, 65535, PCAP_TSTAMP_PRECISION_NANO);
  dumper_ = dead_ ? pcap_dump_open(dead_, path.c_str()) : nullptr;
  if (!dumper_) {
    const std::string error = dead_ ? pcap_geterr(dead_) : "pcap_open_dead failed";
    if (dead_) pcap_close(dead_);
    throw CaptureError(fmt::format("{}: cannot create: {}", path, error));
  }
}

PcapChunkWriter::~PcapChunkWriter() {
  pcap_dump_close(dumper_);
  pcap_close(dead_);
}

void PcapChunkWriter::write(const decoder::Chunk& chunk) {
  pcap_pkthdr header{};
  header.ts.tv_sec = static_cast<time_t>(chunk.t_ns / 1'000'000'000);
  header.ts.tv_usec = static_cast<suseconds_t>(chunk.t_ns % 1'000'000'000);  // nanoseconds
  header.caplen = header.len = static_cast<bpf_u_int32>(chunk.bytes.size());
  pcap_dump(reinterpret_cast<u_char*>(dumper_), &header, chunk.bytes.data());
  if (std::ferror(pcap_dump_file(dumper_))) throw WriteError(path_, errno ? errno : EIO);
}

HexlogWriter::HexlogWriter(const std::string& path, int64_t char_time_ns)
    : file_(path), char_time_ns_(char_time_ns) {}

void HexlogWriter::write(const decoder::Chunk& chunk, const std::string& tty) {
  const int64_t first_ns = chunk.t_ns - static_cast<int64_t>(chunk.bytes.size()) * char_time_ns_;
  const std::time_t seconds = static_cast<std::time_t>(first_ns / 1'000'000'000);
  std::tm tm{};
  localtime_r(&seconds, &tm);
  fmt::memory_buffer& out = line_;
  out.clear();
  fmt::format_to(std::back_inserter(out), "{:04}-{:02}-{:02} {:02}:{:02}:{:02}.{:06}:{}{}\n",
                 tm.tm_year + 1900, tm.tm_mon + 1, tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec,
                 first_ns % 1'000'000'000 / 1000, tty.empty() ? "" : " ", tty);
  for (size_t i = 0; i < chunk.bytes.size(); ++i)
    fmt::format_to(std::back_inserter(out), "{:02X}{}", chunk.bytes[i],
                   (i % 16 == 15 || i + 1 == chunk.bytes.size()) ? "\n" : " ");
  file_.write({out.data(), out.size()});
}

}  // namespace modtap::captures
