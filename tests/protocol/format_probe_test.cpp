// Telling a line's settings from its traffic: the candidates, the pace check, the health count.
#include "decoder/protocol/format_probe.hpp"

#include <gtest/gtest.h>

namespace modtap {
namespace {

TEST(FormatProbe, CandidatesPutTheCommonSettingsFirstAndRespectFixedOnes) {
  const auto all = candidate_formats(std::nullopt, std::nullopt, 8, 1);
  ASSERT_EQ(all.size(), 24u);
  EXPECT_EQ(describe(all[0]), "19200 8E1");
  EXPECT_EQ(describe(all[3]), "9600 8E1");
  const auto fixed = candidate_formats(9600, std::nullopt, 8, 1);
  ASSERT_EQ(fixed.size(), 3u);
  EXPECT_EQ(describe(fixed[1]), "9600 8N1");
  const auto odd_baud = candidate_formats(250000, Parity::none, 8, 2);
  ASSERT_EQ(odd_baud.size(), 1u);
  EXPECT_EQ(describe(odd_baud[0]), "250000 8N2");
}

TEST(FormatProbe, ReadsFasterThanTheBaudAllowsAreNoticed) {
  const std::vector<uint8_t> eight(8, 0x11);
  // 8 bytes at 9600 8E1 take 9.2 ms on the wire; these reads come 1 ms apart: a faster line.
  ChunkPace fast(SerialFormat{9600, 8, Parity::even, 1});
  for (int i = 0; i < 20; ++i) fast.add({0, i * 1'000'000LL, eight});
  EXPECT_TRUE(fast.too_fast());
  ChunkPace right(SerialFormat{115200, 8, Parity::even, 1});
  for (int i = 0; i < 20; ++i) right.add({0, i * 1'000'000LL, eight});
  EXPECT_FALSE(right.too_fast());
}

// One byte a read, as a sniffer's pcap stamps each byte as it ends: a 19200 line's bytes,
// 573 us apart, are too fast for 9600 (1,146 us a byte), never for 19200 itself.
TEST(FormatProbe, OneByteReadsAtTwiceTheBaudAreTooFast) {
  const std::vector<uint8_t> one{0x01};
  const auto bytes_573_us_apart = [&](const SerialFormat& format) {
    ChunkPace pace(format);
    for (int i = 0; i < 40; ++i) pace.add({0, i * 573'000LL, one});
    return pace.too_fast();
  };
  EXPECT_TRUE(bytes_573_us_apart(SerialFormat{9600, 8, Parity::even, 1}));
  EXPECT_FALSE(bytes_573_us_apart(SerialFormat{19200, 8, Parity::even, 1}));
}

TEST(FormatProbe, LineHealthCountsBytesInGoodFrames) {
  LineHealth health;
  const std::vector<uint8_t> bytes(40, 0);
  Frame good;
  good.raw = bytes;
  good.check_ok = true;
  Noise noise;
  noise.raw = std::span<const uint8_t>(bytes).first(30);
  health.on_frame(good);
  health.on_noise(noise);
  EXPECT_EQ(health.bytes, 70u);
  EXPECT_FALSE(health.looks_wrong());
  health.on_noise(noise);
  EXPECT_TRUE(health.looks_wrong());  // 40 of 100 bytes
}

}  // namespace
}  // namespace modtap
