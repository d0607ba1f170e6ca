#include "output/render.hpp"

#include <gtest/gtest.h>

#include "tools/modtap/progress.hpp"

namespace modtap::output {
namespace {

std::string number(double value, int decimals) {
  fmt::memory_buffer out;
  append_number(out, value, decimals);
  return fmt::to_string(out);
}

// Times print from their nanoseconds: the decimal value is exact, and a half rounds up.
TEST(Fixed, PrintsNanosecondsInALargerUnitFromTheIntegers) {
  EXPECT_EQ(fmt::format("{}", Fixed{14'108'056'500, 9, 6}), "14.108057");  // a half: up
  EXPECT_EQ(fmt::format("{}", Fixed{14'108'056'499, 9, 6}), "14.108056");
  EXPECT_EQ(fmt::format("{}", Fixed{2'291'664, 3, 3}), "2291.664");  // us with 3: exact
  EXPECT_EQ(fmt::format("{}", Fixed{999'500, 6, 3}), "1.000");       // a carry into the units
  EXPECT_EQ(fmt::format("{}", Fixed{0, 9, 6}), "0.000000");
  EXPECT_EQ(fmt::format("{}", Fixed{-1'500, 9, 6}), "-0.000002");  // a clock stepped back
  EXPECT_EQ(fmt::format("{:>11}", Fixed{2'291'664, 9, 6}), "   0.002292");
  EXPECT_EQ(fmt::format("{}", Fixed{1'234'567, 6, 1}), "1.2");  // an odd count of decimals
  EXPECT_EQ(fmt::format("{}", Fixed{99'950'000, 6, 1}), "100.0");
  EXPECT_EQ(fmt::format("{}", Fixed{-7, 0, 0}), "-7");
  EXPECT_EQ(fmt::format("{}", Fixed{9'223'372'036'854'775'807, 9, 6}), "9223372036.854776");
  // The same straight into a buffer, as the text lines put their columns.
  fmt::memory_buffer out;
  put_fixed(out, Fixed{2'291'664, 9, 6}, 11);
  put_fixed(out, Fixed{-1'500, 9, 6});
  put_fixed(out, Fixed{123'456'789'000, 9, 6}, 4);  // wider than its column: all of it
  EXPECT_EQ(fmt::to_string(out), "   0.002292-0.000002123.456789");
}

// JSON's times: the same digits as the integer, the second's part kept from call to call.
TEST(NanosecondsText, PrintsTheIntegerWhateverItKept) {
  NanosecondsText text;
  fmt::memory_buffer out;
  for (const int64_t ns : {int64_t{1'700'000'000'000'000'001}, int64_t{1'700'000'000'999'999'999},
                           int64_t{1'700'000'001'000'000'000}, int64_t{1'700'000'000'000'000'000},
                           int64_t{999'999'999}, int64_t{1'000'000'000}, int64_t{0},
                           int64_t{-5'000'000'001}, INT64_MAX}) {
    out.clear();
    text.put(out, ns);
    EXPECT_EQ(fmt::to_string(out), std::to_string(ns));
  }
}

// Whole values skip fmt's float path and must print as "{:.{}f}" does.
TEST(AppendNumber, PrintsAsFixedPointFormattingDoes) {
  for (const auto& [value, decimals] : std::initializer_list<std::pair<double, int>>{
           {51812, 0}, {-5, 0}, {-0.0, 0}, {60, 2}, {12.345, 1}, {1e20, 0}, {0, 0}})
    EXPECT_EQ(number(value, decimals), fmt::format("{:.{}f}", value, decimals)) << value;
}

TEST(FunctionLabel, NamesPublicCodesAndNumbersOthers) {
  EXPECT_EQ(fmt::format("{}", FunctionLabel{0x83}), "Read Holding Registers");
  EXPECT_EQ(fmt::format("{}", FunctionLabel{0x41}), "Function 0x41");
}

template <typename Append>
std::string appended(Append&& append) {
  fmt::memory_buffer out;
  put(out, "x=");  // after what is already there
  append(out);
  return fmt::to_string(out);
}

TEST(Put, AppendsLabelsNumbersAndHexInPlace) {
  EXPECT_EQ(appended([](auto& out) { put_function_label(out, 0x83); }), "x=Read Holding Registers");
  EXPECT_EQ(appended([](auto& out) { put_function_label(out, 0x41); }), "x=Function 0x41");
  EXPECT_EQ(appended([](auto& out) { put_int(out, -42); }), "x=-42");
  EXPECT_EQ(appended([](auto& out) { put_uint(out, 18446744073709551615u); }),
            "x=18446744073709551615");
  EXPECT_EQ(appended([](auto& out) { put_left_aligned(out, 7, 3); }), "x=7  ");
  EXPECT_EQ(appended([](auto& out) { put_hex4(out, 0x2a0f); }), "x=2A0F");
  EXPECT_EQ(appended([](auto& out) { put_hex(out, 0xff00, 4, false); }), "x=ff00");
  EXPECT_EQ(appended([](auto& out) { put_hex(out, 0x7, 2); }), "x=07");
  // Digits below a second: exactly as many as asked, zeros first, odd counts too.
  EXPECT_EQ(appended([](auto& out) { put_zero_padded(out, 2292, 6); }), "x=002292");
  EXPECT_EQ(appended([](auto& out) { put_zero_padded(out, 999'999'999, 9); }), "x=999999999");
  EXPECT_EQ(appended([](auto& out) { put_zero_padded(out, 0, 9); }), "x=000000000");
  EXPECT_EQ(appended([](auto& out) { put_zero_padded(out, 5, 1); }), "x=5");
  // A number printed twice is copied from where it stands, however the buffer grows between.
  EXPECT_EQ(appended([](auto& out) {
              put_uint(out, 42442);
              put(out, std::string(600, ','));
              put_again(out, 2, 7);
            }),
            "x=42442" + std::string(600, ',') + "42442");
  const uint8_t bytes[] = {0x01, 0xab, 0x00};
  EXPECT_EQ(appended([&](auto& out) { append_hex(out, bytes, false); }), "x=01ab00");
  EXPECT_EQ(appended([&](auto& out) { append_hex(out, bytes, true); }), "x=01 AB 00");
  EXPECT_EQ(appended([](auto& out) { append_hex(out, {}, true); }), "x=");
}

// Control bytes are escaped, quotes and backslashes too; a plain string is copied whole.
TEST(JsonString, EscapesWhatJsonAndTerminalsNeed) {
  EXPECT_EQ(appended([](auto& out) { append_json_string(out, "Hz"); }), "x=\"Hz\"");
  EXPECT_EQ(appended([](auto& out) { append_json_string(out, ""); }), "x=\"\"");
  EXPECT_EQ(appended([](auto& out) { append_json_string(out, "a\"b\\c"); }), "x=\"a\\\"b\\\\c\"");
  EXPECT_EQ(appended([](auto& out) { append_json_string(out, std::string_view("\x01\xff", 2)); }),
            "x=\"\\u0001\\u00ff\"");
}

// JSON is UTF-8: a model's Chinese text stays itself. Bytes that are no well-formed UTF-8 (a
// lone lead byte, an overlong form, a surrogate) read as Latin-1, each its own code point.
TEST(JsonString, PassesUtf8AndEscapesBytesThatAreNone) {
  EXPECT_EQ(appended([](auto& out) { append_json_string(out, "机能代码错误 (51H)"); }),
            "x=\"机能代码错误 (51H)\"");
  EXPECT_EQ(appended([](auto& out) { append_json_string(out, "\xe6\x9c"); }),
            "x=\"\\u00e6\\u009c\"");
  EXPECT_EQ(appended([](auto& out) { append_json_string(out, "\xc0\xaf"); }),
            "x=\"\\u00c0\\u00af\"");
  EXPECT_EQ(appended([](auto& out) { append_json_string(out, "\xed\xa0\x80"); }),
            "x=\"\\u00ed\\u00a0\\u0080\"");
  EXPECT_EQ(appended([](auto& out) { append_json_string(out, "\xf0\x9f\x94\x8c!"); }),
            "x=\"\xf0\x9f\x94\x8c!\"");
}

}  // namespace
}  // namespace modtap::output

namespace modtap::output {
namespace {

// A count takes its noun in the number it needs: "1 bad check", "2 bad checks", "0 bytes".
TEST(Render, ACountTakesItsNounInItsNumber) {
  EXPECT_EQ(counted(1, "bad check", "bad checks"), "1 bad check");
  EXPECT_EQ(counted(2, "bad check", "bad checks"), "2 bad checks");
  EXPECT_EQ(counted(0, "byte", "bytes"), "0 bytes");
}

TEST(ProgressBar, SaysHowFarHowFastAndHowLongIsLeft) {
  EXPECT_EQ(tools::ProgressBar::line(0, 1'200'000'000, 0, 10), "[----------]   0% of 1.20 GB");
  EXPECT_EQ(tools::ProgressBar::line(300'000'000, 1'200'000'000, 10, 10),
            "[##--------]  25% of 1.20 GB, 30.0 MB/s, 30 s left");
  EXPECT_EQ(tools::ProgressBar::line(600'000'000, 1'200'000'000, 600, 10),
            "[#####-----]  50% of 1.20 GB, 1.0 MB/s, 10 min left");
  EXPECT_EQ(tools::ProgressBar::line(5000, 5000, 1, 10), "[##########] 100% of 5.0 kB, 5.0 kB/s");
}

}  // namespace
}  // namespace modtap::output
