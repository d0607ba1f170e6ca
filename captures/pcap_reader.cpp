#include "captures/pcap_reader.hpp"

#include "captures/pcapng_format.hpp"

#include <pcap/pcap.h>

#include <fmt/format.h>

namespace modtap::captures {

PcapReader::PcapReader(const std::string& path) : path_(path) {
  char error[PCAP_ERRBUF_SIZE] = {};
  handle_ =
      pcap_open_offline_with_tstamp_precision(path.c_str(), PCAP_TSTAMP_PRECISION_NANO, error);
  if (!handle_) throw CaptureError(fmt::format("{}: offset 0: {}", path, error));
  const int dlt = pcap_datalink(handle_);
  if (dlt < pcapng::first_user_dlt || dlt > pcapng::last_user_dlt) {
    const char* name = pcap_datalink_val_to_name(dlt);
    pcap_close(handle_);
    handle_ = nullptr;
    throw CaptureError(fmt::format(
        "{}: link type {} ({}) does not carry serial bytes; modtap reads DLT_USER0..15 ({}..{})",
        path, dlt, name ? name : "unknown", pcapng::first_user_dlt, pcapng::last_user_dlt));
  }
  channels_.push_back({path, decoder::ChannelRole::bus});
}

PcapReader::~PcapReader() {
  if (handle_) pcap_close(handle_);
}

bool PcapReader::next(decoder::Chunk& chunk) {
  pcap_pkthdr* header = nullptr;
  const u_char* data = nullptr;
  const uint64_t before = offset_;
  const int rc = pcap_next_ex(handle_, &header, &data);
  if (rc == PCAP_ERROR_BREAK) return false;
  if (rc != 1)
    throw CaptureError(fmt::format("{}: offset {}, after packet {}: {}", path_, before, packets_,
                                   pcap_geterr(handle_)));
  ++packets_;
  offset_ += record_header_size + header->caplen;
  const int64_t t_ns = static_cast<int64_t>(header->ts.tv_sec) * 1'000'000'000 + header->ts.tv_usec;
  chunk = {0, t_ns, {data, header->caplen}};
  return true;
}

}  // namespace modtap::captures
