#include "captures/pcap_reader.hpp"

#include <algorithm>
#include <cerrno>
#include <cstring>

#include <unistd.h>

#include <fmt/format.h>

#include "captures/pcapng_format.hpp"

namespace modtap::captures {
namespace {

constexpr uint32_t magic_microseconds = 0xA1B2C3D4, magic_nanoseconds = 0xA1B23C4D;

uint32_t byte_swapped(uint32_t v) {
  return __builtin_bswap32(v);
}

}  // namespace

PcapReader::PcapReader(const std::string& path)
    : path_(path), file_(std::fopen(path.c_str(), "rbe"), &std::fclose), buffer_(1 << 16) {
  if (!file_) fail(0, std::strerror(errno));
  const size_t got = fill(file_header_size);
  if (got < file_header_size)
    fail(0, fmt::format("truncated: a pcap file begins with 24 bytes of header, {} there", got));
  uint32_t magic;
  std::memcpy(&magic, buffer_.data(), 4);
  swapped_ = magic == byte_swapped(magic_microseconds) || magic == byte_swapped(magic_nanoseconds);
  if (swapped_) magic = byte_swapped(magic);
  if (magic != magic_microseconds && magic != magic_nanoseconds)
    fail(0, fmt::format("not a pcap file (it begins with {:08x})", magic));
  fraction_ns_ = magic == magic_nanoseconds ? 1 : 1000;
  const int dlt = static_cast<int>(u32(20) & 0x03FF'FFFF);  // the top bits carry FCS lengths
  at_ += file_header_size;
  if (dlt < pcapng::first_user_dlt || dlt > pcapng::last_user_dlt) {
    throw CaptureError(fmt::format(
        "{}: link type {} ({}) does not carry serial bytes; modtap reads DLT_USER0..15 ({}..{})",
        path, dlt, pcapng::link_type_name(dlt), pcapng::first_user_dlt, pcapng::last_user_dlt));
  }
  clock_ = clock_of_first_packets();
  channels_.push_back({path, ChannelRole::bus});
}

// The packets the first read brought (a file's first 64 KiB; a pipe's, what had come): a time a
// byte where every one holds one byte, and nearly all are stamped at least a character apart at
// the fastest baud a Modbus line runs (921600: 11 us). Bytes a program read one by one out of
// a USB adapter's packet share the packet's moment, a few microseconds apart: a time a packet.
ClockQuality PcapReader::clock_of_first_packets() const {
  constexpr size_t enough = 16;
  constexpr int64_t apart_ns = 10'000;
  size_t packets = 0, apart = 0;
  int64_t last_ns = 0;
  for (size_t at = 0; end_ - at_ - at >= record_header_size + 1; at += record_header_size + 1) {
    if (u32(at + 8) != 1) return ClockQuality::per_chunk;
    const int64_t t_ns = int64_t{u32(at)} * 1'000'000'000 + int64_t{u32(at + 4)} * fraction_ns_;
    if (packets++ && t_ns - last_ns >= apart_ns) ++apart;
    last_ns = t_ns;
  }
  return packets >= enough && apart * 10 >= (packets - 1) * 9 ? ClockQuality::per_byte
                                                              : ClockQuality::per_chunk;
}

bool PcapReader::next(Chunk& chunk) {
  const size_t header = fill(record_header_size);
  if (header == 0) return false;
  const auto cut = [&](size_t got, size_t wanted) {
    fail_in_record(fmt::format("truncated: {} of the record's {} bytes", got, wanted));
  };
  if (header < record_header_size) cut(header, record_header_size);
  const uint32_t seconds = u32(0), fraction = u32(4), caplen = u32(8);
  if (caplen > max_packet)
    fail_in_record(fmt::format("a packet of {} bytes, more than {}: its length is damaged", caplen,
                               max_packet));
  const size_t got = fill(record_header_size + caplen);
  if (got < record_header_size + caplen) cut(got, record_header_size + caplen);
  ++packets_;
  offset_ += record_header_size + caplen;
  const int64_t t_ns = int64_t{seconds} * 1'000'000'000 + int64_t{fraction} * fraction_ns_;
  chunk = {0, t_ns, {buffer_.data() + at_ + record_header_size, caplen}};
  at_ += record_header_size + caplen;
  return true;
}

// read(2) takes what is there, up to the buffer: a file fills it, a pipe from a live capture
// gives what has come and is not waited on for more than the record needs.
size_t PcapReader::fill(size_t n) {
  if (end_ - at_ >= n) return n;
  std::memmove(buffer_.data(), buffer_.data() + at_, end_ - at_);  // the chunk handed out is done
  end_ -= at_;
  at_ = 0;
  if (buffer_.size() < n) buffer_.resize(n);
  while (end_ < n) {
    const ssize_t got = ::read(fileno(file_.get()), buffer_.data() + end_, buffer_.size() - end_);
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) fail(offset_, fmt::format("cannot read: {}", std::strerror(errno)));
    if (got == 0) break;
    end_ += static_cast<size_t>(got);
  }
  return std::min(n, end_);
}

uint32_t PcapReader::u32(size_t at) const {
  uint32_t v;
  std::memcpy(&v, buffer_.data() + at_ + at, 4);
  return swapped_ ? byte_swapped(v) : v;
}

void PcapReader::fail(uint64_t offset, const std::string& what) const {
  throw CaptureError(fmt::format("{}: offset {}: {}", path_, offset, what));
}

void PcapReader::fail_in_record(const std::string& what) const {
  throw CaptureError(
      fmt::format("{}: offset {}, after packet {}: {}", path_, offset_, packets_, what));
}

}  // namespace modtap::captures
