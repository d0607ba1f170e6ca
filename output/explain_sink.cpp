#include "output/explain_sink.hpp"

#include <algorithm>
#include <cstdlib>

#include <fmt/format.h>

#include "decoder/protocol/function_codes.hpp"

namespace modtap::output {
namespace {

// Enough for the readings weighed at every start of 8 KB of unframed bytes (a request and a
// response at each), which leave as records only once the next good frame is found.
constexpr size_t kept_steps = 16384;
// A channel's judgements of copies of the pending request, kept until their records come.
constexpr size_t kept_copies = 64;
// Edge bytes weighed, kept until their records come: a piece's two edges at most, a few times.
constexpr size_t kept_edges = 64;

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

// A start weighed again (more bytes came) makes what was weighed there stale; the starts after
// it that the framer weighs again are told apart the same way.
void ExplainSink::on_start(uint16_t channel, uint64_t offset) {
  ChannelSteps& steps = steps_[channel];
  if (const auto stale = steps.at.find(offset); stale != steps.at.end()) {
    steps.count -= stale->second.size();
    steps.at.erase(stale);
  }
}

void ExplainSink::on_reading(const FramingStep& step) {
  ChannelSteps& steps = steps_[step.channel];
  steps.at[step.offset].push_back(step);
  if (++steps.count <= kept_steps) return;
  const auto oldest = steps.at.begin();
  steps.lost_through = std::max(steps.lost_through.value_or(0), oldest->first);
  steps.count -= oldest->second.size();
  steps.at.erase(oldest);
}

void ExplainSink::on_copy(uint16_t channel, uint64_t offset, const Margin& margin) {
  copies_.push_back({channel, offset, margin});
  if (copies_.size() > kept_copies) copies_.pop_front();
}

void ExplainSink::on_role(uint16_t channel, uint64_t offset, Role role, RoleReason why) {
  roles_.push_back({channel, offset, role, why});
  if (roles_.size() > kept_copies) roles_.pop_front();
}

void ExplainSink::on_pair(uint16_t channel, uint64_t offset, PairReason how) {
  pairs_.push_back({channel, offset, how});
  if (pairs_.size() > kept_copies) pairs_.pop_front();
}

void ExplainSink::on_edge_byte(uint16_t channel, const EdgeByte& edge) {
  edges_.push_back({channel, edge});
  if (edges_.size() > kept_edges) edges_.pop_front();
}

void ExplainSink::on_piece_header(uint16_t channel, const PieceHeader& header) {
  headers_.push_back({channel, header});
  if (headers_.size() > kept_edges) headers_.pop_front();
}

// A channel's records come in the order of their bytes: what was weighed before a record's end
// is of no record to come.
void ExplainSink::forget_before(ChannelSteps& channel, uint64_t offset) {
  const auto end = channel.at.lower_bound(offset);
  for (auto it = channel.at.begin(); it != end; ++it) channel.count -= it->second.size();
  channel.at.erase(channel.at.begin(), end);
}

void ExplainSink::on_frame(const Frame& frame) {
  const bool is_picked = picked(frame);
  if (is_picked) explain_frame(frame);
  place(segment_of(frame), is_picked);
  forget_before(steps_[frame.channel], frame.offset + frame.raw.size());
}

void ExplainSink::explain_frame(const Frame& frame) {
  text_.on_frame(frame);
  explain(frame.channel, frame.offset, frame.mode);
  print_copy(frame);
  if (frame.mode == Mode::rtu && frame.damage != Damage::none) {
    print_inside(frame.channel, frame.offset, frame.raw.size());
    print_damage(frame);
    print_piece_header(frame.channel, frame.offset);
    print_edges(frame.channel, frame.offset, frame.raw.size());
  }
  print_role(frame);
}

// What made the piece a damaged frame: the length its structure says, against what came.
void ExplainSink::print_damage(const Frame& frame) {
  out_.print(
      "  then, no reading holding, the bytes up to the next good frame or silence were one "
      "piece: ");
  const size_t size = frame.raw.size();
  const BodyLength body = body_length(frame.role, frame.raw);
  const bool told = body.kind == BodyLength::Kind::known;
  const size_t claimed = body.bytes + 2u;  // its CRC
  switch (frame.damage) {
    case Damage::cut:
      if (told)
        out_.print("the awaited answer, whose structure says {}; {} came: {}\n",
                   counted(claimed, "byte", "bytes"), size, to_string(frame.damage));
      else
        out_.print("the awaited answer's first {}, too few to tell its length: {}\n",
                   counted(size, "byte", "bytes"), to_string(frame.damage));
      return;
    case Damage::collision:
      out_.print(
          "the awaited answer and more: its structure says {}, whose check fails, and the "
          "bytes after them are records of their own: {}\n",
          counted(size, "byte", "bytes"), to_string(frame.damage));
      return;
    default:
      out_.print("a header whose length rules say these {} exactly, whose check fails: {}\n",
                 counted(size, "byte", "bytes"), to_string(frame.damage));
  }
}

void ExplainSink::on_noise(const Noise& noise) {
  const bool is_picked = picked(noise);
  if (is_picked) explain_noise(noise);
  place(segment_of(noise), is_picked);
  forget_before(steps_[noise.channel], noise.offset + noise.raw.size());
}

void ExplainSink::explain_noise(const Noise& noise) {
  text_.on_noise(noise);
  explain(noise.channel, noise.offset, noise.mode);
  if (noise.mode != Mode::rtu) return;
  print_inside(noise.channel, noise.offset, noise.raw.size());
  out_.print(
      "  then, no reading holding, the bytes up to the next good frame or silence were "
      "noise: {}\n",
      to_string(noise.reason));
  print_piece_header(noise.channel, noise.offset);
  print_edges(noise.channel, noise.offset, noise.raw.size());
}

void ExplainSink::on_timeout(const Timeout& timeout) {
  if (!picked(timeout)) return;
  text_.on_timeout(timeout);
  out_.print("  a time-out: the matcher's, after the request's wait; no framing decided it\n");
}

ExplainSink::Segment ExplainSink::segment_of(const Frame& frame) {
  return {frame.index, frame.channel,  frame.offset, frame.raw.size(), false,
          frame.role,  frame.check_ok, frame.damage, NoiseReason::junk};
}

ExplainSink::Segment ExplainSink::segment_of(const Noise& noise) {
  return {noise.index,   noise.channel, noise.offset, noise.raw.size(), true,
          Role::request, false,         Damage::none, noise.reason};
}

void ExplainSink::place(const Segment& segment, bool is_picked) {
  if (after_due_ == segment.channel) {
    print_segment(segment, false);
    after_due_.reset();
  }
  if (is_picked) {
    out_.print("  the segmentation around it:\n");
    if (const auto before = last_on_channel_.find(segment.channel);
        before != last_on_channel_.end())
      print_segment(before->second, false);
    print_segment(segment, true);
    after_due_ = segment.channel;
  }
  last_on_channel_[segment.channel] = segment;
}

void ExplainSink::print_segment(const Segment& segment, bool is_picked) {
  out_.print("    #{} bytes {}-{}: ", segment.index, segment.offset,
             segment.offset + segment.size - 1);
  if (is_picked)
    out_.print("this record\n");
  else if (segment.noise)
    out_.print("noise ({}), {}\n", to_string(segment.reason),
               counted(segment.size, "byte", "bytes"));
  else if (segment.check_ok)
    out_.print("{}, {} bytes, check ok\n", to_string(segment.role), segment.size);
  else
    out_.print("{}, {} bytes, check bad ({})\n", to_string(segment.role), segment.size,
               to_string(segment.damage));
}

void ExplainSink::explain(uint16_t channel, uint64_t offset, Mode mode) {
  const std::string_view name =
      channel < channels_.size() ? std::string_view(channels_[channel].name) : "the capture";
  if (mode == Mode::ascii) {
    out_.print("  ASCII: ':' starts a frame and CR LF ends it; no reading is weighed\n");
    return;
  }
  out_.print("  at byte {} of {}, the framer weighed:\n", offset, name);
  const ChannelSteps& steps = steps_[channel];
  if (steps.lost_through && *steps.lost_through >= offset) {
    out_.print(
        "    the readings weighed here are no longer held: unframed bytes ran on past the {} "
        "starts --explain holds\n",
        kept_steps / 2);
    return;
  }
  std::vector<const FramingStep*> weighed;
  if (const auto here = steps.at.find(offset); here != steps.at.end())
    for (const FramingStep& step : here->second) weighed.push_back(&step);
  if (weighed.empty())
    out_.print(
        "    no reading: the byte starts no frame a slave address and function code "
        "allow\n");
  else
    print_weighed(weighed);
}

// Where a reading inside unframed bytes had its length rules and CRC agree, and the evidence
// refuted it: why no frame was cut there. Starts refuted whatever their end are many (most
// bytes of a collision's junk), so each row that did is said once, with how many.
void ExplainSink::print_inside(uint16_t channel, uint64_t offset, size_t size) {
  const ChannelSteps& steps = steps_[channel];
  std::map<Evidence, size_t> at_start;
  for (auto it = steps.at.upper_bound(offset); it != steps.at.end() && it->first < offset + size;
       ++it) {
    std::vector<const FramingStep*> refuted;
    for (const FramingStep& step : it->second)
      if (step.outcome == ReadingOutcome::refuted) refuted.push_back(&step);
    // A start's readings are refuted at it together, by one row: the start counts once.
    const FramingStep& first = it->second.front();
    if (first.outcome == ReadingOutcome::refuted_at_start) ++at_start[first.why];
    if (refuted.empty()) continue;
    out_.print("  at byte {}, inside it, a span whose length rules and CRC agree:\n", it->first);
    print_weighed(refuted);
  }
  for (const auto& [why, starts] : at_start) {
    out_.print("  at {} inside it, every reading refuted whatever its end:\n",
               counted(starts, "start", "starts"));
    print_row(evidence_info(why), -1);
  }
}

// The readings weighed at one start, then the winner's margin.
void ExplainSink::print_weighed(const std::vector<const FramingStep*>& weighed) {
  for (size_t i = 0; i < weighed.size(); ++i) {
    const bool same_span = i > 0 && weighed[i]->outcome == ReadingOutcome::refuted &&
                           weighed[i - 1]->outcome == ReadingOutcome::refuted &&
                           weighed[i]->length == weighed[i - 1]->length;
    if (same_span)
      out_.print(
          "    {}, {} bytes: refuted, the same span: the evidence is of the bytes, "
          "whatever role they are read in\n",
          to_string(weighed[i]->role), weighed[i]->length);
    else
      print_reading(*weighed[i]);
  }
  print_margin(weighed);
}

void ExplainSink::print_reading(const FramingStep& step) {
  const EvidenceInfo& why = evidence_info(step.why);
  out_.print("    {}", to_string(step.role));
  if (step.length) out_.print(", {} bytes", step.length);
  if (!scored(step)) {
    out_.print(": {} ({}: {})\n", to_string(step.outcome), why.name, why.why);
    return;
  }
  const bool at_start = step.outcome == ReadingOutcome::refuted_at_start;
  out_.print(": {}, {}{:+} bits\n", to_string(step.outcome), at_start ? "at most " : "",
             step.score());
  if (step.end != SpanEnd::length_rules) {
    const SpanEndInfo& end = span_end_info(step.end);
    out_.print("            its end ({}): {}\n", end.name, end.why);
    print_confirmation(step.end);
  }
  print_row(evidence_info(Evidence::length_and_crc), +1);
  if (step.outcome != ReadingOutcome::kept) print_row(why, -1);
  if (step.outcome == ReadingOutcome::kept) print_end_margin(step.end_margin);
}

// What made up for a CRC search's tries at the end it found, where the search made one.
void ExplainSink::print_confirmation(SpanEnd end) {
  if (end == SpanEnd::echo_length) return;
  const std::optional<Feature> by = span_end_info(end).confirmed_by;
  if (!by) {
    out_.print(
        "              stands unconfirmed: nothing more can come to confirm it (0 of the "
        "search's {} bits)\n",
        search_bits);
    return;
  }
  const FeatureInfo& feature = feature_info(*by);
  out_.print("              confirmed, {} bits of the search's {}: {}: {}\n", feature.bits,
             search_bits, feature.name, feature.why);
}

// A kept frame's end against its runner-up, where it has one.
void ExplainSink::print_end_margin(const Margin& margin) {
  if (margin.runner_up == RunnerUp::none) return;
  out_.print("            its end's runner-up: {}\n", to_string(margin.runner_up));
  print_runner_up(margin, "ambiguous-end");
}

void ExplainSink::print_runner_up(const Margin& margin, std::string_view finding) {
  if (!margin.told) {
    out_.print(
        "              stands: nothing in the bytes or their times tells the two apart "
        "(0 of {} bits): {}\n",
        decisive_bits, finding);
    return;
  }
  const FeatureInfo& told = feature_info(*margin.told);
  out_.print("              ruled out, {} bits: {}: {}\n", margin.bits, told.name, told.why);
}

// A frame that copies the pending request: the slave's echo or the master's retry, as the
// matcher judged it by its time.
// The matcher's last word on the frame's role (a held copy is told twice: first as it was held,
// then as the master's next move showed it).
void ExplainSink::print_role(const Frame& frame) {
  const auto given = std::find_if(roles_.rbegin(), roles_.rend(), [&](const RoleGiven& r) {
    return r.channel == frame.channel && r.offset == frame.offset;
  });
  if (given == roles_.rend()) return;
  out_.print(
      "  the matcher read it as {}: {}\n",
      given->role == Role::unknown ? "neither role" : "a " + std::string(to_string(given->role)),
      to_string(given->why));
  const auto paired = std::find_if(pairs_.rbegin(), pairs_.rend(), [&](const PairGiven& p) {
    return p.channel == frame.channel && p.offset == frame.offset;
  });
  if (paired == pairs_.rend()) return;
  out_.print("  paired with {}{}\n", frame.request ? fmt::format("#{}, ", *frame.request) : "",
             to_string(paired->how));
}

void ExplainSink::print_copy(const Frame& frame) {
  const auto copy = std::find_if(copies_.rbegin(), copies_.rend(), [&](const Copy& c) {
    return c.channel == frame.channel && c.offset == frame.offset;
  });
  if (copy == copies_.rend()) return;
  const bool echo = copy->margin.runner_up == RunnerUp::retry;
  out_.print("  a copy of the pending request, taken for {}; its runner-up: {}\n",
             to_string(echo ? RunnerUp::echo : RunnerUp::retry), to_string(copy->margin.runner_up));
  print_runner_up(copy->margin, "ambiguous-echo");
}

// Each 0x00 or 0xFF weighed at an edge of a piece that became this record, or right next to it
// (the glitch taken from the record's edge).
void ExplainSink::print_edges(uint16_t channel, uint64_t offset, size_t size) {
  for (const Edge& e : edges_)
    if (e.channel == channel && e.edge.offset + 1 >= offset && e.edge.offset <= offset + size)
      print_edge(e.edge);
}

void ExplainSink::print_edge(const EdgeByte& edge) {
  const bool first = edge.side == EdgeSide::first;
  const std::string_view glitch = first ? "the answering driver's glitch, before its answer"
                                        : "the next sender's glitch, after the answer";
  const std::string_view own = first ? "the piece's own first byte" : "the answer's own last byte";
  out_.print("  byte {} ({:02X}), the {} of the piece, read two ways:\n", edge.offset, edge.value,
             first ? "first" : "last");
  print_two_way_reading(glitch, std::span(edge.for_glitch).first(edge.glitch_features));
  print_two_way_reading(own, std::span(edge.for_byte).first(edge.byte_features));
  const int lead = std::abs(edge.glitch_bits() - edge.byte_bits());
  out_.print("  taken for {}, ", edge.glitch() ? glitch : own);
  if (lead == 0)
    out_.print("the evidence tied, and {}", to_string(edge.habit));
  else
    out_.print("by {}", counted(lead, "bit", "bits"));
  const Margin margin = edge.margin();
  if (margin.runner_up == RunnerUp::none)
    out_.print(": the glitch is no runner-up on a quiet bus\n");
  else if (margin.stands())
    out_.print(": the runner-up stands (a lead of {} rules it out): ambiguous-end\n",
               counted(decisive_bits, "bit", "bits"));
  else
    out_.print(": the runner-up is ruled out\n");
}

void ExplainSink::print_two_way_reading(std::string_view reading,
                                        std::span<const Feature> features) {
  if (features.empty()) {
    out_.print("    {}: +0 bits, no feature speaks for it\n", reading);
    return;
  }
  out_.print("    {}: {:+} bits\n", reading, feature_bits(features));
  for (const Feature f : features) {
    const FeatureInfo& feature = feature_info(f);
    out_.print("       {:+4}  {}: {}\n", feature.bits, feature.name, feature.why);
  }
}

void ExplainSink::print_piece_header(uint16_t channel, uint64_t offset) {
  for (const Header& h : headers_) {
    if (h.channel != channel || h.header.offset != offset) continue;
    const PieceHeader& header = h.header;
    out_.print("  its header, which allows a frame of the piece's length, read two ways:\n");
    print_two_way_reading("a damaged frame",
                          std::span(header.for_frame).first(header.frame_features));
    print_two_way_reading("noise", std::span(header.for_noise).first(header.noise_features));
    const int lead = header.noise_bits() - header.frame_bits();
    if (header.noise())
      out_.print("  taken for noise, by {}\n", counted(lead, "bit", "bits"));
    else
      out_.print("  taken for a damaged frame: noise needs a lead of {} (it has {})\n",
                 counted(decisive_bits, "bit", "bits"), lead);
    return;
  }
}

// A row's weight and why, then its features': the crc's row is its one feature.
void ExplainSink::print_row(const EvidenceInfo& row, int sign) {
  if (row.feature_count == 1) {
    const FeatureInfo& feature = feature_info(row.features[0]);
    out_.print("      {:+4}  {}: {}\n", sign * feature.bits, feature.name, feature.why);
    return;
  }
  out_.print("      {:+4}  {}: {}\n", sign * row.bits(), row.name, row.why);
  for (size_t i = 0; i < row.feature_count; ++i) print_feature(row.features[i], sign);
  if (row.for_span) print_feature(*row.for_span, -sign);
}

void ExplainSink::print_feature(Feature f, int sign) {
  const FeatureInfo& feature = feature_info(f);
  out_.print("              {:+4}  {}: {}\n", sign * feature.bits, feature.name, feature.why);
}

// What won at the start, against the best of the rest; no frame at all scores 0 (the bytes
// are junk, a glitch or a damaged frame's).
void ExplainSink::print_margin(const std::vector<const FramingStep*>& weighed) {
  const auto kept = std::find_if(weighed.begin(), weighed.end(), [](const FramingStep* step) {
    return step->outcome == ReadingOutcome::kept;
  });
  const FramingStep* runner_up = nullptr;
  for (const FramingStep* step : weighed)
    if (scored(*step) && step->outcome != ReadingOutcome::kept &&
        (!runner_up || step->score() > runner_up->score()))
      runner_up = step;
  if (kept != weighed.end()) {
    const bool beats_nothing = !runner_up || runner_up->score() < 0;
    out_.print("  kept by {} bits over the runner-up: {}\n",
               (*kept)->score() - (beats_nothing ? 0 : runner_up->score()),
               beats_nothing
                   ? std::string("no frame here (0 bits)")
                   : fmt::format("{} ({:+} bits)", reading_name(*runner_up), runner_up->score()));
  } else if (runner_up) {
    out_.print("  no frame here (0 bits), by {} bits over the runner-up: {}\n", -runner_up->score(),
               reading_name(*runner_up));
  }
}

// Whether the reading was scored: its span weighed, or refuted at its start.
bool ExplainSink::scored(const FramingStep& step) {
  return step.outcome == ReadingOutcome::kept || step.outcome == ReadingOutcome::refuted ||
         step.outcome == ReadingOutcome::refuted_at_start;
}

std::string ExplainSink::reading_name(const FramingStep& step) {
  if (step.outcome == ReadingOutcome::refuted_at_start)
    return fmt::format("the {}, whatever its end", to_string(step.role));
  return fmt::format("the {} of {} bytes", to_string(step.role), step.length);
}

}  // namespace modtap::output
