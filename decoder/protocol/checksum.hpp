// The two Modbus serial checks: CRC-16/MODBUS for RTU and LRC for ASCII.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace modtap {

// CRC-16/MODBUS (poly 0xA001 reflected, init 0xFFFF). On the wire the low byte goes first.
uint16_t crc16(std::span<const uint8_t> bytes, uint16_t crc = 0xFFFF);
uint16_t crc16_step(uint16_t crc, uint8_t byte);
// The first k >= `first` where the CRC of the first k bytes is the start value again, or 0. Of a
// span whose CRC holds, the tail from there holds too: its own CRC is the span's.
size_t crc16_back_to_start(std::span<const uint8_t> bytes, size_t first);

// The CRC carried in the last two bytes of an RTU ADU (low byte first).
inline uint16_t wire_crc(std::span<const uint8_t> adu) {
  return static_cast<uint16_t>(adu[adu.size() - 2] | (adu[adu.size() - 1] << 8));
}

// Whether an RTU ADU (at least its two CRC bytes) carries the CRC of the bytes before it.
bool rtu_crc_holds(std::span<const uint8_t> adu);

// Lists, in a step or two, where the bytes of a stream from a given start end in their own CRC,
// so a framer can look for frame ends in junk without running the CRC from every offset.
//
// The register is linear: with A the step through a 0x00 byte, a byte b takes the state s to
// A(s ^ b). Along any run of the register, A^-k(s) ^ W_k stays the same, where W_0 = 0 and
// W_k+1 = W_k ^ A^-k(b_k). A frame [a, n) takes 0xFFFF to the residue 0 exactly when
// W_n == W_a ^ A^-a(0xFFFF): one value per end, one per start, compared.
//
// The values are relative to where the index (re)started, so it can skip what nobody searches.
class CrcIndex {
 public:
  CrcIndex();
  // Covers nothing, from stream offset `origin` on.
  void restart(uint64_t origin);
  // The bytes at offsets end() and on.
  void append(std::span<const uint8_t> bytes);
  // Forgets the stream before `offset`.
  void drop_before(uint64_t offset);
  uint64_t begin() const { return base_; }
  uint64_t end() const { return base_ + starts_.size(); }

  // Calls found(end) for each end in [first, last], in order, that makes [begin, end) good.
  template <class Found>
  void good_ends(uint64_t begin, uint64_t first, uint64_t last, Found&& found) const;

 private:
  static constexpr uint64_t none = UINT64_MAX;
  static constexpr int max_chain_walk = 32;
  // The index reaches at most a search (256 bytes) beyond the start searched, so a few
  // thousand chains keep each one short; a chain holds neighbouring values, told apart by
  // comparing.
  static constexpr uint16_t chain_mask = (1 << 12) - 1;
  // Ends in [first, last] whose value is `key`, newest first, into `out`; false when the chain
  // is too long to walk (a long run of one value), and the caller compares one by one.
  bool chained_ends(uint16_t key, uint64_t first, uint64_t last, std::array<uint64_t, 256>& out,
                    size_t& count) const;

  std::vector<uint16_t> ends_{0};  // W at the offsets base_ .. end, the end included
  std::vector<uint16_t> starts_;   // W_a ^ A^-a(0xFFFF) at the offsets base_ .. end - 1
  // Hash chains over ends_: the newest end offset in each chain (inside the index, or none),
  // and for each end the one before it in its chain; an offset below base_ (forgotten, or from
  // before a restart) ends a walk.
  std::vector<uint64_t> newest_;
  void unlink(size_t first, size_t last);
  std::vector<uint64_t> same_before_;
  uint64_t base_ = 0;
  uint16_t top_bit_image_ = 0x80;     // A^-k(0x80): the images of a byte's bits follow from it
  uint16_t unshifted_init_ = 0xFFFF;  // A^-k(0xFFFF)
};

template <class Found>
void CrcIndex::good_ends(uint64_t begin, uint64_t first, uint64_t last, Found&& found) const {
  const uint16_t key = starts_[begin - base_];
  std::array<uint64_t, 256> chained;
  size_t count = 0;
  if (last - first < chained.size() && chained_ends(key, first, last, chained, count)) {
    while (count > 0) found(chained[--count]);
    return;
  }
  const uint16_t* values = ends_.data() - base_;
  for (uint64_t at = first; at <= last; ++at)
    if (values[at] == key) found(at);
}

// LRC: two's complement of the 8-bit sum of the bytes.
uint8_t lrc(std::span<const uint8_t> bytes);

}  // namespace modtap
