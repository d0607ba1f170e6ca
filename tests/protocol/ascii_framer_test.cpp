#include "decoder/protocol/ascii_framer.hpp"

#include <gtest/gtest.h>

#include <string>

#include "tests/support/collector.hpp"

namespace modtap {
namespace {

using testing::analyze_untimed;
using testing::expect_same_at_every_split;
using testing::Record;

std::vector<uint8_t> bytes(const std::string& s) {
  return {s.begin(), s.end()};
}

TEST(AsciiFramer, FramesColonToCrLfAndChecksTheLrc) {
  const auto out = analyze_untimed(bytes(":010300000001FB\r\n"), {}, ModeChoice::ascii);
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_TRUE(frames[0].check_ok);
  EXPECT_EQ(frames[0].raw, bytes(":010300000001FB\r\n"));
}

// Each stray ':' starts a frame that never ends; a run of them, or of junk, is one record, as
// a run of junk is in RTU, up to a frame's 513 characters: 20 MB of ':' is not 20 million.
TEST(AsciiFramer, RunsOfNoiseAreOneRecordUpToAFramesLength) {
  const std::string good = ":010300000001FB\r\n";
  const auto out = analyze_untimed(bytes(std::string(2000, ':') + good + "junk:01" + good), {},
                                   ModeChoice::ascii);
  const auto noise = out.noise();
  ASSERT_EQ(noise.size(), 5u);
  size_t colons = 0;
  for (size_t i = 0; i < 4; ++i) {
    EXPECT_LE(noise[i].raw.size(), AsciiFramer::max_frame_chars);
    EXPECT_EQ(noise[i].reason, NoiseReason::truncated);
    colons += noise[i].raw.size();
  }
  EXPECT_EQ(colons, 2000u);
  EXPECT_EQ(noise[4].raw, bytes("junk:01"));  // junk, then a frame's start: junk
  EXPECT_EQ(noise[4].reason, NoiseReason::junk);
  EXPECT_EQ(out.frames().size(), 2u);
}

TEST(AsciiFramer, FramesReservedAddressesAsRtuDoes) {
  // N3 allows stations up to 254; 248-255 are reserved by Modbus but still frames.
  const auto out =
      analyze_untimed(bytes(":FE0301200001DD\r\n:FE03020005F8\r\n"), {}, ModeChoice::ascii);
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_TRUE(frames[0].check_ok);
  EXPECT_EQ(frames[0].role, Role::request);
  EXPECT_EQ(frames[1].role, Role::response);
  EXPECT_EQ(frames[1].request, frames[0].index);
}

TEST(AsciiFramer, ReportsABadLrcWithTheExpectedValue) {
  const auto out = analyze_untimed(bytes(":010300000001FA\r\n"), {}, ModeChoice::ascii);
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_FALSE(frames[0].check_ok);
  EXPECT_EQ(frames[0].expected_check, 0xFB);
}

TEST(AsciiFramer, TurnsJunkBeforeTheColonIntoNoise) {
  const auto input = bytes("xx\x01:010300000001FB\r\n");
  const auto out = analyze_untimed(input, {}, ModeChoice::ascii);
  ASSERT_EQ(out.stream().size(), 2u);
  EXPECT_EQ(out.stream()[0].type, Record::Type::noise);
  EXPECT_EQ(out.stream()[0].raw, bytes("xx\x01"));
  EXPECT_EQ(out.bytes_of(0), input);
}

TEST(AsciiFramer, EndsAFrameThatNeverSeesCrLfAtTheNextColon) {
  const auto input = bytes(":0103000000:010300000001FB\r\n");
  const auto out = analyze_untimed(input, {}, ModeChoice::ascii);
  ASSERT_EQ(out.stream().size(), 2u);
  EXPECT_EQ(out.stream()[0].reason, NoiseReason::truncated);
  EXPECT_TRUE(out.stream()[1].check_ok);
}

TEST(AsciiFramer, BoundsAColonWithNoEnd) {
  std::string endless = ":";
  endless.append(5000, '0');
  const auto out = analyze_untimed(bytes(endless), {}, ModeChoice::ascii);
  EXPECT_EQ(out.bytes_of(0), bytes(endless));
  ASSERT_FALSE(out.records.empty());
  EXPECT_EQ(out.stream()[0].reason, NoiseReason::overlong);
  for (const auto& r : out.records) EXPECT_LE(r.raw.size(), AsciiFramer::max_frame_chars);
}

TEST(AsciiFramer, RejectsCharactersThatAreNotHex) {
  const auto out = analyze_untimed(bytes(":01030000000G\r\n"), {}, ModeChoice::ascii);
  ASSERT_EQ(out.stream().size(), 1u);
  EXPECT_EQ(out.stream()[0].reason, NoiseReason::bad_hex);
}

TEST(AsciiFramer, AutomaticModeRecognisesAscii) {
  std::string text;
  for (int i = 0; i < 4; ++i) text += ":010300000001FB\r\n:0103020005F5\r\n";
  std::string clean;
  for (char c : text)
    if (c != ' ') clean.push_back(c);
  const auto out = analyze_untimed(bytes(clean), {}, ModeChoice::automatic);
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 8u);
  for (const auto& f : frames) EXPECT_TRUE(f.check_ok);
  EXPECT_EQ(frames[1].role, Role::response);
  EXPECT_EQ(frames[1].request, frames[0].index);
}

TEST(AsciiFramer, GivesTheSameRecordsHoweverTheReadsSplitTheBytes) {
  // A request and its answer, an exception, a bad LRC, junk between frames, a frame cut by the
  // next colon, non-hex inside a frame, a lone CR and LF, and a broadcast: cut at every pair of
  // offsets, the framer must find the same records as in one piece.
  const auto input = bytes(
      ":010300000001FB\r\n:0103020005F5\r\nxx:0183027A\r\n:010300000001FA\r\n\r"
      ":0106000\n:01030000000G\r\n:000600010003F6\r\n:0103");
  const auto whole = analyze_untimed(input, {}, ModeChoice::ascii);
  ASSERT_GE(whole.frames().size(), 4u);
  EXPECT_EQ(whole.bytes_of(0), input);
  expect_same_at_every_split(input, ModeChoice::ascii, true);
}

}  // namespace
}  // namespace modtap
