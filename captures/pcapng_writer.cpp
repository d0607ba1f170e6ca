#include "captures/pcapng_writer.hpp"

#include <algorithm>
#include <cstring>
#include <vector>

#include "captures/pcapng_format.hpp"

namespace modtap::captures {
using namespace pcapng;

// Blocks are written in the machine's byte order; the byte-order magic tells readers which.
class PcapngWriter::Block {
 public:
  // Writes into `storage`: a writer keeps one, so a packet allocates nothing once it has grown
  // to the largest block, and each piece is a copy, not a vector insert.
  Block(std::vector<uint8_t>& storage, uint32_t type) : bytes_(storage) {
    put(type);
    put(uint32_t{0});  // the total length, known at the end
  }
  template <typename T>
  [[gnu::always_inline]] void put(T value) {
    std::memcpy(room(sizeof value), &value, sizeof value);
  }
  // The data and zeros to the next 32-bit boundary.
  void put_bytes(std::span<const uint8_t> data) {
    const size_t padded = (data.size() + 3) & ~size_t{3};
    uint8_t* at = room(padded);
    std::copy(data.begin(), data.end(), at);
    std::fill(at + data.size(), at + padded, uint8_t{0});
  }
  void option(uint16_t code, std::span<const uint8_t> value) {
    put(code);
    put(static_cast<uint16_t>(value.size()));
    put_bytes(value);
  }
  void option(uint16_t code, std::string_view text) {
    option(code, {reinterpret_cast<const uint8_t*>(text.data()), text.size()});
  }
  void end_options() {
    put(opt_endofopt);
    put(uint16_t{0});
  }
  // The whole block, its total length at both ends.
  std::span<const uint8_t> finish() {
    const auto total = static_cast<uint32_t>(size_ + 4);
    std::memcpy(bytes_.data() + 4, &total, 4);
    put(total);
    return {bytes_.data(), size_};
  }

 private:
  [[gnu::always_inline]] uint8_t* room(size_t n) {
    if (size_ + n > bytes_.size()) bytes_.resize(std::max(size_ + n, 2 * bytes_.size()));
    uint8_t* at = bytes_.data() + size_;
    size_ += n;
    return at;
  }
  std::vector<uint8_t>& bytes_;
  size_t size_ = 0;
};

PcapngWriter::PcapngWriter(const std::string& path, bool live) : file_(path), live_(live) {
  write_section_header();
  if (live_) flush();
}

// One write per block, so a failure leaves the file whole up to its last complete block
// (as far as the C library's buffer allows: it writes whole buffers, never half a call).
void PcapngWriter::write_block(Block& block) {
  file_.write(block.finish());
}

void PcapngWriter::write_section_header() {
  Block b(block_, section_header_block);
  b.put(byte_order_magic);
  b.put(uint16_t{1});
  b.put(uint16_t{0});
  b.put(int64_t{-1});  // section length not known in advance
  b.option(shb_userappl, std::string_view("modtap"));
  b.end_options();
  write_block(b);
}

uint32_t PcapngWriter::add_interface(int link_type, std::string_view name,
                                     std::string_view comment) {
  Block b(block_, interface_description_block);
  b.put(static_cast<uint16_t>(link_type));
  b.put(uint16_t{0});
  b.put(uint32_t{0});  // no snap length
  if (!comment.empty()) b.option(opt_comment, comment);
  b.option(if_name, name);
  const uint8_t nanoseconds = 9;
  b.option(if_tsresol, std::span<const uint8_t>(&nanoseconds, 1));
  b.end_options();
  write_block(b);
  return interfaces_++;
}

void PcapngWriter::write_packet(uint32_t interface, int64_t t_ns, std::span<const uint8_t> data,
                                PacketDirection direction, std::string_view comment) {
  Block b(block_, enhanced_packet_block);
  const auto t = static_cast<uint64_t>(t_ns);
  b.put(interface);
  b.put(static_cast<uint32_t>(t >> 32));
  b.put(static_cast<uint32_t>(t & 0xFFFFFFFF));
  b.put(static_cast<uint32_t>(data.size()));
  b.put(static_cast<uint32_t>(data.size()));
  b.put_bytes(data);
  if (!comment.empty()) b.option(opt_comment, comment);
  if (direction != PacketDirection::unknown) {
    const uint32_t flags = static_cast<uint32_t>(direction);
    b.option(epb_flags, {reinterpret_cast<const uint8_t*>(&flags), 4});
  }
  b.end_options();
  write_block(b);
  if (live_) flush();
}

void PcapngWriter::flush() {
  file_.flush();
}

void PcapngWriter::close() {
  file_.close();
}

}  // namespace modtap::captures
