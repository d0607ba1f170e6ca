#include "captures/pcap_chunk_writer.hpp"

#include <pcap/pcap.h>

#include <cerrno>
#include <cstdio>

#include <fmt/format.h>

#include "captures/chunk_source.hpp"
#include "captures/output_file.hpp"

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

void PcapChunkWriter::write(const Chunk& chunk) {
  pcap_pkthdr header{};
  header.ts.tv_sec = static_cast<time_t>(chunk.t_ns / 1'000'000'000);
  header.ts.tv_usec = static_cast<suseconds_t>(chunk.t_ns % 1'000'000'000);  // nanoseconds
  header.caplen = header.len = static_cast<bpf_u_int32>(chunk.bytes.size());
  pcap_dump(reinterpret_cast<u_char*>(dumper_), &header, chunk.bytes.data());
  if (std::ferror(pcap_dump_file(dumper_))) throw WriteError(path_, errno ? errno : EIO);
}

}  // namespace modtap::captures
