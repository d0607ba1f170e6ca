// The summary of a capture: counts, error rates and turnaround, printed at the end (-T stats).
#pragma once

#include "decoder/analyzer.hpp"
#include "tools/modtap/output.hpp"

namespace modtap::tools {

void print_stats(Output& out, const decoder::BusStats& stats);

// Takes records and keeps nothing: -T none and -T stats measure the pipeline alone.
class NullSink final : public decoder::RecordSink {
 public:
  void on_frame(const decoder::Frame&) override {}
  void on_noise(const decoder::Noise&) override {}
  void on_timeout(const decoder::Timeout&) override {}
};

}  // namespace modtap::tools
