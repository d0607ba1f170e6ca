#include "decoder/analysis/bus_timeline.hpp"

#include <iterator>
#include <map>
#include <numeric>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "decoder/models/register_meaning.hpp"

namespace modtap {
namespace {

constexpr int64_t second = 1'000'000'000;

RegisterValue holding(uint16_t address, std::string_view name = {}) {
  RegisterValue reg;
  reg.address = address;
  reg.name = name;
  return reg;
}

Frame frame_at(int64_t t_ns, bool check_ok = true) {
  static const std::vector<uint8_t> adu{0x01, 0x03, 0x02, 0x00, 0x07, 0x00, 0x00};
  Frame f;
  f.role = Role::response;
  f.raw = f.adu = adu;
  f.check_ok = check_ok;
  f.t_ns = f.end_ns = t_ns;
  return f;
}

uint64_t total_frames(const BusTimeline& timeline) {
  return std::accumulate(timeline.traffic().begin(), timeline.traffic().end(), uint64_t{0},
                         [](uint64_t sum, const TrafficBin& b) { return sum + b.frames; });
}

TEST(BusTimeline, AnHourFitsTheFixedBinsAndLosesNoFrame) {
  BusTimeline timeline;
  const int64_t origin = 1'700'000'000 * second;
  for (int64_t t = 0; t < 3600 * second; t += second / 10) timeline.on_frame(frame_at(origin + t));
  EXPECT_LE(timeline.traffic().size(), BusTimeline::max_bins);
  EXPECT_GT(timeline.traffic().size(),
            BusTimeline::max_bins / 2);  // coarsened no further than needed
  EXPECT_EQ(total_frames(timeline), 36000u);
  EXPECT_EQ(timeline.origin_ns(), origin);
  // Each bin covers first_bin_ns doubled some times, and holds the frames of its stretch.
  const int64_t bin = timeline.bin_ns();
  EXPECT_EQ(bin % BusTimeline::first_bin_ns, 0);
  EXPECT_TRUE(std::has_single_bit(static_cast<uint64_t>(bin / BusTimeline::first_bin_ns)));
  const int64_t step = second / 10;
  EXPECT_EQ(timeline.traffic()[0].frames, static_cast<uint64_t>((bin + step - 1) / step));
}

TEST(BusTimeline, TroubleLandsInTheStretchItHappenedIn) {
  BusTimeline timeline;
  timeline.on_frame(frame_at(0));
  timeline.on_frame(frame_at(100 * second));  // a long capture: bins of seconds
  timeline.on_frame(frame_at(42 * second, false));
  Timeout timeout;
  timeout.t_ns = 70 * second;
  timeout.reason = TimeoutReason::silence;
  timeline.on_timeout(timeout);
  timeout.reason = TimeoutReason::end_of_capture;  // unanswered: no time-out
  timeline.on_timeout(timeout);
  Noise noise;
  noise.t_ns = 99 * second;
  timeline.on_noise(noise);
  const auto& bins = timeline.traffic();
  const auto at = [&](int64_t t) { return bins[static_cast<size_t>(t / timeline.bin_ns())]; };
  EXPECT_EQ(at(42 * second).bad_checks, 1u);
  EXPECT_EQ(at(70 * second).timeouts, 1u);
  EXPECT_EQ(at(99 * second).noise_records, 1u);
  uint64_t trouble = 0;
  for (const TrafficBin& b : bins) trouble += b.trouble();
  EXPECT_EQ(trouble, 3u);
}

TEST(BusTimeline, ATimeBeforeTheFirstCountsInTheFirstBin) {
  BusTimeline timeline;
  timeline.on_frame(frame_at(10 * second));
  timeline.on_frame(frame_at(5 * second));  // a clock that stepped back
  ASSERT_EQ(timeline.traffic().size(), 1u);
  EXPECT_EQ(timeline.traffic()[0].frames, 2u);
}

TEST(BusTimeline, FollowedRegistersKeepTheirRangeAndLastValuePerStretch) {
  BusTimeline timeline([](const RegisterValue& reg) { return reg.address == 0x2103; });
  Meaning meaning;
  meaning.registers.push_back(holding(0x2103, "output_frequency"));
  meaning.registers.push_back(holding(0x2104, "output_current"));
  for (int i = 0; i < 2000; ++i) {
    meaning.registers[0].value = i % 7;
    Frame f = frame_at(i * (second / 100));
    f.meaning = &meaning;
    timeline.on_frame(f);
  }
  ASSERT_EQ(timeline.followed().size(), 1u);
  const auto& [key, series] = *timeline.followed().begin();
  EXPECT_EQ(key.address, 0x2103);
  EXPECT_EQ(key.slave, 1);
  EXPECT_EQ(series.name, "output_frequency");
  ASSERT_EQ(series.bins.size(), timeline.traffic().size());
  uint64_t values = 0;
  for (const ValueBin& bin : series.bins) {
    values += bin.count;
    EXPECT_EQ(bin.min, 0);
    EXPECT_EQ(bin.max, 6);
  }
  EXPECT_EQ(values, 2000u);
  EXPECT_EQ(series.bins.back().last, 1999 % 7);
}

// A register whose values have names (a drive's state) is kept as states with their texts;
// one value without a name, a name that changes (a string) or too many values make it a number.
TEST(BusTimeline, ARegisterOfNamedValuesKeepsItsStates) {
  const auto follow = [](const std::vector<std::pair<double, std::string_view>>& readings) {
    BusTimeline timeline([](const RegisterValue&) { return true; });
    Meaning meaning;
    meaning.registers.push_back(holding(0x2520, "status"));
    int64_t t = 0;
    for (const auto& [value, text] : readings) {
      meaning.registers[0].value = value;
      meaning.registers[0].text = text;
      Frame f = frame_at(t += second);
      f.meaning = &meaning;
      timeline.on_frame(f);
    }
    return timeline.followed().begin()->second;
  };
  const FollowedSeries drive =
      follow({{7, "Run, Reverse, Ready"}, {0, "Stop"}, {7, "Run, Reverse, Ready"}});
  EXPECT_TRUE(drive.stateful);
  EXPECT_EQ(drive.states, (std::map<double, std::string>{{0, "Stop"}, {7, "Run, Reverse, Ready"}}));
  EXPECT_FALSE(follow({{7, "Run"}, {3, ""}}).stateful);
  EXPECT_FALSE(follow({{0, "AB"}, {0, "CD"}}).stateful);
  std::vector<std::pair<double, std::string_view>> many;
  const std::string_view names[] = {"a", "b", "c", "d", "e", "f", "g",
                                    "h", "i", "j", "k", "l", "m"};
  for (size_t i = 0; i < std::size(names); ++i) many.emplace_back(i, names[i]);
  const FollowedSeries counter = follow(many);
  EXPECT_FALSE(counter.stateful);
  EXPECT_TRUE(counter.states.empty());
}

TEST(BusTimeline, FollowsAtMostSixteenRegisters) {
  BusTimeline timeline([](const RegisterValue&) { return true; });
  Meaning meaning;
  for (uint16_t a = 0; a < 20; ++a) meaning.registers.push_back(holding(a));
  Frame f = frame_at(0);
  f.meaning = &meaning;
  timeline.on_frame(f);
  EXPECT_EQ(timeline.followed().size(), BusTimeline::max_followed);
  EXPECT_EQ(timeline.followed_not_kept(), 4u);
}

}  // namespace
}  // namespace modtap
