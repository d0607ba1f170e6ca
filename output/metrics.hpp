// Bus health for Prometheus: the statistics --stats writes, in the text exposition format,
// served on /metrics while modtap runs (output/network/metrics_server). The counters are
// BusStatistics', read under the same lock the pipeline adds records with; nothing here counts on
// its own but the ports' troubles.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <mutex>
#include <span>
#include <string>

#include <fmt/format.h>

#include "decoder/analysis/bus_problems.hpp"
#include "decoder/analysis/bus_statistics.hpp"

namespace modtap::output {

// What the live loop knows of its own ports: how many it listens on and how many it reads now,
// reads that failed (an unplugged adapter) and ports that came back (--reconnect). Written by
// the live loop, read by the server.
struct PortHealth {
  std::atomic<uint32_t> ports{0};  // 0: a capture file, no port
  std::atomic<uint32_t> open{0};
  std::atomic<uint64_t> read_errors{0};
  std::atomic<uint64_t> reconnects{0};
};

// The exposition (version 0.0.4) of modtap's version, the statistics, the problems and the
// ports' health.
void append_metrics(fmt::memory_buffer& out, std::string_view version,
                    const BusStatistics& statistics, std::span<const Problem> problems,
                    const PortHealth& ports);

// The statistics and the problems' evidence (`health`), fed by the pipeline and read by the
// server's thread, one at a time.
class SharedStatistics final : public RecordSink {
 public:
  explicit SharedStatistics(RecordSink& health) : health_(health) {}

  void on_frame(const Frame& frame) override {
    std::lock_guard lock(mutex_);
    health_.on_frame(frame);
  }
  void on_noise(const Noise& noise) override {
    std::lock_guard lock(mutex_);
    health_.on_noise(noise);
  }
  void on_timeout(const Timeout& timeout) override {
    std::lock_guard lock(mutex_);
    health_.on_timeout(timeout);
  }
  // Runs `reader` while no record comes in.
  void read(const std::function<void()>& reader) {
    std::lock_guard lock(mutex_);
    reader();
  }

 private:
  std::mutex mutex_;
  RecordSink& health_;
};

}  // namespace modtap::output
