#include "decoder/analysis/bus_statistics.hpp"

#include <algorithm>
#include <ctime>
#include <utility>

#include <fmt/chrono.h>
#include <fmt/format.h>

#include "decoder/models/record_fields.hpp"
#include "decoder/models/register_meaning.hpp"
#include "decoder/protocol/clock_time.hpp"

namespace modtap {

namespace {

void count(ExchangeCounts& c, const Frame& frame) {
  c.requests += frame.role == Role::request;
  c.responses += frame.role == Role::response;
  c.late += frame.role == Role::response && (frame.findings & finding_late_response);
  c.exceptions += frame.check_ok && frame.role == Role::response && frame.is_exception();
  c.bad_checks += !frame.check_ok;
  c.retries += (frame.findings & finding_retry) != 0;
}

}  // namespace

SlaveStatistics& BusStatistics::slave(uint8_t address) {
  auto& entry = addresses_[address];
  if (!entry) entry = std::make_unique<SlaveStatistics>();
  return *entry;
}

void BusStatistics::see_time(int64_t start_ns, int64_t end_ns) {
  first_t_ns = first_t_ns ? std::min(*first_t_ns, start_ns) : start_ns;
  last_t_ns = last_t_ns ? std::max(*last_t_ns, end_ns) : end_ns;
}

void BusStatistics::count_finding(size_t slot, uint64_t index) {
  findings[slot].add(index);
}

void BusStatistics::on_frame(const Frame& frame) {
  if (std::exchange(data_bits_from_mode_, false))
    format_ = format_.with_data_bits_of(frame.mode == Mode::ascii);
  ++frames;
  frame_bytes += frame.raw.size();
  see_time(frame.t_ns, frame.end_ns);
  requests += frame.role == Role::request;
  responses += frame.role == Role::response;
  unknown_roles += frame.role == Role::unknown;
  bad_checks += !frame.check_ok;
  exceptions += frame.check_ok && frame.role == Role::response && frame.is_exception();
  broadcasts += (frame.findings & finding_broadcast) != 0;
  unsolicited += (frame.findings & finding_unsolicited) != 0;
  retries += (frame.findings & finding_retry) != 0;
  ++damaged[static_cast<size_t>(frame.damage)];
  findings_of(frame).each([&](size_t slot) { count_finding(slot, frame.index); });
  // Latency of good responses in time only; a negative one (a clock that stepped back) never
  // counts, nor a late answer's wait: the master had given up (the late-response finding).
  if (frame.check_ok && counts_latency(frame))
    latency_ns.add(static_cast<uint64_t>(*frame.latency_ns));
  if (frame.adu.empty() || frame.device() == 0) return;
  keep_values(frame);
  SlaveStatistics& s = slave(frame.device());
  s.good = s.good || frame.check_ok;
  count_exchange(frame, s);
}

void BusStatistics::count_exchange(const Frame& frame, SlaveStatistics& s) {
  count(s.counts, frame);
  s.last_frame_ns = std::max(s.last_frame_ns, frame.end_ns);
  // An answer to a request, however garbled, is the slave speaking.
  if (frame.role == Role::response && (frame.check_ok || frame.request)) heard(s, frame.t_ns);
  if (!frame.check_ok) return;  // its function code may be as corrupted as its check
  if (frame.role == Role::response) s.last_answer_ns = frame.end_ns;
  count(s.by_function[frame.function() & 0x7F], frame);
  if (frame.role == Role::response && frame.is_exception() && frame.adu.size() > 2)
    ++s.exceptions_by_code[frame.adu[2]];
  if (counts_latency(frame)) s.latency_ns.add(static_cast<uint64_t>(*frame.latency_ns));
  if (frame.role != Role::request) return;
  auto& last = last_request_ns_[frame.device()];
  if (last && frame.t_ns >= *last)
    s.poll_interval_ns.add(static_cast<uint64_t>(frame.t_ns - *last));
  last = frame.t_ns;
}

// What the device holds, as its good responses say (states_values).
void BusStatistics::keep_values(const Frame& frame) {
  const Meaning* meaning = frame.meaning;
  if (!states_values(frame)) return;
  for (const RegisterValue& reg : meaning->registers) {
    const RegisterKey key{frame.device(), reg.table, reg.address};
    auto it = registers.find(key);
    if (it == registers.end()) {
      if (registers.size() >= kept_registers) {
        ++register_values_not_kept;
        continue;
      }
      it = registers.emplace(key, LastValue{}).first;
    }
    it->second.keep(reg, frame.t_ns);
  }
}

void LastValue::keep(const RegisterValue& reg, int64_t when) {
  changes += reads++ && reg.raw != raw;
  if (std::isfinite(reg.value)) {
    lowest = std::min(lowest, reg.value);
    highest = std::max(highest, reg.value);
  }
  name = reg.name;
  unit = reg.unit;
  text = reg.text;
  value = reg.value;
  decimals = reg.decimals;
  raw = reg.raw;
  t_ns = when;
}

RegisterValue LastValue::as_register(Table table, uint16_t address) const {
  RegisterValue reg;
  reg.table = table;
  reg.address = address;
  reg.name = name;
  reg.unit = unit;
  reg.text = text;
  reg.value = value;
  reg.decimals = decimals;
  reg.raw = raw;
  return reg;
}

void BusStatistics::on_noise(const Noise& noise) {
  ++noise_records;
  noise_bytes += noise.raw.size();
  ++noise_by_reason[static_cast<size_t>(noise.reason)];
  for_each_frame_finding(noise.findings, [&](size_t slot) { count_finding(slot, noise.index); });
  see_time(noise.t_ns, noise.end_ns);
  if (!noise.damaged_answer) return;
  SlaveStatistics& s = slave(noise.request_slave);
  ++s.counts.garbled;
  heard(s, noise.t_ns);
}

void BusStatistics::heard(SlaveStatistics& s, int64_t t_ns) {
  if (s.open_outage) outages_[*s.open_outage].back_ns = t_ns;
  s.open_outage.reset();
  s.silence.heard();
}

void BusStatistics::unanswered_again(SlaveStatistics& s, const Timeout& timeout) {
  if (s.silence.unanswered(timeout)) {
    ++outage_count_;
    if (outages_.size() < kept_outages) {
      s.open_outage = outages_.size();
      outages_.push_back({timeout.slave, s.silence.first_request, s.silence.since_ns, {}, 0});
    }
  }
  if (s.open_outage) outages_[*s.open_outage].timeouts = s.silence.timeouts;
}

void BusStatistics::on_timeout(const Timeout& timeout) {
  if (!timeout.timed_out()) {
    ++unanswered;  // the capture ended first: no time-out, and no time
    return;
  }
  ++timeouts;
  see_time(timeout.t_ns, timeout.t_ns);
  if (timeout.slave == 0) return;
  SlaveStatistics& s = slave(timeout.slave);
  ++s.counts.timeouts;
  ++s.by_function[timeout.function & 0x7F].timeouts;
  unanswered_again(s, timeout);
}

uint64_t BusStatistics::stray_bad_checks() const {
  uint64_t sum = 0;
  for (const auto& [address, s] : addresses_)
    if (!s->good) sum += s->counts.bad_checks;
  return sum;
}

size_t BusStatistics::stray_addresses() const {
  return static_cast<size_t>(std::count_if(addresses_.begin(), addresses_.end(),
                                           [](const auto& entry) { return !entry.second->good; }));
}

double BusStatistics::duration_s() const {
  if (!first_t_ns) return 0;
  return static_cast<double>(*last_t_ns - *first_t_ns) / 1e9;
}

std::optional<double> BusStatistics::bus_load() const {
  const double duration_ns = duration_s() * 1e9;
  if (clock_ == ClockQuality::none || duration_ns <= 0) return std::nullopt;
  const double busy_ns =
      static_cast<double>(frame_bytes + noise_bytes) * static_cast<double>(format_.char_time_ns());
  return std::min(1.0, busy_ns / duration_ns);
}

std::string moment_text(const BusStatistics& s, int64_t t_ns) {
  if (!s.dated())
    return fmt::format("{:.3f} s into the capture",
                       static_cast<double>(t_ns - s.first_t_ns.value_or(0)) / 1e9);
  constexpr int64_t day_ns = 86'400'000'000'000;
  const auto utc = fmt::gmtime(static_cast<std::time_t>(seconds_and_micros(t_ns).second));
  if (*s.first_t_ns / day_ns == *s.last_t_ns / day_ns) return fmt::format("{:%H:%M:%S} UTC", utc);
  return fmt::format("{:%Y-%m-%d %H:%M:%S} UTC", utc);
}

}  // namespace modtap
