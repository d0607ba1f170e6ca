#include "decoder/checksum.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "tests/support/collector.hpp"

namespace modtap::decoder {
namespace {

using testing::hex;

TEST(Crc16, MatchesTheCatalogueCheckValue) {
  // CRC-16/MODBUS in the CRC catalogue: check("123456789") = 0x4B37.
  const std::string text = "123456789";
  EXPECT_EQ(crc16({reinterpret_cast<const uint8_t*>(text.data()), text.size()}), 0x4B37);
}

TEST(Crc16, MatchesTheStandardsExample) {
  // Modbus over Serial Line V1.02, appendix B: 02 07 gives CRC 0x1241 (41 12 on the wire).
  EXPECT_EQ(crc16(hex("0207")), 0x1241);
}

TEST(Crc16, StepwiseEqualsWhole) {
  const auto bytes = hex("01 03 00 00 00 0a");
  uint16_t crc = 0xFFFF;
  for (uint8_t b : bytes) crc = crc16_step(crc, b);
  EXPECT_EQ(crc, crc16(bytes));
  EXPECT_EQ(crc, 0xCDC5);
}

TEST(Crc16, SlicedFormEqualsBytewiseAtEveryLength) {
  std::vector<uint8_t> bytes;
  uint32_t x = 7;
  for (int i = 0; i < 300; ++i) {
    x = x * 1664525 + 1013904223;
    bytes.push_back(static_cast<uint8_t>(x >> 24));
  }
  for (size_t n = 0; n <= bytes.size(); ++n) {
    uint16_t bytewise = 0xFFFF;
    for (size_t i = 0; i < n; ++i) bytewise = crc16_step(bytewise, bytes[i]);
    ASSERT_EQ(crc16({bytes.data(), n}), bytewise) << n;
  }
}

TEST(Crc16, ResidueOfAGoodFrameStaysZeroWithATrailingZero) {
  // Why the framer never trusts a zero residue alone.
  auto frame = hex("01 03 00 00 00 0a c5 cd");
  EXPECT_EQ(crc16(frame), 0);
  frame.push_back(0);
  EXPECT_EQ(crc16(frame), 0);
}

TEST(Lrc, MatchesTheManualsExample) {
  // NTA5000 manual 2.1: 01 03 01 00 00 0A gives LRC F1.
  EXPECT_EQ(lrc(hex("01 03 01 00 00 0a")), 0xF1);
}

}  // namespace
}  // namespace modtap::decoder
