#include "decoder/protocol/analyzer.hpp"

#include <algorithm>

namespace modtap {

// Automatic mode: both framers read the first bytes of every channel; the mode that finds
// good frames wins, and the buffered chunks are replayed through it in their order.
class Analyzer::ModeProbe {
 public:
  ModeProbe(const AnalyzerOptions& options) : options_(options) {}

  // True once the evidence is in.
  bool push(const Chunk& chunk, ChannelRole role) {
    last_ns_ = std::max(last_ns_, chunk.t_ns);
    auto& kept = chunks_.emplace_back(Kept{chunk.channel,
                                           chunk.t_ns,
                                           {chunk.bytes.begin(), chunk.bytes.end()},
                                           chunk.continues_read,
                                           chunk.read_goes_on});
    buffered_ += kept.bytes.size();
    Trial& trial = trial_for(chunk.channel, role);
    const Chunk copy{chunk.channel, kept.t_ns, kept.bytes, kept.continues_read, kept.read_goes_on};
    trial.rtu.push(copy);
    trial.ascii.push(copy);
    return rtu_count_.good >= enough || ascii_count_.good >= enough || buffered_ >= max_buffered;
  }
  Mode verdict() const { return ascii_count_.good > rtu_count_.good ? Mode::ascii : Mode::rtu; }

  // A live port's idle moment: once the line has been quiet a while (no ASCII frame pauses
  // that long between characters in practice) and the RTU trial holds nothing, a good frame in
  // one mode and none in the other is evidence enough (a quiet bus may not send three soon).
  bool flush(int64_t now_ns) {
    bool holding = false;
    for (auto& trial : trials_) {
      if (!trial) continue;
      trial->rtu.flush(now_ns);
      trial->ascii.flush(now_ns);
      holding |= trial->rtu.held_since_ns() != INT64_MAX;
    }
    return !chunks_.empty() && !holding && now_ns - last_ns_ >= quiet_ns &&
           (rtu_count_.good > 0) != (ascii_count_.good > 0);
  }

  template <typename Fn>
  void replay(Fn&& push) const {
    for (const auto& kept : chunks_)
      push(Chunk{kept.channel, kept.t_ns, kept.bytes, kept.continues_read, kept.read_goes_on});
  }

 private:
  static constexpr int enough = 3;
  static constexpr int64_t quiet_ns = 100'000'000;  // longer than any t3.5 or master's pause
  static constexpr size_t max_buffered = 4096;

  struct Counter final : FrameSink {
    int good = 0;
    void on_frame(Frame& frame) override { good += frame.check_ok; }
    void on_noise(Noise&) override {}
  };
  struct Trial {
    RtuFramer rtu;
    AsciiFramer ascii;
  };
  struct Kept {
    uint16_t channel;
    int64_t t_ns;
    std::vector<uint8_t> bytes;
    bool continues_read;
    bool read_goes_on;
  };

  Trial& trial_for(uint16_t channel, ChannelRole role) {
    while (trials_.size() <= channel) trials_.emplace_back();
    auto& trial = trials_[channel];
    if (!trial) {
      RtuFramerOptions rtu{options_.format, options_.clock, role, options_.chunk_jitter_ns};
      rtu.weights = options_.framing_weights;
      AsciiFramerOptions ascii{options_.format, options_.clock, role,
                               options_.ascii_char_timeout_ns};
      trial.reset(new Trial{{channel, rtu, rtu_count_}, {channel, ascii, ascii_count_}});
    }
    return *trial;
  }

