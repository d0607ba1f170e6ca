#include "decoder/analysis/bus_timeline.hpp"

#include <algorithm>

#include "decoder/models/record_fields.hpp"

namespace modtap {

namespace {

// A frame worth a technician's look: one of its findings is a warning or an error.
bool warns(const Frame& frame) {
  const auto registry = finding_registry();
  bool found = false;
  findings_of(frame).each(
      [&](size_t slot) { found = found || registry[slot].severity != Severity::note; });
  return found;
}

// Bins 2i and 2i+1 become bin i.
template <typename Bin>
void halve(std::vector<Bin>& bins) {
  for (size_t i = 0; i < bins.size(); ++i) {
    if (i % 2 == 0)
      bins[i / 2] = bins[i];
    else
      bins[i / 2].merge(bins[i]);
  }
  bins.resize((bins.size() + 1) / 2);
}

}  // namespace

void TrafficBin::merge(const TrafficBin& later) {
  frames += later.frames;
  requests += later.requests;
  responses += later.responses;
  timeouts += later.timeouts;
  exceptions += later.exceptions;
  bad_checks += later.bad_checks;
  noise_records += later.noise_records;
  warnings += later.warnings;
}

void ValueBin::add(double value) {
  ++count;
  min = std::min(min, value);
  max = std::max(max, value);
  last = value;
}

void ValueBin::merge(const ValueBin& later) {
  if (later.count == 0) return;
  count += later.count;
  min = std::min(min, later.min);
  max = std::max(max, later.max);
  last = later.last;
}

void BusTimeline::coarsen() {
  halve(traffic_);
  for (auto& [key, series] : followed_) halve(series.bins);
  bin_ns_ *= 2;
}

size_t BusTimeline::bin_at(int64_t t_ns) {
  if (!origin_) origin_ = t_ns;
  const int64_t since = std::max<int64_t>(0, t_ns - *origin_);
  while (static_cast<uint64_t>(since / bin_ns_) >= max_bins) coarsen();
  const auto bin = static_cast<size_t>(since / bin_ns_);
  if (bin >= traffic_.size()) {
    traffic_.resize(bin + 1);
    for (auto& [key, series] : followed_) series.bins.resize(bin + 1);
  }
  return bin;
}

void BusTimeline::on_frame(const Frame& frame) {
  const size_t at = bin_at(frame.t_ns);
  TrafficBin& bin = traffic_[at];
  ++bin.frames;
  bin.requests += frame.role == Role::request;
  bin.responses += frame.role == Role::response;
  bin.exceptions += frame.check_ok && frame.role == Role::response && frame.is_exception();
  bin.bad_checks += !frame.check_ok;
  bin.warnings += warns(frame);
  if (follow_) follow_values(frame, at);
}

// As the statistics keep last values: what a good response says the device holds.
void BusTimeline::follow_values(const Frame& frame, size_t bin) {
  const Meaning* meaning = frame.meaning;
  if (!states_values(frame)) return;
  for (const RegisterValue& reg : meaning->registers) {
    if (!follow_(reg)) continue;
    const RegisterKey key{frame.slave(), reg.table, reg.address};
    auto it = followed_.find(key);
    if (it == followed_.end()) {
      if (followed_.size() >= max_followed) {
        ++followed_not_kept_;
        continue;
      }
      FollowedSeries series;
      series.name = reg.name;
      series.unit = reg.unit;
      series.bins.resize(traffic_.size());
      it = followed_.emplace(key, std::move(series)).first;
    }
    it->second.bins[bin].add(reg.value);
    it->second.add_state(reg.value, reg.text);
  }
}

void FollowedSeries::add_state(double value, std::string_view text) {
  if (!stateful) return;
  const auto it = states.try_emplace(value, text).first;
  // A value without a name, a name that changed (a string register), or too many values: a
  // number line shows it better.
  if (text.empty() || it->second != text || states.size() > max_states) {
    stateful = false;
    states.clear();
  }
}

void BusTimeline::on_noise(const Noise& noise) {
  ++traffic_[bin_at(noise.t_ns)].noise_records;
}

void BusTimeline::on_timeout(const Timeout& timeout) {
  if (timeout.timed_out()) ++traffic_[bin_at(timeout.t_ns)].timeouts;
}

}  // namespace modtap
