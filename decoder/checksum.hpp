// The two Modbus serial checks: CRC-16/MODBUS for RTU and LRC for ASCII.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

namespace modtap::decoder {

// CRC-16/MODBUS (poly 0xA001 reflected, init 0xFFFF). On the wire the low byte goes first.
uint16_t crc16(std::span<const uint8_t> bytes, uint16_t crc = 0xFFFF);
uint16_t crc16_step(uint16_t crc, uint8_t byte);

// The CRC carried in the last two bytes of an RTU ADU (low byte first).
inline uint16_t wire_crc(std::span<const uint8_t> adu) {
  return static_cast<uint16_t>(adu[adu.size() - 2] | (adu[adu.size() - 1] << 8));
}

// LRC: two's complement of the 8-bit sum of the bytes.
uint8_t lrc(std::span<const uint8_t> bytes);

}  // namespace modtap::decoder
