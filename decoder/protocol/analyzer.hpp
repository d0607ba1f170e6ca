// The pipeline for one bus: a framer per channel feeding one matcher, records out in order.
// It owns no I/O: sources push chunks in, a RecordSink takes records out.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string_view>
#include <variant>
#include <vector>

#include "decoder/protocol/ascii_framer.hpp"
#include "decoder/protocol/frame_sink.hpp"
#include "decoder/protocol/framing_evidence.hpp"
#include "decoder/protocol/matcher.hpp"
#include "decoder/protocol/record_sink.hpp"
#include "decoder/protocol/records.hpp"
#include "decoder/protocol/rtu_framer.hpp"
#include "decoder/protocol/serial_format.hpp"

namespace modtap {

enum class ModeChoice : uint8_t { automatic, rtu, ascii };
template <>
struct EnumNames<ModeChoice> {
  static constexpr std::array<std::string_view, 3> names{"auto", "rtu", "ascii"};
};

struct AnalyzerOptions {
  ModeChoice mode = ModeChoice::automatic;
  SerialFormat format;
  ClockQuality clock = ClockQuality::per_chunk;
  int64_t timeout_ns = 1'000'000'000;
  // The master's time-out is timeout_ns as the user told it (--timeout), not a default: no
  // retry comes before it. A slave's model time-out is told for that slave.
  bool timeout_told = false;
  const SlaveTimeouts* slave_timeout_ns = nullptr;  // those slaves' whose model sets their own
  int64_t ascii_char_timeout_ns = 1'000'000'000;
  int64_t chunk_jitter_ns = default_read_jitter_ns;
  // Told the readings the RTU framer weighs at each start (--explain); not the mode trials'.
  FramingObserver* framing_observer = nullptr;
  FeatureWeights framing_weights = table_weights;  // the RTU framer's evidence table's weights
};

class Analyzer final : private FrameSink {
 public:
  Analyzer(const AnalyzerOptions& options, std::vector<ChannelInfo> channels, RecordSink& out);
  ~Analyzer() override;

  void push(const Chunk& chunk);
  void flush(int64_t now_ns);  // live sources: call on idle so silences resolve frames
  void finish();

  // The mode the bus settled on (automatic mode decides from the first frames).
  std::optional<Mode> mode() const { return mode_; }
  // How often a chunk's time stamp was earlier than one before it (a capture whose clock
  // stepped back); latencies across such a step are not measured.
  uint64_t clock_steps_back() const { return clock_steps_back_; }
  const Matcher& matcher() const { return matcher_; }
  // No byte pushed so far waits in a framer or in the mode's probe: what comes next begins
  // a new record, so a file of raw reads may turn here without cutting a frame in two.
  bool between_frames() const { return !probe_ && settled_ns(INT64_MAX) == INT64_MAX; }

 private:
  class ModeProbe;
  using Framer =
      std::variant<std::monostate, std::unique_ptr<RtuFramer>, std::unique_ptr<AsciiFramer>>;
  struct Channel {
    ChannelInfo info;
    Framer framer;
  };

  Channel& channel(uint16_t id);
  void feed(const Chunk& chunk);
  // The matcher's clock: never past a byte a framer still holds, so a response that framer
  // has yet to emit is not preceded by its request's time-out.
  int64_t settled_ns(int64_t now_ns) const;
  int64_t earliest_start_ns(const Chunk& chunk) const;
  void start_framer(uint16_t id, Mode mode);
  void settle_mode();
  void on_frame(Frame& frame) override;
  void on_noise(Noise& noise) override;
  const Expectation& expectation() const override { return matcher_.expectation(); }
  void on_timeout(const Timeout& timeout);
  // A copy the matcher cannot yet tell from a retry (Matcher::copy_in_doubt), or an echo only
  // its slave's learned turnaround tells from one (Matcher::echo_in_doubt), waits, its bytes
  // copied, for the master's next move: the next frame, or the clock past its decide-by time.
  // The same bytes again after such an echo wait with it, chained: the master moving on right
  // after them shows that they were the answer, and the first copy the master's retry.
  struct HeldCopy {
    std::optional<Frame> frame;
    std::vector<uint8_t> bytes;  // its raw and ADU bytes, kept from one copy to the next
    int64_t decide_by_ns = 0;
    bool echo = false;  // held by echo_in_doubt: the same bytes again are chained to it
  };
  void on_frame_in_doubt(Frame& frame, ChannelRole role);
  void hold(const Frame& frame, int64_t decide_by_ns, bool echo);
  void chain(const Frame& frame);
  void release_held(bool late);
  // The chained copies as the master's next move told them: the second the answer to the
  // first, or each as the matcher judges it.
  void release_chain(bool second_answered);
  void release_undecided();
  // How the master's next move told a held copy: the answer, the master's retry, or untold
  // (judged by the matcher as any copy).
  enum class HeldAs : uint8_t { answer, retry, judged };
  void pass_on(Frame& copy, HeldAs as);
  void settle(int64_t settled_ns);
  void release_held_by(int64_t now_ns) {
    if (held_.frame && now_ns >= held_.decide_by_ns) release_undecided();
  }

  AnalyzerOptions options_;
  std::vector<Channel> channels_;
  RecordSink& out_;
  Matcher matcher_;
  std::unique_ptr<ModeProbe> probe_;  // until automatic mode has decided
  std::optional<Mode> mode_;
  uint64_t next_index_ = 1;
  int64_t last_ns_ = 0;
  uint64_t clock_steps_back_ = 0;
  HeldCopy held_;
  HeldCopy chained_;  // an echo in doubt that the held copy repeats
};

}  // namespace modtap
