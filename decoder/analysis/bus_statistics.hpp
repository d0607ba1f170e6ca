// What a capture adds up to, for a technician: per slave, how often it was asked, answered,
// late, silent, refusing; per function code the same; latency and poll-interval percentiles in
// fixed memory; every finding counted with where it first showed. The one place these
// counters are kept: -T stats, --stats and the metrics all read them from here.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "decoder/analysis/histogram.hpp"
#include "decoder/analysis/silence_run.hpp"
#include "decoder/models/register_meaning.hpp"
#include "decoder/protocol/findings.hpp"
#include "decoder/protocol/function_codes.hpp"
#include "decoder/protocol/record_sink.hpp"
#include "decoder/protocol/serial_format.hpp"

namespace modtap {

// Counted per slave and per function code.
struct ExchangeCounts {
  uint64_t requests = 0;
  uint64_t responses = 0;
  uint64_t timeouts = 0;
  uint64_t exceptions = 0;
  uint64_t bad_checks = 0;
  uint64_t retries = 0;
  uint64_t garbled = 0;  // answers that came as noise, past reading (Noise::damaged_answer)
  // Responses that came after the master gave up (late-response): each is a response, and its
  // request a time-out; the master got an answer to the others.
  uint64_t late = 0;

  double timeout_rate() const {
    return requests ? static_cast<double>(timeouts) / static_cast<double>(requests) : 0.0;
  }
  uint64_t answered_in_time() const { return responses - std::min(late, responses); }
};

// A slave that went silent (silent_after_timeouts or more time-outs in a row): from the end of
// the first unanswered request to the start of the next answer it gave, garbled or not (none
// yet: it had not come back when the capture ended). A device that answers in junk is there.
struct Outage {
  uint8_t slave = 0;
  uint64_t first_request = 0;  // the first request it left unanswered
  int64_t silent_from_ns = 0;
  std::optional<int64_t> back_ns;
  uint64_t timeouts = 0;
};

struct SlaveStatistics {
  ExchangeCounts counts;
  std::map<uint8_t, uint64_t> exceptions_by_code;
  std::map<uint8_t, ExchangeCounts> by_function;  // function code without the exception bit
  Histogram latency_ns;                           // end of request to start of response
  Histogram poll_interval_ns;                     // start of one request to the next's
  int64_t last_frame_ns = 0;
  std::optional<int64_t> last_answer_ns;  // the end of its last good answer: when it last spoke
  SilenceRun silence;                     // its time-outs since it was last heard
  std::optional<size_t> open_outage;      // in outages(), while it stays silent
  bool good = false;  // a frame with a good check came from or went to this address
};

// The last value the bus carried for one register: the bus's state, as a data logger shows it.
// Texts are copied: a frame's own composed texts do not outlive it.
struct LastValue {
  std::string name, unit, text;
  double value = 0;
  int decimals = 0;
  uint64_t raw = 0;
  int64_t t_ns = 0;
  // Over the capture: how often it was carried, how often its value differed from the one
  // before, and the range of its finite values (a drive's parameter holds one; a measurement
  // moves): lowest > highest where none was finite.
  uint64_t reads = 0, changes = 0;
  double lowest = INFINITY, highest = -INFINITY;

  void keep(const RegisterValue& reg, int64_t when);
  // As the register it was, its texts pointing here.
  RegisterValue as_register(Table table, uint16_t address) const;
};
struct RegisterKey {
  uint8_t slave;
  Table table;
  uint16_t address;
  auto operator<=>(const RegisterKey&) const = default;
};

// A finding's count and the indexes of the first records that show it, each once: a frame may
// show a model's finding for several of its registers, and counts for each.
struct FindingCount {
  static constexpr size_t kept = 5;
  uint64_t count = 0;

  void add(uint64_t index) {
    ++count;
    if (records_ < kept && (records_ == 0 || first_[records_ - 1] != index))
      first_[records_++] = index;
  }
  std::span<const uint64_t> first_records() const { return {first_.data(), records_}; }

 private:
  std::array<uint64_t, kept> first_{};
  size_t records_ = 0;
};

class BusStatistics final : public RecordSink {
 public:
  // `data_bits_from_mode`: nobody gave the line's data bits, so the first frame's mode says
  // them (ASCII 7, RTU 8), for the bus load and for what the statistics say of the line.
  BusStatistics(SerialFormat format, ClockQuality clock, bool data_bits_from_mode = false)
      : format_(format), clock_(clock), data_bits_from_mode_(data_bits_from_mode) {}

