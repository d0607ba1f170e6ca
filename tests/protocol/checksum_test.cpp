#include "decoder/protocol/checksum.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "tests/support/collector.hpp"

namespace modtap {
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

// `size` bytes of a linear congruential generator from `seed`: the same on every run.
std::vector<uint8_t> random_bytes(size_t size, uint32_t seed) {
  std::vector<uint8_t> bytes;
  uint32_t x = seed;
  for (size_t i = 0; i < size; ++i) {
    x = x * 1664525 + 1013904223;
    bytes.push_back(static_cast<uint8_t>(x >> 24));
  }
  return bytes;
}

TEST(Crc16, SlicedFormEqualsBytewiseAtEveryLength) {
  const std::vector<uint8_t> bytes = random_bytes(300, 7);
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

// The framer's test of a good span for a good frame at its end: the tail of a good span is good
// exactly where the CRC of the bytes before it is back at its start value.
TEST(Crc16, TheTailOfAGoodSpanIsGoodWhereTheCrcIsBackAtItsStart) {
  std::vector<uint8_t> bytes = random_bytes(200, 11);
  const uint16_t crc = crc16(bytes);
  bytes.push_back(static_cast<uint8_t>(crc & 0xFF));
  bytes.push_back(static_cast<uint8_t>(crc >> 8));
  size_t tails = 0;
  for (size_t start = 1; start + 2 <= bytes.size(); ++start) {
    const bool good = crc16({bytes.data() + start, bytes.size() - start}) == 0;
    const bool back = crc16({bytes.data(), start}) == 0xFFFF;
    ASSERT_EQ(good, back) << start;
    EXPECT_EQ(crc16_back_to_start(bytes, start) == start, back) << start;
    tails += good;
  }
  EXPECT_EQ(crc16_back_to_start(bytes, 1), 0u);  // none among these bytes, as 1 in 65,536
  EXPECT_EQ(tails, 0u);
  // A cut answer and a glitch whose bytes take the CRC back to its start, then a request.
  const auto span = hex("11 03 0a 12 40 a2 00 22 03 00 10 00 01 82 9c");
  EXPECT_EQ(crc16(span), 0);
  EXPECT_EQ(crc16_back_to_start(span, 1), 7u);
  EXPECT_EQ(crc16_back_to_start(span, 8), 0u);
}

// Random bytes with good frames planted at random places, and a run of zeros after one of them
// (every zero keeps its residue zero: one value repeated, the index's longest chain).
std::vector<uint8_t> bytes_with_planted_frames(size_t size, uint32_t seed) {
  std::vector<uint8_t> bytes;
  uint32_t x = seed;
  auto next = [&x] { return x = x * 1664525 + 1013904223; };
  for (size_t i = 0; i < size; ++i) bytes.push_back(static_cast<uint8_t>(next() >> 24));
  auto plant = [&bytes](size_t at, size_t length) {
    const uint16_t crc = crc16({bytes.data() + at, length});
    bytes[at + length] = static_cast<uint8_t>(crc & 0xFF);
    bytes[at + length + 1] = static_cast<uint8_t>(crc >> 8);
  };
  for (int planted = 0; planted < 40; ++planted) {
    const size_t length = 2 + next() % 250;
    plant(next() % (size - length - 2), length);
  }
  plant(size / 2, 6);
  std::fill_n(bytes.begin() + size / 2 + 8, 300, 0);
  return bytes;
}

TEST(CrcIndex, TellsEveryGoodSpanAsTheCrcDoes) {
  const auto bytes = bytes_with_planted_frames(3000, 11);
  CrcIndex index;
  // Fed in uneven pieces, forgetting what lies behind as a framer does.
  size_t fed = 0;
  uint64_t dropped = 0;
  size_t good_spans = 0;
  for (size_t piece = 1; fed < bytes.size(); piece = piece * 3 % 701 + 1) {
    const size_t n = std::min(piece, bytes.size() - fed);
    index.append({bytes.data() + fed, n});
    fed += n;
    for (uint64_t begin = dropped; begin + 4 <= fed; ++begin) {
      const uint64_t last = std::min<uint64_t>(fed, begin + 256);
      std::vector<uint64_t> expected;
      for (uint64_t end = begin + 4; end <= last; ++end)
        if (crc16({bytes.data() + begin, end - begin}) == 0) expected.push_back(end);
      std::vector<uint64_t> found;
      index.good_ends(begin, begin + 4, last, [&](uint64_t end) { found.push_back(end); });
      ASSERT_EQ(found, expected) << "from " << begin << " with " << fed << " bytes";
      good_spans += expected.size();
    }
    dropped = fed > 600 ? fed - 600 : 0;
    index.drop_before(dropped);
  }
  EXPECT_GT(good_spans, 300u);  // the zero run alone gives one per zero
}

// A framer restarts the index where its next search begins: back before where the last one
// went, or past it. Whatever the index held before, it tells the spans the CRC does.
TEST(CrcIndex, ARestartAnywhereTellsWhatTheCrcDoes) {
  const auto bytes = bytes_with_planted_frames(3000, 12);
  CrcIndex index;
  uint32_t x = 5;
  auto next = [&x] { return x = x * 1664525 + 1013904223; };
  size_t good_spans = 0;
  for (int restart = 0; restart < 200; ++restart) {
    const uint64_t origin = next() % (bytes.size() - 300);
    const uint64_t fed = origin + 1 + next() % 299;
    index.restart(origin);
    index.append({bytes.data() + origin, static_cast<size_t>(fed - origin)});
    for (uint64_t begin = origin; begin + 4 <= fed; ++begin) {
      std::vector<uint64_t> expected, found;
      uint16_t crc = 0xFFFF;
      for (uint64_t end = begin + 1; end <= fed; ++end)
        if ((crc = crc16_step(crc, bytes[end - 1])) == 0 && end >= begin + 4)
          expected.push_back(end);
      index.good_ends(begin, begin + 4, fed, [&](uint64_t end) { found.push_back(end); });
      ASSERT_EQ(found, expected) << "from " << begin << " after a restart at " << origin;
      good_spans += expected.size();
    }
  }
  EXPECT_GT(good_spans, 100u);
}

TEST(Lrc, MatchesTheManualsExample) {
  // NTA5000 manual 2.1: 01 03 01 00 00 0A gives LRC F1.
  EXPECT_EQ(lrc(hex("01 03 01 00 00 0a")), 0xF1);
}

}  // namespace
}  // namespace modtap
