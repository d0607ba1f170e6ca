#include "captures/pcapng_reader.hpp"

#include <algorithm>
#include <cerrno>
#include <cstring>

#include <fmt/format.h>

#include "captures/pcapng_format.hpp"

namespace modtap::captures {
namespace {

using namespace pcapng;

uint32_t swap32(uint32_t v) {
  return __builtin_bswap32(v);
}

bool serial_link(int link_type) {
  return (link_type >= first_user_dlt && link_type <= last_user_dlt) ||
         link_type == exported_pdu_dlt;
}

// Exported-PDU tags (big-endian type and length, values padded to 4) come before the bytes.
std::span<const uint8_t> after_exported_pdu_tags(std::span<const uint8_t> data) {
  size_t at = 0;
  while (at + 4 <= data.size()) {
    const unsigned type = data[at] << 8 | data[at + 1];
    const size_t length = data[at + 2] << 8 | data[at + 3];
    at += 4;
    if (type == 0) return data.subspan(at);
    at += (length + 3) & ~size_t{3};
  }
  return {};
}

}  // namespace

PcapngReader::PcapngReader(const std::string& path, int64_t char_time_ns)
    : path_(path),
      char_time_ns_(char_time_ns),
      file_(std::fopen(path.c_str(), "rb"), &std::fclose) {
  if (!file_) throw CaptureError(fmt::format("{}: cannot open: {}", path, std::strerror(errno)));
  // The interfaces come before their packets; read them now, so the channels are known before
  // the first packet. An interface described later is added when it comes.
  uint32_t type = 0;
  while (read_block(type)) {
    if (describes(type)) continue;
    if (type == enhanced_packet_block || type == simple_packet_block ||
        type == obsolete_packet_block) {
      held_type_ = type;  // next() takes it first: a pipe cannot be read again
      break;
    }
  }
  if (channels_.empty()) channels_.push_back({path_, ChannelRole::bus});
}

void PcapngReader::fail(const std::string& what) const {
  throw CaptureError(fmt::format("{}: offset {}: {}", path_, offset_, what));
}

// One block: its type, and its body (without the type and the two lengths) in body_.
// The file is read straight through, never sought: a pipe reads as a file does.
bool PcapngReader::read_block(uint32_t& type) {
  offset_ = position_;
  uint32_t head[2];
  const size_t got = read(head, sizeof head);
  if (got == 0) return false;
  if (got < sizeof head) fail("truncated pcapng block header");
  type = head[0];
  uint32_t magic = 0;
  if (type == section_header_block) {
    // The byte order is the section's own: read it from the magic after the length.
    if (read(&magic, 4) != 4) fail("truncated section header");
    if (magic != byte_order_magic && magic != swap32(byte_order_magic))
      fail("not a pcapng section header");
    swapped_ = magic != byte_order_magic;
    have_section_ = true;
  } else {
    if (!have_section_) fail("no section header before the first block");
    if (swapped_) type = swap32(type);
  }
  const uint32_t length = swapped_ ? swap32(head[1]) : head[1];
  if (length < 12 || length % 4 != 0 || length > max_block ||
      (type == section_header_block && length < 16))
    fail(fmt::format("block length {} is not a pcapng block's", length));
  body_.resize(length - 12);
  const size_t magic_size = type == section_header_block ? 4 : 0;  // read already
  std::memcpy(body_.data(), &magic, magic_size);
  uint32_t trailer = 0;
  if (read(body_.data() + magic_size, body_.size() - magic_size) != body_.size() - magic_size ||
      read(&trailer, 4) != 4)
    fail(fmt::format("truncated pcapng block of {} bytes", length));
  if ((swapped_ ? swap32(trailer) : trailer) != length)
    fail("block lengths at its start and end differ");
  return true;
}

// Section headers and interface descriptions say what the packets after them mean.
bool PcapngReader::describes(uint32_t type) {
  if (type == section_header_block) {
    interfaces_.clear();  // a new section numbers its interfaces anew
  } else if (type == interface_description_block) {
    interface_description();
  } else {
    return false;
  }
  return true;
}

uint16_t PcapngReader::u16(size_t at) const {
  uint16_t v;
  std::memcpy(&v, body_.data() + at, 2);
  return swapped_ ? static_cast<uint16_t>(v >> 8 | v << 8) : v;
}

uint32_t PcapngReader::u32(size_t at) const {
  uint32_t v;
  std::memcpy(&v, body_.data() + at, 4);
  return swapped_ ? swap32(v) : v;
}

// The options from `at` to the block's end, each as code and value, up to opt_endofopt.
template <typename Visit>
void PcapngReader::options(size_t at, Visit visit) const {
  while (at + 4 <= body_.size()) {
    const uint16_t code = u16(at), length = u16(at + 2);
    at += 4;
    if (code == opt_endofopt || at + length > body_.size()) return;
    visit(code, std::span<const uint8_t>(body_.data() + at, length));
    at += (length + 3u) & ~3u;
  }
}

void PcapngReader::interface_description() {
  if (body_.size() < 8) fail("interface description too short");
  Interface i;
  i.link_type = u16(0);
  std::string name, comment;
  options(8, [&](uint16_t code, std::span<const uint8_t> value) {
    const std::string text(value.begin(), value.end());
    if (code == if_name) name = text;
    if (code == opt_comment) comment = text;
    if (code == if_tsresol && !value.empty()) {  // 10^-n s, or 2^-n s with the top bit set
      const bool binary = value[0] & 0x80;
      const int exponent = std::min(value[0] & 0x7F, binary ? 62 : 18);
      i.ticks_per_second = 1;
      for (int e = 0; e < exponent; ++e) i.ticks_per_second *= binary ? 2 : 10;
    }
  });
  if (!serial_link(i.link_type))
    fail(fmt::format(
        "link type {} ({}) does not carry serial bytes; modtap reads DLT_USER0..15 "
        "({}..{}) and exported PDUs ({})",
        i.link_type, link_type_name(i.link_type), first_user_dlt, last_user_dlt, exported_pdu_dlt));
  i.modtap = comment.starts_with(interface_convention);
  if (i.modtap && interfaces_.empty()) {
    if (comment.find("clock=per-byte") != std::string::npos) clock_ = ClockQuality::per_byte;
    if (comment.find("clock=none") != std::string::npos) clock_ = ClockQuality::none;
  }
  if (const auto at = comment.find(" char_ns="); i.modtap && at != std::string::npos)
    i.char_ns = std::strtoll(comment.c_str() + at + 9, nullptr, 10);
  ChannelRole role = ChannelRole::bus;
  if (i.modtap && comment.find("role=master") != std::string::npos) role = ChannelRole::master;
  if (i.modtap && comment.find("role=slave") != std::string::npos) role = ChannelRole::slave;
  i.channel = static_cast<uint16_t>(channels_.size());
  channels_.push_back({name.empty() ? path_ : name, role});
  interfaces_.push_back(i);
}

bool PcapngReader::next(Chunk& chunk) {
  if (rest_at_) {  // the rest of a modtap packet
    const auto rest = std::span<const uint8_t>(bytes_).subspan(rest_at_);
    if (clock_ == ClockQuality::per_byte && rest.size() > 1) {
      const auto last = static_cast<int64_t>(bytes_.size() - 1);
      const auto k = static_cast<int64_t>(rest_at_);
      chunk = {rest_channel_, first_end_ns_ + (rest_end_ns_ - first_end_ns_) * k / last,
               rest.first(1)};
      ++rest_at_;
      return true;
    }
    chunk = {rest_channel_, rest_end_ns_, rest};
    rest_at_ = 0;
    return true;
  }
  uint32_t type = 0;
  if (held_type_) {  // the first packet block, read while looking for the interfaces
    type = *held_type_;
    held_type_.reset();
    if (packet(type, chunk)) return true;
  }
  while (read_block(type))
    if (!describes(type) && packet(type, chunk)) return true;
  return false;
}

size_t PcapngReader::read(void* into, size_t size) {
  const size_t got = std::fread(into, 1, size, file_.get());
  position_ += got;
  return got;
}

bool PcapngReader::packet(uint32_t type, Chunk& chunk) {
  uint32_t interface = 0, caplen = 0;
  uint64_t stamp = 0;
  size_t data_at = 0;
  if (type == enhanced_packet_block || type == obsolete_packet_block) {
    if (body_.size() < 20) fail("packet block too short");
    interface = type == enhanced_packet_block ? u32(0) : (u32(0) & 0xFFFF);
    stamp = uint64_t{u32(4)} << 32 | u32(8);
    caplen = u32(12);
    data_at = 20;
  } else if (type == simple_packet_block) {
    if (body_.size() < 4) fail("packet block too short");
    caplen = std::min<uint32_t>(u32(0), static_cast<uint32_t>(body_.size() - 4));
    data_at = 4;
  } else {
    return false;  // statistics, name resolution, custom blocks: nothing to read
  }
  if (interface >= interfaces_.size())
    fail(fmt::format("packet of undescribed interface {}", interface));
  if (caplen > body_.size() - data_at)
    fail(fmt::format("packet length {} exceeds its block", caplen));
  const Interface& i = interfaces_[interface];
  std::span<const uint8_t> data(body_.data() + data_at, caplen);
  std::string comment;
  options(data_at + ((caplen + 3u) & ~3u), [&](uint16_t code, std::span<const uint8_t> value) {
    if (code == opt_comment) comment.assign(value.begin(), value.end());
  });
  if (i.link_type == exported_pdu_dlt) data = after_exported_pdu_tags(data);
  bytes_.assign(data.begin(), data.end());
  if (bytes_.empty()) return false;
  const auto t_ns = static_cast<int64_t>(static_cast<__int128>(stamp) * 1'000'000'000 /
                                         static_cast<__int128>(i.ticks_per_second));
  // modtap stamps a record at its first byte and says how long it lasted where that was not its
  // bytes at the line's speed; other writers stamp a packet when its last byte was read, as
  // every reader of a serial port does.
  if (i.modtap) {
    const int64_t char_ns = i.char_ns > 0 ? i.char_ns : char_time_ns_;
    const auto duration_at = comment.find(" duration_ns=");
    const int64_t duration = duration_at != std::string::npos
                                 ? std::strtoll(comment.c_str() + duration_at + 13, nullptr, 10)
                                 : static_cast<int64_t>(bytes_.size()) * char_ns;
    first_end_ns_ = t_ns + char_ns;
    // With a clock per read the first run judged the packet's bytes together; with one per byte,
    // each byte alone, as the rest's come.
    chunk = {i.channel, first_end_ns_, std::span<const uint8_t>(bytes_).first(1),
             comment.find(" untimed_start=1") != std::string::npos,
             bytes_.size() > 1 && clock_ != ClockQuality::per_byte};
    if (bytes_.size() > 1) {
      rest_at_ = 1;
      rest_end_ns_ = t_ns + duration;
      rest_channel_ = i.channel;
    }
    return true;
  }
  chunk = {i.channel, t_ns, bytes_};
  return true;
}

}  // namespace modtap::captures
