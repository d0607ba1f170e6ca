#include "captures/pcapng_writer.hpp"

#include <algorithm>
#include <cstring>

#include "captures/pcapng_format.hpp"

namespace modtap::captures {
using namespace pcapng;

namespace {

// The file is written in pieces of at least this many bytes (and whole blocks).
constexpr size_t write_size = 256 * 1024;

constexpr size_t max_holds = 4096;
constexpr size_t max_held_bytes = 4 << 20;

constexpr size_t padded(size_t n) {
  return (n + 3) & ~size_t{3};
}

uint32_t load32(const uint8_t* at) {
  uint32_t v;
  std::memcpy(&v, at, 4);
  return v;
}

void store32(uint8_t* at, uint32_t v) {
  std::memcpy(at, &v, 4);
}

// An enhanced packet block's fixed part: type, total length, interface, time high and low,
// captured and original length; the data follows it.
constexpr size_t epb_header = 28;
constexpr size_t epb_captured_length = 20;

}  // namespace

// A block built in place at the end of the writer's pending bytes, in the machine's byte order
// (the byte-order magic tells readers which). Its size is known before anything is written, so
// that its room is made once and each field is a copy: a block a frame, this is the hottest
// code of a -w run.
class PcapngWriter::Block {
 public:
  // `body`: the bytes between the block's length at its start and the same length at its end.
  Block(PcapngWriter& writer, uint32_t type, size_t body)
      : total_(static_cast<uint32_t>(body + 12)), at_(writer.room(total_)) {
    put(type);
    put(total_);
  }
  // What an option of `n` bytes takes: code, length, the value padded to 32 bits.
  static constexpr size_t option_size(size_t n) { return 4 + padded(n); }
  static constexpr size_t end_of_options = 4;

  template <typename T>
  void put(T value) {
    std::memcpy(at_, &value, sizeof value);
    at_ += sizeof value;
  }
  // The data and zeros to the next 32-bit boundary: the last word zeroed, the data over it.
  void put_bytes(std::span<const uint8_t> data) {
    if (data.empty()) return;
    store32(at_ + padded(data.size()) - 4, 0);
    std::memcpy(at_, data.data(), data.size());
    at_ += padded(data.size());
  }
  // The caller keeps `value` to 65,535 bytes, an option length's 16 bits.
  void option(uint16_t code, std::span<const uint8_t> value) {
    put(code);
    put(static_cast<uint16_t>(value.size()));
    put_bytes(value);
  }
  void option(uint16_t code, std::string_view text) {
    option(code, {reinterpret_cast<const uint8_t*>(text.data()), text.size()});
  }
  // The end of the options and the block's closing length.
  void finish() {
    put(opt_endofopt);
    put(uint16_t{0});
    put(total_);
  }

