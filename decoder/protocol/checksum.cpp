#include "decoder/protocol/checksum.hpp"

#include <algorithm>
#include <array>

namespace modtap {
namespace {

using Table = std::array<uint16_t, 256>;

// One bit through the register with nothing shifted in: S, of which a byte's step through 0x00
// (A, decoder/protocol/checksum.hpp) is S^8.
constexpr uint16_t crc16_bit_step(uint16_t crc) {
  return static_cast<uint16_t>((crc >> 1) ^ ((crc & 1) ? 0xA001 : 0));
}

// tables[0] is the usual byte table; tables[k] advances a byte k positions further, so four
// bytes take four look-ups and no dependency chain between them (slicing-by-4).
constexpr std::array<Table, 4> make_crc_tables() {
  std::array<Table, 4> tables{};
  for (unsigned i = 0; i < 256; ++i) {
    uint16_t crc = static_cast<uint16_t>(i);
    for (int bit = 0; bit < 8; ++bit) crc = crc16_bit_step(crc);
    tables[0][i] = crc;
  }
  for (size_t k = 1; k < 4; ++k)
    for (unsigned i = 0; i < 256; ++i)
      tables[k][i] =
          static_cast<uint16_t>((tables[k - 1][i] >> 8) ^ tables[0][tables[k - 1][i] & 0xFF]);
  return tables;
}

constexpr auto crc_tables = make_crc_tables();
constexpr const Table& crc_table = crc_tables[0];

// The byte table's high bytes are all different, so a step through 0x00 can be undone: the
// high byte names the entry, and the entry gives back the byte shifted out.
constexpr Table make_unshift_table() {
  Table entry_of_high_byte{};
  for (unsigned i = 0; i < 256; ++i)
    entry_of_high_byte[crc_table[i] >> 8] = static_cast<uint16_t>(i);
  return entry_of_high_byte;
}

constexpr bool high_bytes_distinct() {
  std::array<bool, 256> seen{};
  for (uint16_t entry : crc_table) {
    if (seen[entry >> 8]) return false;
    seen[entry >> 8] = true;
  }
  return true;
}
static_assert(high_bytes_distinct());

constexpr Table entry_of_high_byte = make_unshift_table();

// The index adds A^-k(b) at the k-th byte. S takes a byte's bit j + 1 to its bit j, and commutes
// with A^-k, so the image of bit j is S^(7-j) of the top bit's image y = A^-k(0x80): the byte's
// high nibble adds the sum of S^(3-i) y over its bits i, and its low nibble the same of S^4 y.
// `nibble_images[half][nibble][byte]` is that sum for one byte of y (it is linear in y): four
// look-ups a byte where eight images each took a step back.
using NibbleImages = std::array<std::array<Table, 16>, 2>;
constexpr NibbleImages make_nibble_images() {
  NibbleImages images{};
  for (unsigned half = 0; half < 2; ++half)
    for (unsigned nibble = 0; nibble < 16; ++nibble)
      for (unsigned byte = 0; byte < 256; ++byte) {
        uint16_t power = static_cast<uint16_t>(byte << (8 * half));  // S^j y, j from 0
        uint16_t sum = 0;
        for (unsigned j = 0; j < 4; ++j) {
          if (nibble >> (3 - j) & 1) sum ^= power;
          power = crc16_bit_step(power);
        }
        images[half][nibble][byte] = sum;
      }
  return images;
}
constexpr NibbleImages nibble_images = make_nibble_images();

// S^4 of a register: its low nibble's feedback, the rest shifted.
constexpr std::array<uint16_t, 16> make_four_bit_feedback() {
  std::array<uint16_t, 16> table{};
  for (uint16_t low = 0; low < 16; ++low) {
    uint16_t crc = low;
    for (int bit = 0; bit < 4; ++bit) crc = crc16_bit_step(crc);
    table[low] = crc;
  }
  return table;
}
constexpr std::array<uint16_t, 16> four_bit_feedback = make_four_bit_feedback();

inline uint16_t nibble_image(unsigned nibble, uint16_t y) {
  return nibble_images[0][nibble][y & 0xFF] ^ nibble_images[1][nibble][y >> 8];
}

// A^-1: the state that a step through 0x00 takes to `crc`.
uint16_t crc16_unshift(uint16_t crc) {
  const uint16_t low = entry_of_high_byte[crc >> 8];
  return static_cast<uint16_t>(((crc ^ crc_table[low]) << 8) | low);
}

}  // namespace

uint16_t crc16_step(uint16_t crc, uint8_t byte) {
  return static_cast<uint16_t>((crc >> 8) ^ crc_table[(crc ^ byte) & 0xFF]);
}

namespace {

// Four bytes a step through the sliced tables; inlined into both callers below.
[[gnu::always_inline]] inline uint16_t crc16_sliced(const uint8_t* p, size_t n, uint16_t crc) {
  for (; n >= 4; n -= 4, p += 4) {
    const unsigned w = crc ^ (p[0] | p[1] << 8);
    crc = static_cast<uint16_t>(crc_tables[3][w & 0xFF] ^ crc_tables[2][w >> 8] ^
                                crc_tables[1][p[2]] ^ crc_tables[0][p[3]]);
  }
  for (; n > 0; --n, ++p) crc = crc16_step(crc, *p);
  return crc;
}

}  // namespace

uint16_t crc16(std::span<const uint8_t> bytes, uint16_t crc) {
  return crc16_sliced(bytes.data(), bytes.size(), crc);
}

// One call with the CRC's loop in it: the framer asks it at every start in junk.
bool rtu_crc_holds(std::span<const uint8_t> adu) {
  return crc16_sliced(adu.data(), adu.size() - 2, 0xFFFF) == wire_crc(adu);
}

// Kept out of line: inlined, it swells the framer's weighing of every frame.
[[gnu::noinline]] size_t crc16_back_to_start(std::span<const uint8_t> bytes, size_t first) {
  uint16_t crc = 0xFFFF;
  for (size_t k = 0; k < bytes.size();) {
    crc = crc16_step(crc, bytes[k]);
    if (++k >= first && crc == 0xFFFF) return k;
  }
  return 0;
}

CrcIndex::CrcIndex() : newest_(chain_mask + 1, none) {
  restart(0);
}

void CrcIndex::restart(uint64_t origin) {
  unlink(0, ends_.size());
  base_ = origin;
  ends_.assign(1, 0);
  starts_.clear();
  same_before_.assign(1, none);  // the value 0 is in chain 0, now empty
  newest_[0] = origin;
  top_bit_image_ = 0x80;
  unshifted_init_ = 0xFFFF;
}

// A chain whose newest end is among ends_[first, last) starts afresh: the chains' newest ends
// stay inside the index, so a restart anywhere, back or on, meets no chain of an index before
// it. Each end is unlinked at most once after it was appended: this costs less than indexing.
void CrcIndex::unlink(size_t first, size_t last) {
  for (size_t i = first; i < last; ++i) {
    uint64_t& newest = newest_[ends_[i] & chain_mask];
    if (newest == base_ + i) newest = none;
  }
}

void CrcIndex::append(std::span<const uint8_t> bytes) {
  uint16_t w = ends_.back();
  uint64_t offset = base_ + ends_.size();  // of the end being added
  uint16_t top = top_bit_image_;
  for (uint8_t byte : bytes) {
    starts_.push_back(static_cast<uint16_t>(w ^ unshifted_init_));
    const uint16_t top4 = static_cast<uint16_t>((top >> 4) ^ four_bit_feedback[top & 0xF]);
    w ^= static_cast<uint16_t>(nibble_image(byte >> 4, top) ^ nibble_image(byte & 0xF, top4));
    top = crc16_unshift(top);
    unshifted_init_ = crc16_unshift(unshifted_init_);
    ends_.push_back(w);
    same_before_.push_back(newest_[w & chain_mask]);
    newest_[w & chain_mask] = offset++;
  }
  top_bit_image_ = top;
}

void CrcIndex::drop_before(uint64_t offset) {
  // Nothing indexed since the last restart (a frame its length rules found, as most are): the
  // next search restarts the index where it begins, past anything forgotten here.
  if (offset <= base_ || starts_.empty()) return;
  if (offset >= end()) return restart(offset);
  const auto count = static_cast<ptrdiff_t>(offset - base_);
  unlink(0, static_cast<size_t>(count));
  ends_.erase(ends_.begin(), ends_.begin() + count);
  starts_.erase(starts_.begin(), starts_.begin() + count);
  same_before_.erase(same_before_.begin(), same_before_.begin() + count);
  base_ = offset;
}

bool CrcIndex::chained_ends(uint16_t key, uint64_t first, uint64_t last,
                            std::array<uint64_t, 256>& out, size_t& count) const {
  uint64_t end = newest_[key & chain_mask];
  for (int walked = 0; end != none && end > last; end = same_before_[end - base_])
    if (++walked > max_chain_walk) return false;
  // `first` is at least base_, so an end forgotten by drop_before stops the walk here.
  for (; end != none && end >= first; end = same_before_[end - base_])
    if (ends_[end - base_] == key) out[count++] = end;
  return true;
}

uint8_t lrc(std::span<const uint8_t> bytes) {
  uint8_t sum = 0;
  for (uint8_t b : bytes) sum = static_cast<uint8_t>(sum + b);
  return static_cast<uint8_t>(-sum);
}

}  // namespace modtap
