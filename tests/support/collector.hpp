// Test helpers: a RecordSink that keeps copies of every record, and ways to feed bytes.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "decoder/protocol/analyzer.hpp"

namespace modtap::testing {

struct Record {
  enum class Type { frame, noise, timeout } type = Type::frame;
  uint64_t index = 0;
  uint16_t channel = 0;
  uint64_t offset = 0;
  std::vector<uint8_t> raw;
  Role role = Role::unknown;
  bool check_ok = false;
  uint16_t expected_check = 0;
  Damage damage = Damage::none;
  uint32_t findings = 0;
  std::optional<uint64_t> request;
  std::optional<int64_t> latency_ns;
  int64_t t_ns = 0;
  NoiseReason reason = NoiseReason::junk;
  TimeoutReason timeout_reason = TimeoutReason::silence;
  uint8_t device = 0;           // a frame's device(); a noise record's request_slave
  bool damaged_answer = false;  // a noise record's
};

class Collector final : public RecordSink {
 public:
  void on_frame(const Frame& f) override {
    Record r;
    r.type = Record::Type::frame;
    r.index = f.index;
    r.channel = f.channel;
    r.offset = f.offset;
    r.raw.assign(f.raw.begin(), f.raw.end());
    r.role = f.role;
    r.check_ok = f.check_ok;
    r.expected_check = f.expected_check;
    r.damage = f.damage;
    r.findings = f.findings;
    r.request = f.request;
    r.latency_ns = f.latency_ns;
    r.t_ns = f.t_ns;
    r.device = f.device();
    records.push_back(std::move(r));
  }
  void on_noise(const Noise& n) override {
    Record r;
    r.type = Record::Type::noise;
    r.index = n.index;
    r.channel = n.channel;
    r.offset = n.offset;
    r.raw.assign(n.raw.begin(), n.raw.end());
    r.device = n.request_slave;
    r.damaged_answer = n.damaged_answer;
    r.reason = n.reason;
    r.findings = n.findings;
    r.request = n.request;
    r.t_ns = n.t_ns;
    records.push_back(std::move(r));
  }
  void on_timeout(const Timeout& t) override {
    Record r;
    r.type = Record::Type::timeout;
    r.request = t.request;
    r.channel = t.channel;
    r.t_ns = t.t_ns;
    r.timeout_reason = t.reason;
    records.push_back(std::move(r));
  }

  // Frames and noise in order: the records that carry bytes.
  std::vector<Record> stream() const {
    std::vector<Record> out;
    for (const auto& r : records)
      if (r.type != Record::Type::timeout) out.push_back(r);
    return out;
  }
  std::vector<Record> frames() const { return of(Record::Type::frame); }
  std::vector<Record> noise() const { return of(Record::Type::noise); }
  std::vector<Record> timeouts() const { return of(Record::Type::timeout); }
  // Every byte of a channel, in record order: must equal the input (byte conservation).
  std::vector<uint8_t> bytes_of(uint16_t channel) const {
    std::vector<uint8_t> out;
    for (const auto& r : records)
      if (r.type != Record::Type::timeout && r.channel == channel)
        out.insert(out.end(), r.raw.begin(), r.raw.end());
    return out;
  }

  std::vector<Record> records;

 private:
  std::vector<Record> of(Record::Type type) const {
    std::vector<Record> out;
    for (const auto& r : records)
      if (r.type == type) out.push_back(r);
    return out;
  }
};

inline std::vector<uint8_t> hex(const std::string& text) {
  std::vector<uint8_t> out;
  int nibble = -1;
  for (char c : text) {
    int v = (c >= '0' && c <= '9')   ? c - '0'
            : (c >= 'a' && c <= 'f') ? c - 'a' + 10
            : (c >= 'A' && c <= 'F') ? c - 'A' + 10
                                     : -1;
    if (v < 0) continue;
    if (nibble < 0) {
      nibble = v;
    } else {
      out.push_back(static_cast<uint8_t>(nibble << 4 | v));
      nibble = -1;
    }
  }
  return out;
}

// Runs bytes with no timing through an analyzer, split into chunks at `cuts`.
inline Collector analyze_untimed(const std::vector<uint8_t>& bytes, std::vector<size_t> cuts = {},
                                 ModeChoice mode = ModeChoice::rtu,
                                 const FeatureWeights& weights = table_weights) {
  Collector out;
  AnalyzerOptions options;
  options.mode = mode;
  options.clock = ClockQuality::none;
  options.framing_weights = weights;
  Analyzer analyzer(options, {{"test", ChannelRole::bus}}, out);
  cuts.push_back(bytes.size());
  size_t at = 0;
  for (size_t cut : cuts) {
    if (cut < at || cut > bytes.size()) continue;
    analyzer.push({0, 0, {bytes.data() + at, cut - at}});
    at = cut;
  }
  analyzer.finish();
  return out;
}

// Feeds the bytes cut at every offset, and at every pair of offsets when `pairs`, and expects
// the same records as from one piece: how a source splits its reads must change nothing.
inline void expect_same_at_every_split(const std::vector<uint8_t>& bytes,
                                       ModeChoice mode = ModeChoice::rtu, bool pairs = false) {
  const auto whole = analyze_untimed(bytes, {}, mode);
  auto expect_same = [&](const std::vector<size_t>& cuts) {
    const auto split = analyze_untimed(bytes, cuts, mode);
    const std::string where = ::testing::PrintToString(cuts);
    ASSERT_EQ(split.records.size(), whole.records.size()) << "cut at " << where;
    for (size_t i = 0; i < whole.records.size(); ++i) {
      const Record& a = split.records[i];
      const Record& b = whole.records[i];
      EXPECT_EQ(a.raw, b.raw) << "cut at " << where;
      EXPECT_EQ(a.type, b.type) << "cut at " << where;
      EXPECT_EQ(a.role, b.role) << "cut at " << where;
      EXPECT_EQ(a.check_ok, b.check_ok) << "cut at " << where;
      EXPECT_EQ(a.request, b.request) << "cut at " << where;
      EXPECT_EQ(a.reason, b.reason) << "cut at " << where;
    }
  };
  for (size_t cut = 1; cut < bytes.size(); ++cut) {
    expect_same({cut});
    if (pairs)
      for (size_t second = cut + 1; second < bytes.size(); ++second) expect_same({cut, second});
  }
}

}  // namespace modtap::testing