  AnalyzerOptions options_;
  Counter rtu_count_, ascii_count_;
  std::vector<std::unique_ptr<Trial>> trials_;
  std::vector<Kept> chunks_;
  size_t buffered_ = 0;
  int64_t last_ns_ = INT64_MIN;  // when the last chunk came
};

namespace {

MatcherOptions matcher_options(const AnalyzerOptions& o) {
  MatcherOptions m;
  m.timeout_ns = o.timeout_ns;
  m.timeout_told = o.timeout_told;
  m.slave_timeout_ns = o.slave_timeout_ns;
  m.t35_ns = o.format.t35_ns();
  m.timed = o.clock != ClockQuality::none;
  m.exact_clock = o.clock == ClockQuality::per_byte;
  m.clock_lag_ns = o.clock == ClockQuality::per_chunk ? o.chunk_jitter_ns : 0;
  m.observer = o.framing_observer;
  return m;
}

}  // namespace

Analyzer::Analyzer(const AnalyzerOptions& options, std::vector<ChannelInfo> channels,
                   RecordSink& out)
    : options_(options),
      out_(out),
      matcher_(matcher_options(options), [this](const Timeout& t) { on_timeout(t); }) {
  for (auto& info : channels) channels_.push_back({std::move(info), std::monostate{}});
  if (options.mode == ModeChoice::automatic) {
    probe_ = std::make_unique<ModeProbe>(options);
  } else {
    mode_ = options.mode == ModeChoice::ascii ? Mode::ascii : Mode::rtu;
  }
}

Analyzer::~Analyzer() = default;

Analyzer::Channel& Analyzer::channel(uint16_t id) {
  while (channels_.size() <= id) channels_.push_back({ChannelInfo{}, std::monostate{}});
  Channel& c = channels_[id];
  if (std::holds_alternative<std::monostate>(c.framer) && mode_) start_framer(id, *mode_);
  return c;
}

void Analyzer::start_framer(uint16_t id, Mode mode) {
  Channel& c = channels_[id];
  if (mode == Mode::rtu) {
    RtuFramerOptions o{
        options_.format,           options_.clock,          c.info.role, options_.chunk_jitter_ns,
        options_.framing_observer, options_.framing_weights};
    c.framer = std::make_unique<RtuFramer>(id, o, static_cast<FrameSink&>(*this));
  } else {
    AsciiFramerOptions o{options_.format, options_.clock, c.info.role,
                         options_.ascii_char_timeout_ns};
    c.framer = std::make_unique<AsciiFramer>(id, o, static_cast<FrameSink&>(*this));
  }
}

void Analyzer::push(const Chunk& chunk) {
  if (options_.clock != ClockQuality::none) {
    clock_steps_back_ += chunk.t_ns < last_ns_;
    last_ns_ = std::max(last_ns_, chunk.t_ns);
  }
  feed(chunk);
}

// Pushed chunks, and those the mode probe kept and replays once the mode is known.
void Analyzer::feed(const Chunk& chunk) {
  Channel& c = channel(chunk.channel);
  if (options_.clock != ClockQuality::none) {
    settle(settled_ns(earliest_start_ns(chunk)));
  }
  if (probe_) {
    if (probe_->push(chunk, c.info.role)) settle_mode();
    return;
  }
  if (auto* rtu = std::get_if<std::unique_ptr<RtuFramer>>(&c.framer)) {
    (*rtu)->push(chunk);
  } else if (auto* ascii = std::get_if<std::unique_ptr<AsciiFramer>>(&c.framer)) {
    (*ascii)->push(chunk);
  }
}

void Analyzer::flush(int64_t now_ns) {
  if (probe_ && probe_->flush(now_ns)) settle_mode();
  for (auto& c : channels_) {
    if (auto* rtu = std::get_if<std::unique_ptr<RtuFramer>>(&c.framer)) (*rtu)->flush(now_ns);
    if (auto* ascii = std::get_if<std::unique_ptr<AsciiFramer>>(&c.framer)) (*ascii)->flush(now_ns);
  }
  if (options_.clock != ClockQuality::none) {
    settle(settled_ns(now_ns));
  }
}

// Nothing before `settled_ns` is still to be framed: a held copy whose time to be told is over
// goes as the matcher judges it, and time-outs due by then fall. A copy still held may answer
// the pending request, so that request's time-out waits for it.
void Analyzer::settle(int64_t settled_ns) {
  release_held_by(settled_ns);
  const std::optional<Frame>& first = chained_.frame ? chained_.frame : held_.frame;
  matcher_.advance(first ? std::min(settled_ns, first->t_ns) : settled_ns);
}

// A read is stamped when it came, and its bytes may have begun as early as the line could carry
// them all: until they are framed, and their frames timed, nothing times out after that. A
// time-out then falls where the frames' own times put it, as it does reading the frames back
// from a file that times each (a pcapng modtap wrote).
int64_t Analyzer::earliest_start_ns(const Chunk& chunk) const {
  return chunk.t_ns - static_cast<int64_t>(chunk.bytes.size()) * options_.format.char_time_ns();
}

int64_t Analyzer::settled_ns(int64_t now_ns) const {
  int64_t settled = now_ns;
  for (const auto& c : channels_) {
    if (auto* rtu = std::get_if<std::unique_ptr<RtuFramer>>(&c.framer))
      settled = std::min(settled, (*rtu)->held_since_ns());
    if (auto* ascii = std::get_if<std::unique_ptr<AsciiFramer>>(&c.framer))
      settled = std::min(settled, (*ascii)->held_since_ns());
  }
  return settled;
}

void Analyzer::settle_mode() {
  const auto probe = std::move(probe_);
  mode_ = probe->verdict();
  for (uint16_t id = 0; id < channels_.size(); ++id) start_framer(id, *mode_);
  probe->replay([this](const Chunk& kept) { feed(kept); });
}

void Analyzer::finish() {
  if (probe_) settle_mode();
  for (auto& c : channels_) {
    if (auto* rtu = std::get_if<std::unique_ptr<RtuFramer>>(&c.framer)) (*rtu)->finish();
    if (auto* ascii = std::get_if<std::unique_ptr<AsciiFramer>>(&c.framer)) (*ascii)->finish();
  }
  // The capture ended before the master's next move: the copy may be either. A copy of the
  // pending request stays as its time told (a retry); one of a request that timed out already,
  // read as its late answer, invents no request.
  if (held_.frame && !held_.echo && !chained_.frame) {
    held_.frame->findings |= finding_ambiguous_echo;
    release_held(!matcher_.copies_pending(*held_.frame));
  }
  if (held_.frame) release_undecided();
  matcher_.finish(last_ns_);
}

void Analyzer::on_frame(Frame& frame) {
  frame.index = next_index_++;
  if (options_.clock == ClockQuality::none) last_ns_ = std::max(last_ns_, frame.end_ns);
  const ChannelRole role = channels_[frame.channel].info.role;
  if (held_.frame || (role == ChannelRole::bus && matcher_.may_be_copy_in_doubt(frame)))
    return on_frame_in_doubt(frame, role);
  matcher_.on_frame(frame, role);
  out_.on_frame(frame);
}

// The few frames that follow a held copy, or may be one.
void Analyzer::on_frame_in_doubt(Frame& frame, ChannelRole role) {
  if (held_.frame) {
    const Frame& held = *held_.frame;
    const bool same_again = held.adu.size() == frame.adu.size() &&
                            std::equal(held.adu.begin(), held.adu.end(), frame.adu.begin());
    if (held_.echo && !chained_.frame && role == ChannelRole::bus && frame.check_ok && same_again)
      return chain(frame);
    const bool moved_on = Matcher::moved_on_after(held, frame, held_.decide_by_ns);
    if (chained_.frame) {
      release_chain(moved_on);
    } else {
      release_held(moved_on && !held_.echo);
    }
  }
  if (role == ChannelRole::bus) {
    if (const auto decide_by = matcher_.copy_in_doubt(frame)) return hold(frame, *decide_by, false);
    if (const auto decide_by = matcher_.echo_in_doubt(frame)) return hold(frame, *decide_by, true);
  }
  matcher_.on_frame(frame, role);
  out_.on_frame(frame);
}

void Analyzer::hold(const Frame& frame, int64_t decide_by_ns, bool echo) {
  held_.bytes.assign(frame.raw.begin(), frame.raw.end());
  held_.bytes.insert(held_.bytes.end(), frame.adu.begin(), frame.adu.end());
  held_.frame = frame;
  held_.frame->raw = {held_.bytes.data(), frame.raw.size()};
  held_.frame->adu = {held_.bytes.data() + frame.raw.size(), frame.adu.size()};
  held_.decide_by_ns = decide_by_ns;
  held_.echo = echo;
  matcher_.doubt(*held_.frame);
}

// The echo held before waits on, and the same bytes again are held after it (a vector's swap
// keeps the frames' views of their bytes).
void Analyzer::chain(const Frame& frame) {
  std::swap(chained_, held_);
  hold(frame, Matcher::untold_decide_by(frame, chained_.frame->end_ns), false);
}

// The master's next move decides the held copy: a request of its own sent without waiting for
// the copy's answer makes the copy the slave's late answer; anything else (noise, the request
// again, silence) leaves the matcher to judge it as any copy: the master's retry.
void Analyzer::release_held(bool late) {
  matcher_.end_doubt();
  pass_on(*held_.frame, late ? HeldAs::answer : HeldAs::judged);
  held_.frame.reset();
}

void Analyzer::release_chain(bool second_answered) {
  matcher_.end_doubt();
  pass_on(*chained_.frame, second_answered ? HeldAs::retry : HeldAs::judged);
  pass_on(*held_.frame, second_answered ? HeldAs::answer : HeldAs::judged);
  chained_.frame.reset();
  held_.frame.reset();
}

void Analyzer::pass_on(Frame& copy, HeldAs as) {
  switch (as) {
    case HeldAs::answer:
      matcher_.on_late_copy(copy);
      break;
    case HeldAs::retry:
      matcher_.on_retry_copy(copy);
      break;
    case HeldAs::judged:
      matcher_.on_frame(copy, ChannelRole::bus);
      break;
  }
  out_.on_frame(copy);
}

// Nothing came to tell the held copies apart: each goes as the matcher judges it.
void Analyzer::release_undecided() {
  if (chained_.frame) return release_chain(false);
  release_held(false);
}

void Analyzer::on_noise(Noise& noise) {
  noise.index = next_index_++;
  if (held_.frame) release_undecided();
  matcher_.on_noise(noise, channels_[noise.channel].info.role);
  out_.on_noise(noise);
}

void Analyzer::on_timeout(const Timeout& timeout) {
  out_.on_timeout(timeout);
}

}  // namespace modtap
