// Big-endian reads off Modbus bytes, the one place they are spelled. Past the end they read 0:
// a damaged frame's fields are still read as far as its bytes go, never beyond.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

namespace modtap {

constexpr uint16_t be16(std::span<const uint8_t> bytes, size_t at) {
  return bytes.size() < at + 2 ? 0 : static_cast<uint16_t>(bytes[at] << 8 | bytes[at + 1]);
}

// The bytes from `at` on, or none past the end.
constexpr std::span<const uint8_t> bytes_from(std::span<const uint8_t> bytes, size_t at) {
  return at < bytes.size() ? bytes.subspan(at) : bytes.subspan(bytes.size());
}

}  // namespace modtap
