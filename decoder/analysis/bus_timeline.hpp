// What the bus did over time, in fixed memory, for the report's charts: per stretch of time the
// traffic and the trouble (time-outs, exceptions, bad checks, noise, findings), and the values
// of the followed registers. At most `max_bins` stretches: when a capture outgrows them, each
// two neighbours merge and a stretch covers twice the time, so a week costs what a minute does.
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "decoder/analysis/bus_statistics.hpp"
#include "decoder/protocol/record_sink.hpp"

namespace modtap {

struct TrafficBin {
  uint64_t frames = 0, requests = 0, responses = 0;
  uint64_t timeouts = 0, exceptions = 0, bad_checks = 0, noise_records = 0;
  uint64_t warnings = 0;  // frames with a finding of warning or error severity

  void merge(const TrafficBin& later);
  uint64_t trouble() const { return timeouts + exceptions + bad_checks + noise_records; }
};

// The values one register took in a stretch of time.
struct ValueBin {
  uint64_t count = 0;
  double min = std::numeric_limits<double>::infinity();
  double max = -std::numeric_limits<double>::infinity();
  double last = 0;

  void add(double value);
  void merge(const ValueBin& later);
};

struct FollowedSeries {
  static constexpr size_t max_states = 12;

  std::string name, unit;
  std::vector<ValueBin> bins;  // as many as the timeline's; empty ones have count 0
  // A register whose every value has a name (an enum, a set of bits) and which took at most
  // max_states values: each value's text, to draw as states rather than numbers.
  std::map<double, std::string> states;
  bool stateful = true;  // no value without a name, nor more than max_states, so far

  void add_state(double value, std::string_view text);
};

class BusTimeline final : public RecordSink {
 public:
  static constexpr size_t max_bins = 240;
  static constexpr int64_t first_bin_ns = 10'000'000;  // 10 ms, doubled as the capture grows
  static constexpr size_t max_followed = 16;           // series; further registers are not kept

  // `follow` picks the registers whose values are kept over time; none when empty.
  explicit BusTimeline(std::function<bool(const RegisterValue&)> follow = {})
      : follow_(std::move(follow)) {}

  void on_frame(const Frame& frame) override;
  void on_noise(const Noise& noise) override;
  void on_timeout(const Timeout& timeout) override;

  // The start of bin 0 (the first record's time), or nothing before the first record.
  std::optional<int64_t> origin_ns() const { return origin_; }
  int64_t bin_ns() const { return bin_ns_; }
  double bin_s() const { return static_cast<double>(bin_ns_) / 1e9; }
  // The time the bins cover, from the origin to the end of the last.
  double span_s() const { return static_cast<double>(traffic_.size()) * bin_s(); }
  const std::vector<TrafficBin>& traffic() const { return traffic_; }
  const std::map<RegisterKey, FollowedSeries>& followed() const { return followed_; }
  uint64_t followed_not_kept() const { return followed_not_kept_; }

 private:
  // The bin a time falls in, growing and coarsening the bins as needed. A time before the
  // origin (a clock that stepped back) counts in bin 0.
  size_t bin_at(int64_t t_ns);
  void coarsen();
  void follow_values(const Frame& frame, size_t bin);

  std::function<bool(const RegisterValue&)> follow_;
  std::optional<int64_t> origin_;
  int64_t bin_ns_ = first_bin_ns;
  std::vector<TrafficBin> traffic_;
  std::map<RegisterKey, FollowedSeries> followed_;
  uint64_t followed_not_kept_ = 0;
};

}  // namespace modtap
