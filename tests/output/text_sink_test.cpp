#include "output/text_sink.hpp"

#include <cstdio>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace modtap::output {
namespace {

// The time column of a text line for each start time, as the sink prints it.
std::vector<std::string> time_columns(TimeFormat format, const std::vector<int64_t>& starts) {
  FILE* stream = std::tmpfile();
  std::vector<std::string> columns;
  {
    captures::OutputFile file(stream, "test");
    Output out(file);
    const std::vector<ChannelInfo> channels{{"bus", ChannelRole::bus}};
    TextSink sink(out, channels, TextOptions{.time = format});
    static const uint8_t read[] = {0x01, 0x03, 0x00, 0x00, 0x00, 0x01, 0x84, 0x0A};
    Frame frame;
    frame.raw = frame.adu = read;
    frame.role = Role::request;
    frame.check_ok = true;
    for (const int64_t t : starts) {
      frame.t_ns = t;
      frame.end_ns = t + 4'000'000;
      ++frame.index;
      sink.on_frame(frame);
    }
    out.flush();
  }
  std::rewind(stream);
  char line[512];
  while (std::fgets(line, sizeof line, stream))
    columns.emplace_back(std::string(line).substr(6, 12));
  std::fclose(stream);
  return columns;
}

// Seconds with six decimals, right-aligned to eleven characters: rounded half up from the
// nanoseconds, the whole seconds made once a second and the microseconds each line.
TEST(TextSink, PrintsTheTimeColumnFromTheNanoseconds) {
  const int64_t first = 1'700'000'000'000'000'000;
  EXPECT_EQ(
      time_columns(TimeFormat::relative,
                   {first, first + 2'291'664, first + 1'999'999'500, first + 12'345'678'901,
                    first - 1'500, first + 12'345'679'400, first + 10'000'000'000'000}),
      (std::vector<std::string>{"    0.000000", "    0.002292", "    2.000000", "   12.345679",
                                "   -0.000002", "   12.345679", " 10000.00000"}));
  EXPECT_EQ(time_columns(TimeFormat::delta, {first, first + 2'291'664, first + 2'291'664,
                                             first + 3'002'291'664, first}),
            (std::vector<std::string>{"    0.000000", "    0.002292", "    0.000000",
                                      "    3.000000", "   -3.002292"}));
}

// A noise line counts its bytes in the number they take, and shows them in capitals, as the
// check column and the manuals write bytes.
TEST(TextSink, NoiseSaysItsBytesAsPeopleWriteThem) {
  FILE* stream = std::tmpfile();
  {
    captures::OutputFile file(stream, "test");
    Output out(file);
    const std::vector<ChannelInfo> channels{{"bus", ChannelRole::bus}};
    TextSink sink(out, channels, TextOptions{});
    static const uint8_t glitch[] = {0xFF}, junk[] = {0xAB, 0x0C};
    Noise noise;
    noise.raw = glitch;
    noise.reason = NoiseReason::glitch;
    sink.on_noise(noise);
    noise.raw = junk;
    noise.reason = NoiseReason::junk;
    sink.on_noise(noise);
    out.flush();
  }
  std::rewind(stream);
  char line[512];
  std::vector<std::string> lines;
  while (std::fgets(line, sizeof line, stream)) lines.emplace_back(line);
  std::fclose(stream);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_NE(lines[0].find("noise 1 byte (glitch): FF\n"), std::string::npos) << lines[0];
  EXPECT_NE(lines[1].find("noise 2 bytes (junk): AB 0C\n"), std::string::npos) << lines[1];
}

}  // namespace
}  // namespace modtap::output
