// The RTU and ASCII examples printed in the device manuals (../shared/seeds), byte for byte,
// including the ones the manuals got wrong: those must show as bad checks with the right value.
#include <cctype>
#include <ostream>
#include <string>
#include <string_view>
#include <utility>

#include <gtest/gtest.h>

#include "decoder/protocol/function_codes.hpp"
#include "tests/support/collector.hpp"

namespace modtap {
namespace {

using testing::analyze_untimed;
using testing::hex;

struct Example {
  const char* source;
  const char* bytes;
  bool check_ok;
  uint16_t expected_check;  // CRC register value: the low byte goes first on the wire
};

// How GoogleTest lists a parameter: the example's words, not its bytes.
void PrintTo(const Example& example, std::ostream* out) {
  *out << example.source;
}

class ManualExample : public ::testing::TestWithParam<Example> {};

TEST_P(ManualExample, IsOneFrameWithTheRightVerdict) {
  const Example& e = GetParam();
  const auto bytes = hex(e.bytes);
  const auto out = analyze_untimed(bytes);
  ASSERT_EQ(out.stream().size(), 1u) << e.source;
  const auto frame = out.stream()[0];
  EXPECT_EQ(frame.type, testing::Record::Type::frame) << e.source;
  EXPECT_EQ(frame.raw, bytes) << e.source;
  EXPECT_EQ(frame.check_ok, e.check_ok) << e.source;
  EXPECT_EQ(frame.expected_check, e.expected_check) << e.source;
}

// "000 FC03 request, corrected (...)" -> Nta5000_FC03RequestCorrected: the manual's device, then
// the example in words, so a failure names the example.
std::string example_name(const ::testing::TestParamInfo<Example>& info) {
  static const std::pair<std::string_view, std::string_view> manuals[] = {
      {"000", "Nta5000_"}, {"002", "N3_"}, {"004", "Gd20_"}};
  std::string_view text = info.param.source;
  text = text.substr(0, text.find(" ("));
  std::string name;
  for (const auto& [file, device] : manuals)
    if (text.starts_with(file)) name = device;
  bool word_start = true;
  for (char c : text.substr(text.find(' ') + 1)) {
    const auto byte = static_cast<unsigned char>(c);
    if (!std::isalnum(byte)) {
      word_start = word_start || c == ' ';
      continue;
    }
    name += word_start ? static_cast<char>(std::toupper(byte)) : c;
    word_start = false;
  }
  return name;
}

INSTANTIATE_TEST_SUITE_P(
    Manuals, ManualExample,
    ::testing::Values(
        // 000 NTA5000 (English)
        Example{"000 FC03 request as printed (address A023 instead of 2523)",
                "01 03 a0 23 00 01 57 c0", true, 0xC057},
        Example{"000 FC03 request with the right address and the printed CRC",
                "01 03 25 23 00 01 57 c0", false, 0xCC7E},
        Example{"000/001 FC03 request, corrected", "01 03 25 23 00 01 7e cc", true, 0xCC7E},
        Example{"000 FC03 response", "01 03 02 07 d0 bb e8", true, 0xE8BB},
        Example{"000 FC03 exception", "01 83 52 c0 cd", true, 0xCDC0},
        Example{"000 error-code section", "02 83 52 30 cd", true, 0xCD30},
        Example{"000 FC08 loop-back", "01 08 00 00 a5 37 da 8d", true, 0x8DDA},
        Example{"000 FC08 exception", "01 88 20 47 d8", true, 0xD847},
        Example{"000 FC06 write 60.00 Hz", "01 06 25 02 17 70 2d 12", true, 0x122D},
        Example{"000 FC06 exception", "01 86 52 c3 9d", true, 0x9DC3},
        Example{"000 FC10 request", "01 10 25 01 00 02 04 00 01 17 70 cb 26", true, 0x26CB},
        Example{"000 FC10 response", "01 10 25 01 00 02 1b 04", true, 0x041B},
        Example{"000 FC10 exception", "01 90 52 cd fd", true, 0xFDCD},
        // 002 N3
        Example{"002 error example as printed (CRC of 01 83 52)", "02 83 52 c0 cd", false, 0xCD30},
        Example{"002 FC03 response as printed", "01 03 02 17 70 af 82", false, 0x50B6},
        Example{"002 FC03 response, corrected", "01 03 02 17 70 b6 50", true, 0x50B6},
        // 004 GD20
        Example{"004 FC03 request", "01 03 00 04 00 02 85 ca", true, 0xCA85},
        Example{"004 FC03 response", "01 03 04 13 88 00 00 7e 9d", true, 0x9D7E},
        Example{"004 FC06 request", "02 06 00 04 13 88 c5 6e", true, 0x6EC5},
        Example{"004 FC08 loop-back", "01 08 00 00 12 ab ad 14", true, 0x14AD},
        Example{"004 FC10 request as printed (CRC of the FC06 example)",
                "02 10 00 04 00 02 04 13 88 00 32 c5 6e", false, 0x63F8},
        Example{"004 FC10 response as printed", "02 10 00 04 00 02 c5 6e", false, 0x3A00},
        Example{"004 FC10 request, corrected", "02 10 00 04 00 02 04 13 88 00 32 f8 63", true,
                0x63F8}),
    example_name);

TEST(ManualAsciiExample, Nta5000ReadDecodesWithItsLrc) {
  // 000, 4.1 ASCII: ":010325230001B3" CR LF, and the response ":0103021770" LRC 73.
  const std::string request = ":010325230001B3\r\n", response = ":01030217707 3\r\n";
  std::vector<uint8_t> bytes(request.begin(), request.end());
  for (char c : response)
    if (c != ' ') bytes.push_back(static_cast<uint8_t>(c));
  const auto out = analyze_untimed(bytes, {}, ModeChoice::ascii);
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_TRUE(frames[0].check_ok);
  EXPECT_EQ(frames[0].role, Role::request);
  EXPECT_TRUE(frames[1].check_ok);
  EXPECT_EQ(frames[1].role, Role::response);
  EXPECT_EQ(frames[1].request, frames[0].index);
}

TEST(ManualAsciiExample, Nta5000Fc08ExceptionPrintedLrcIsBad) {
  // 000, 4.1 ASCII, FC08 exception: 01 88 20 with LRC printed as 37H 35H ("75"); the LRC of
  // 01 88 20 is 57H, as 001 prints it. The printed frame is the exception with a bad check.
  for (const auto& [text, good] : {std::pair{":01882075\r\n", false}, {":01882057\r\n", true}}) {
    const std::string line = text;
    const auto out = analyze_untimed({line.begin(), line.end()}, {}, ModeChoice::ascii);
    ASSERT_EQ(out.stream().size(), 1u) << line;
    const auto frame = out.stream()[0];
    EXPECT_EQ(frame.type, testing::Record::Type::frame) << line;
    EXPECT_EQ(frame.check_ok, good) << line;
    EXPECT_EQ(frame.expected_check, 0x57) << line;
    EXPECT_EQ(frame.role, Role::response) << line;
  }
}

}  // namespace
}  // namespace modtap
