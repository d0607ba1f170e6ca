// What takes the analyzer's records: the outputs, the statistics, the model stage. Records are
// handed over as const; spans inside them are valid only during the call.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "decoder/protocol/records.hpp"

namespace modtap {

class RecordSink {
 public:
  virtual ~RecordSink() = default;
  virtual void on_frame(const Frame& frame) = 0;
  virtual void on_noise(const Noise& noise) = 0;
  virtual void on_timeout(const Timeout& timeout) = 0;
};

// Hands every record to each of several sinks (the terminal, the statistics, a pcapng file).
class FanOut final : public RecordSink {
 public:
  void add(RecordSink& sink) { sinks_.push_back(&sink); }
  void on_frame(const Frame& f) override {
    for (auto* s : sinks_) s->on_frame(f);
  }
  void on_noise(const Noise& n) override {
    for (auto* s : sinks_) s->on_noise(n);
  }
  void on_timeout(const Timeout& t) override {
    for (auto* s : sinks_) s->on_timeout(t);
  }

 private:
  std::vector<RecordSink*> sinks_;
};

// Passes records on until `max_records` frames and noise records have gone through (-c N, as
// tshark counts packets: junk read as noise counts too, so a limit is reached on any input),
// then none. A time-out is not a record of the line but modtap's own: it does not count, and
// after the limit passes only if it was known before the last record counted; the others the
// analyzer still holds when the run stops stay out.
class RecordLimit final : public RecordSink {
 public:
  // `on_reached` runs once, after the last record went through: a live run stops there.
  RecordLimit(uint64_t max_records, RecordSink& next, std::function<void()> on_reached = {})
      : left_(max_records), next_(next), on_reached_(std::move(on_reached)) {}
  bool reached() const { return left_ == 0; }
  void on_frame(const Frame& f) override {
    if (reached()) return;
    next_.on_frame(f);
    count(f.t_ns);
  }
  void on_noise(const Noise& n) override {
    if (reached()) return;
    next_.on_noise(n);
    count(n.t_ns);
  }
  void on_timeout(const Timeout& t) override {
    if (!reached() || t.t_ns <= last_ns_) next_.on_timeout(t);
  }

 private:
  void count(int64_t t_ns) {
    last_ns_ = t_ns;
    if (--left_ == 0 && on_reached_) on_reached_();
  }

  uint64_t left_;
  int64_t last_ns_ = 0;
  RecordSink& next_;
  std::function<void()> on_reached_;
};

// The times of the records seen so far: the first one's, the latest's and the one's before it.
struct RecordClock {
  std::optional<int64_t> first_ns;
  std::optional<int64_t> previous_ns;
  std::optional<int64_t> latest_ns;

  void see(int64_t t_ns) {
    if (!first_ns) first_ns = t_ns;
    previous_ns = latest_ns;
    latest_ns = t_ns;
  }
};

// The clock a sink's time column counts by: every record's, kept before a filter (shared), or
// its own, of the records the sink is given.
class SinkClock {
 public:
  explicit SinkClock(const RecordClock* shared) : shared_(shared) {}
  void see(int64_t t_ns) {
    if (!shared_) own_.see(t_ns);
  }
  const RecordClock& get() const { return shared_ ? *shared_ : own_; }

 private:
  const RecordClock* shared_;
  RecordClock own_;
};

// Keeps `clock` of every record going through, then hands it on. Set before the filter, it lets
// the sinks behind count time over the whole capture as tshark does (-t r from the first
// packet, -t d from the packet before, shown or not): a filter picks lines, it does not move
// them in time.
class ClockStage final : public RecordSink {
 public:
  ClockStage(RecordClock& clock, RecordSink& next) : clock_(clock), next_(next) {}
  void on_frame(const Frame& f) override {
    clock_.see(f.t_ns);
    next_.on_frame(f);
  }
  void on_noise(const Noise& n) override {
    clock_.see(n.t_ns);
    next_.on_noise(n);
  }
  void on_timeout(const Timeout& t) override {
    clock_.see(t.t_ns);
    next_.on_timeout(t);
  }

 private:
  RecordClock& clock_;
  RecordSink& next_;
};

// Takes records and keeps nothing: -T none measures the pipeline alone.
class NullSink final : public RecordSink {
 public:
  void on_frame(const Frame&) override {}
  void on_noise(const Noise&) override {}
  void on_timeout(const Timeout&) override {}
};

}  // namespace modtap
