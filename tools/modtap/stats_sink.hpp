// The summary of a capture (-T stats): counts, error rates and turnaround. A sink like the
// others, so the pipeline itself counts nothing it is not asked for.
#pragma once

#include <map>
#include <string>

#include "decoder/analyzer.hpp"
#include "tools/modtap/output.hpp"

namespace modtap::tools {

// Per slave: which drive on the bus is the one misbehaving.
struct SlaveStats {
  uint64_t requests = 0, responses = 0, exceptions = 0, bad_checks = 0, timeouts = 0;
  int64_t latency_sum_ns = 0, latency_max_ns = 0;
  uint64_t latency_count = 0;
};

struct BusStats {
  uint64_t frames = 0, bad_checks = 0, requests = 0, responses = 0, unknown_roles = 0;
  uint64_t exceptions = 0, broadcasts = 0, unsolicited = 0, mismatches = 0, timeouts = 0;
  uint64_t unanswered = 0;  // still waiting when the capture ended: no time-out
  uint64_t noise_records = 0, noise_bytes = 0, frame_bytes = 0;
  int64_t latency_sum_ns = 0, latency_max_ns = 0;
  uint64_t latency_count = 0;
  std::map<uint8_t, SlaveStats> slaves;
  std::map<std::string, uint64_t> model_findings;  // by kind, when a model reads the frames
};

class StatsSink final : public decoder::RecordSink {
 public:
  void on_frame(const decoder::Frame& frame) override;
  void on_noise(const decoder::Noise& noise) override;
  void on_timeout(const decoder::Timeout& timeout) override {
    if (!timeout.timed_out()) {
      ++stats_.unanswered;
      return;
    }
    ++stats_.timeouts;
    ++stats_.slaves[timeout.slave].timeouts;
  }
  const BusStats& stats() const { return stats_; }

 private:
  void count_slave(const decoder::Frame& frame);

  BusStats stats_;
};

void print_stats(Output& out, const BusStats& stats);

// Takes records and keeps nothing: -T none measures the pipeline alone.
class NullSink final : public decoder::RecordSink {
 public:
  void on_frame(const decoder::Frame&) override {}
  void on_noise(const decoder::Noise&) override {}
  void on_timeout(const decoder::Timeout&) override {}
};

}  // namespace modtap::tools