  void on_frame(const Frame& frame) override;
  void on_noise(const Noise& noise) override;
  void on_timeout(const Timeout& timeout) override;

  // Bus-wide counts. A broadcast is a request; unknown-role frames are neither.
  uint64_t frames = 0, requests = 0, responses = 0, unknown_roles = 0;
  uint64_t bad_checks = 0, exceptions = 0, broadcasts = 0, retries = 0, unsolicited = 0;
  uint64_t timeouts = 0;
  uint64_t unanswered = 0;  // still waiting when the capture ended: no time-out
  uint64_t frame_bytes = 0, noise_bytes = 0, noise_records = 0;
  std::array<uint64_t, 5> noise_by_reason{};  // NoiseReason order
  std::array<uint64_t, 4> damaged{};          // Damage order; [0] unused
  std::optional<int64_t> first_t_ns, last_t_ns;
  Histogram latency_ns;
  std::array<FindingCount, frame_finding_count + rule_kind_count> findings;
  // The last value of each register read or written, up to kept_registers of them; values of
  // registers beyond those are counted, not kept (random traffic touches every address).
  static constexpr size_t kept_registers = 20000;
  std::map<RegisterKey, LastValue> registers;
  uint64_t register_values_not_kept = 0;
  // The first kept_outages silences, in the order they began, and how many there were in all.
  static constexpr size_t kept_outages = 1000;  // a week of a flapping slave stays bounded
  const std::vector<Outage>& outages() const { return outages_; }
  uint64_t outage_count() const { return outage_count_; }

  // Every address a frame named, slave 0 (broadcast) aside. Only those `good` are slaves: a
  // corrupted address byte does not make one. Bad checks on the others are counted apart.
  const std::map<uint8_t, std::unique_ptr<SlaveStatistics>>& addresses() const {
    return addresses_;
  }
  // Calls visit(address, statistics) for each slave (an address `good`), in address order.
  template <typename Visit>
  void for_each_slave(Visit&& visit) const {
    for (const auto& [address, slave] : addresses_)
      if (slave->good) visit(address, *slave);
  }
  uint64_t stray_bad_checks() const;
  size_t stray_addresses() const;

  double duration_s() const;
  // Whether the times are dates (since the Unix epoch), as a pcap's are, rather than counted from
  // the capture's start, as a raw file's nominal times and a logic analyzer's are.
  bool dated() const {
    constexpr int64_t year_2000_ns = 946'684'800'000'000'000;
    return first_t_ns && *first_t_ns >= year_2000_ns;
  }
  // The share of the capture's time the wire carried characters, from the character format.
  // Unknown (nullopt) when the source has no clock: its times are nominal.
  std::optional<double> bus_load() const;
  const SerialFormat& format() const { return format_; }
  ClockQuality clock() const { return clock_; }
  // How late a clock per read may stamp a byte (--chunk-jitter; a device server's packets:
  // docs/live.md): what its latencies and gaps cannot tell apart. 0 for other clocks.
  int64_t read_lag_ns() const { return clock_ == ClockQuality::per_chunk ? read_lag_ns_ : 0; }
  void set_read_lag(int64_t ns) { read_lag_ns_ = ns; }

 private:
  SlaveStatistics& slave(uint8_t address);
  void see_time(int64_t start_ns, int64_t end_ns);
  void count_finding(size_t slot, uint64_t index);
  void count_exchange(const Frame& frame, SlaveStatistics& slave);
  // A late answer's latency is the master's time-out and more; an answer after another master's
  // exchange holds that exchange: neither is the slave's.
  static bool counts_latency(const Frame& frame) {
    return frame.latency_ns && *frame.latency_ns >= 0 &&
           !(frame.findings & (finding_late_response | finding_after_other_master));
  }
  void keep_values(const Frame& frame);
  void heard(SlaveStatistics& slave, int64_t t_ns);
  void unanswered_again(SlaveStatistics& slave, const Timeout& timeout);

  SerialFormat format_;
  ClockQuality clock_;
  int64_t read_lag_ns_ = 0;
  bool data_bits_from_mode_;
  std::map<uint8_t, std::unique_ptr<SlaveStatistics>> addresses_;
  std::array<std::optional<int64_t>, 256> last_request_ns_{};
  std::vector<Outage> outages_;
  uint64_t outage_count_ = 0;
};

// When `t_ns` was, as a person reads it of this capture: the time of day (UTC) in a dated
// capture of one day, with the date in one of more, else seconds into the capture. The
// problems' sentences and the report say times so.
std::string moment_text(const BusStatistics& statistics, int64_t t_ns);

}  // namespace modtap
