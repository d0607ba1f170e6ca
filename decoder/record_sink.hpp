// What takes the analyzer's records: the outputs, the statistics, the model stage. Records are
// handed over as const; spans inside them are valid only during the call.
#pragma once

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

// Takes records and keeps nothing: -T none measures the pipeline alone.
class NullSink final : public RecordSink {
 public:
  void on_frame(const Frame&) override {}
  void on_noise(const Noise&) override {}
  void on_timeout(const Timeout&) override {}
};

}  // namespace modtap::decoder