 private:
  uint32_t total_;
  uint8_t* at_;
};

PcapngWriter::PcapngWriter(const std::string& path, bool live)
    : file_(path, /*buffered=*/false), live_(live) {
  write_section_header();
  if (live_) flush();
}

PcapngWriter::~PcapngWriter() {
  if (closed_) return;
  try {
    write_out(end_ - begin_);
  } catch (const WriteError&) {  // the file's own destructor closes it
  }
}

void PcapngWriter::grow(size_t n) {
  const size_t capacity = std::max(end_ + n, std::max(2 * capacity_, 2 * write_size));
  auto grown = std::make_unique<uint8_t[]>(capacity);
  // The written bytes before begin_ too: a block being built holds its place by index.
  if (end_ > 0) std::memcpy(grown.get(), pending_.get(), end_);
  pending_ = std::move(grown);
  capacity_ = capacity;
}

inline uint8_t* PcapngWriter::room(size_t n) {
  if (end_ + n > capacity_) [[unlikely]]
    grow(n);
  uint8_t* at = pending_.get() + end_;
  end_ += n;
  return at;
}

// Makes `n` bytes of room at `at` inside the pending bytes, moving what follows.
void PcapngWriter::insert_room(size_t at, size_t n) {
  const size_t tail = end_ - at;
  room(n);
  std::memmove(pending_.get() + at + n, pending_.get() + at, tail);
}

// The bytes before the first held packet.
size_t PcapngWriter::writable() const {
  if (holds_.empty()) return end_ - begin_;
  return static_cast<size_t>(holds_.front().at - file_.bytes_written());
}

// Writes the first `n` pending bytes (whole blocks), keeping the rest.
void PcapngWriter::write_out(size_t n) {
  if (n == 0) return;
  file_.write({pending_.get() + begin_, n});
  begin_ += n;
  // What is left moves to the front once it is no more than what went out: each byte moves
  // at most about once, however long a held packet keeps the rest waiting.
  if (begin_ == end_) {
    begin_ = end_ = 0;
  } else if (begin_ >= end_ - begin_) {
    std::memmove(pending_.get(), pending_.get() + begin_, end_ - begin_);
    end_ -= begin_;
    begin_ = 0;
  }
}

void PcapngWriter::write_due() {
  while (!holds_.empty() && end_ - begin_ - writable() > max_held_bytes)
    holds_.erase(holds_.begin());
  if (live_) {
    flush();
  } else if (const size_t n = writable(); n >= write_size) {
    write_out(n);
  }
}

void PcapngWriter::write_section_header() {
  constexpr std::string_view application = "modtap";
  Block b(*this, section_header_block,
          16 + Block::option_size(application.size()) + Block::end_of_options);
  b.put(byte_order_magic);
  b.put(uint16_t{1});
  b.put(uint16_t{0});
  b.put(int64_t{-1});  // section length not known in advance
  b.option(shb_userappl, application);
  b.finish();
}

uint32_t PcapngWriter::add_interface(int link_type, std::string_view name,
                                     std::string_view comment) {
  name = name.substr(0, 0xFFFF);
  comment = comment.substr(0, 0xFFFF);
  const uint8_t nanoseconds = 9;
  Block b(*this, interface_description_block,
          8 + (comment.empty() ? 0 : Block::option_size(comment.size())) +
              Block::option_size(name.size()) + Block::option_size(1) + Block::end_of_options);
  b.put(static_cast<uint16_t>(link_type));
  b.put(uint16_t{0});
  b.put(uint32_t{0});  // no snap length
  if (!comment.empty()) b.option(opt_comment, comment);
  b.option(if_name, name);
  b.option(if_tsresol, std::span<const uint8_t>(&nanoseconds, 1));
  b.finish();
  write_due();
  return interfaces_++;
}

void PcapngWriter::write_packet(uint32_t interface, int64_t t_ns, std::span<const uint8_t> data,
                                PacketDirection direction, std::string_view comment,
                                uint64_t hold) {
  if (hold != 0) {
    if (holds_.size() == max_holds) holds_.erase(holds_.begin());
    holds_.push_back({hold, bytes_written()});
  }
  comment = comment.substr(0, 0xFFFF);
  // A held packet has a comment, if an empty one, for extend_comment to grow.
  const bool commented = !comment.empty() || hold != 0;
  const bool flagged = direction != PacketDirection::unknown;
  Block b(*this, enhanced_packet_block,
          20 + padded(data.size()) + (commented ? Block::option_size(comment.size()) : 0) +
              (flagged ? Block::option_size(4) : 0) + Block::end_of_options);
  const auto t = static_cast<uint64_t>(t_ns);
  b.put(interface);
  b.put(static_cast<uint32_t>(t >> 32));
  b.put(static_cast<uint32_t>(t & 0xFFFFFFFF));
  b.put(static_cast<uint32_t>(data.size()));
  b.put(static_cast<uint32_t>(data.size()));
  b.put_bytes(data);
  if (commented) b.option(opt_comment, comment);
  if (flagged) {
    const uint32_t flags = static_cast<uint32_t>(direction);
    b.option(epb_flags, {reinterpret_cast<const uint8_t*>(&flags), 4});
  }
  b.finish();
  write_due();
}

void PcapngWriter::extend_comment(uint64_t hold, std::string_view more) {
  const auto held =
      std::find_if(holds_.begin(), holds_.end(), [&](const Hold& h) { return h.key == hold; });
  if (held == holds_.end()) return;
  const size_t block = static_cast<size_t>(held->at - file_.bytes_written()) + begin_;
  const size_t option = block + epb_header + padded(load32(&pending_[block + epb_captured_length]));
  uint16_t length;
  std::memcpy(&length, &pending_[option + 2], 2);
  more = more.substr(0, 0xFFFF - length);
  const size_t text = option + 4, text_end = text + length;
  const size_t grown = padded(length + more.size()) - padded(length);
  insert_room(text + padded(length), grown);
  // Readers take a comment's verdicts from its first line: the lines after it move along.
  const auto first_line_end =
      static_cast<size_t>(std::find(&pending_[text], &pending_[text_end], '\n') - &pending_[0]);
  std::memmove(&pending_[first_line_end + more.size()], &pending_[first_line_end],
               text_end - first_line_end);
  std::memcpy(&pending_[first_line_end], more.data(), more.size());
  std::memset(&pending_[text_end + more.size()], 0,
              padded(length + more.size()) - length - more.size());
  length = static_cast<uint16_t>(length + more.size());
  std::memcpy(&pending_[option + 2], &length, 2);
  const uint32_t total = load32(&pending_[block + 4]) + static_cast<uint32_t>(grown);
  store32(&pending_[block + 4], total);
  store32(&pending_[block + total - 4], total);
  for (auto later = held + 1; later != holds_.end(); ++later) later->at += grown;
}

void PcapngWriter::release(uint64_t hold) {
  const auto held =
      std::find_if(holds_.begin(), holds_.end(), [&](const Hold& h) { return h.key == hold; });
  if (held == holds_.end()) return;
  holds_.erase(held);
  write_due();
}

void PcapngWriter::release_all() {
  holds_.clear();
  write_due();
}

void PcapngWriter::flush() {
  write_out(writable());
  file_.flush();
}

void PcapngWriter::close() {
  if (closed_) return;
  closed_ = true;
  holds_.clear();
  write_out(end_ - begin_);
  file_.close();
}

}  // namespace modtap::captures
