#include "output/explain_sink.hpp"

#include <algorithm>

#include <fmt/format.h>

namespace modtap::output {
namespace {

// Enough for every reading weighed at the starts whose records may still be on their way.
constexpr size_t kept_steps = 64;

TextOptions with_clock(TextOptions options, const RecordClock& clock) {
  options.clock = &clock;
  return options;
}

}  // namespace

ExplainSink::ExplainSink(Output& out, const std::vector<ChannelInfo>& channels, TextOptions options,
                         uint64_t index)
    : out_(out),
      channels_(channels),
      text_(out, channels, with_clock(options, clock_)),
      index_(index) {}

// A start weighed again (more bytes came) makes what was weighed there and after it stale.
void ExplainSink::on_start(uint16_t channel, uint64_t offset) {
  std::erase_if(steps_, [&](const FramingStep& step) {
    return step.channel == channel && step.offset >= offset;
  });
}

void ExplainSink::on_reading(const FramingStep& step) {
  steps_.push_back(step);
  if (steps_.size() > kept_steps) steps_.pop_front();
}

void ExplainSink::on_frame(const Frame& frame) {
  if (!picked(frame)) return;
  text_.on_frame(frame);
  explain(frame.channel, frame.offset, frame.mode);
  if (frame.mode == Mode::rtu && frame.damage != Damage::none)
    out_.print(
        "  then, no reading holding, the bytes up to the next good frame or silence were "
        "one piece, which the awaited answer's structure or the header's length rules "
        "make a frame with a bad check: {}\n",
        to_string(frame.damage));
}

void ExplainSink::on_noise(const Noise& noise) {
  if (!picked(noise)) return;
  text_.on_noise(noise);
  explain(noise.channel, noise.offset, noise.mode);
  if (noise.mode == Mode::rtu)
    out_.print(
        "  then, no reading holding, the bytes up to the next good frame or silence were "
        "noise: {}\n",
        to_string(noise.reason));
}

void ExplainSink::on_timeout(const Timeout& timeout) {
  if (!picked(timeout)) return;
  text_.on_timeout(timeout);
  out_.print("  a time-out: the matcher's, after the request's wait; no framing decided it\n");
}

void ExplainSink::explain(uint16_t channel, uint64_t offset, Mode mode) {
  const std::string_view name =
      channel < channels_.size() ? std::string_view(channels_[channel].name) : "the capture";
  if (mode == Mode::ascii) {
    out_.print("  ASCII: ':' starts a frame and CR LF ends it; no reading is weighed\n");
    return;
  }
  out_.print("  at byte {} of {}, the framer weighed:\n", offset, name);
  bool any = false;
  for (const FramingStep& step : steps_) {
    if (step.channel != channel || step.offset != offset) continue;
    any = true;
    const EvidenceInfo& why = evidence_info(step.why);
    out_.print("    {}", to_string(step.role));
    if (step.length) out_.print(", {} bytes", step.length);
    out_.print(": {} ({}: {})\n", to_string(step.outcome), why.name, why.why);
  }
  if (!any)
    out_.print(
        "    no reading: the byte starts no frame a slave address and function code "
        "allow\n");
}

}  // namespace modtap::output
