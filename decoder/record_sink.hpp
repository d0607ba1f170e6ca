// What takes the analyzer's records: the outputs, the statistics, the model stage. Records are
// handed over as const; spans inside them are valid only during the call.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "decoder/records.hpp"

namespace modtap::decoder {

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

// Passes records on until `max_frames` frames have gone through (-c N), then none: records the
// analyzer still holds when the run stops (pending time-outs) stay out too.
class FrameLimit final : public RecordSink {
 public:
  // `on_reached` runs once, after the last frame went through: a live run stops there.
  FrameLimit(uint64_t max_frames, RecordSink& next, std::function<void()> on_reached = {})
      : left_(max_frames), next_(next), on_reached_(std::move(on_reached)) {}
  bool reached() const { return left_ == 0; }
  void on_frame(const Frame& f) override {
    if (reached()) return;
    --left_;
    next_.on_frame(f);
    if (reached() && on_reached_) on_reached_();
  }
  void on_noise(const Noise& n) override {
    if (!reached()) next_.on_noise(n);
  }
  void on_timeout(const Timeout& t) override {
    if (!reached()) next_.on_timeout(t);
  }

 private:
  uint64_t left_;
  RecordSink& next_;
  std::function<void()> on_reached_;
};

// Takes records and keeps nothing: -T none measures the pipeline alone.
class NullSink final : public RecordSink {
 public:
  void on_frame(const Frame&) override {}
  void on_noise(const Noise&) override {}
  void on_timeout(const Timeout&) override {}
};

}  // namespace modtap::decoder
