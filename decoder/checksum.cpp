#include "decoder/checksum.hpp"

#include <array>

namespace modtap::decoder {
namespace {

constexpr std::array<uint16_t, 256> make_crc_table() {
  std::array<uint16_t, 256> table{};
  for (unsigned i = 0; i < 256; ++i) {
    uint16_t crc = static_cast<uint16_t>(i);
    for (int bit = 0; bit < 8; ++bit) crc = (crc & 1) ? (crc >> 1) ^ 0xA001 : crc >> 1;
    table[i] = crc;
  }
  return table;
}

constexpr auto crc_table = make_crc_table();

}  // namespace

uint16_t crc16_step(uint16_t crc, uint8_t byte) {
  return static_cast<uint16_t>((crc >> 8) ^ crc_table[(crc ^ byte) & 0xFF]);
}

uint16_t crc16(std::span<const uint8_t> bytes, uint16_t crc) {
  for (uint8_t b : bytes) crc = crc16_step(crc, b);
  return crc;
}

uint8_t lrc(std::span<const uint8_t> bytes) {
  uint8_t sum = 0;
  for (uint8_t b : bytes) sum = static_cast<uint8_t>(sum + b);
  return static_cast<uint8_t>(-sum);
}

}  // namespace modtap::decoder
