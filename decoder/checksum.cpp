#include "decoder/checksum.hpp"

#include <array>

namespace modtap::decoder {
namespace {

using Table = std::array<uint16_t, 256>;

// tables[0] is the usual byte table; tables[k] advances a byte k positions further, so four
// bytes take four look-ups and no dependency chain between them (slicing-by-4).
constexpr std::array<Table, 4> make_crc_tables() {
  std::array<Table, 4> tables{};
  for (unsigned i = 0; i < 256; ++i) {
    uint16_t crc = static_cast<uint16_t>(i);
    for (int bit = 0; bit < 8; ++bit) crc = (crc & 1) ? (crc >> 1) ^ 0xA001 : crc >> 1;
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

}  // namespace

uint16_t crc16_step(uint16_t crc, uint8_t byte) {
  return static_cast<uint16_t>((crc >> 8) ^ crc_table[(crc ^ byte) & 0xFF]);
}

uint16_t crc16(std::span<const uint8_t> bytes, uint16_t crc) {
  const uint8_t* p = bytes.data();
  size_t n = bytes.size();
  for (; n >= 4; n -= 4, p += 4) {
    const unsigned w = crc ^ (p[0] | p[1] << 8);
    crc = static_cast<uint16_t>(crc_tables[3][w & 0xFF] ^ crc_tables[2][w >> 8] ^
                                crc_tables[1][p[2]] ^ crc_tables[0][p[3]]);
  }
  for (; n > 0; --n, ++p) crc = crc16_step(crc, *p);
  return crc;
}

uint8_t lrc(std::span<const uint8_t> bytes) {
  uint8_t sum = 0;
  for (uint8_t b : bytes) sum = static_cast<uint8_t>(sum + b);
  return static_cast<uint8_t>(-sum);
}

}  // namespace modtap::decoder
