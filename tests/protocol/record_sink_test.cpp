#include "decoder/protocol/record_sink.hpp"

#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace modtap {
namespace {

// What reached the end of a chain: each record's kind and start, "f@0", "n@5", "t@9".
class Seen final : public RecordSink {
 public:
  void on_frame(const Frame& f) override { kept.push_back("f@" + std::to_string(f.t_ns)); }
  void on_noise(const Noise& n) override { kept.push_back("n@" + std::to_string(n.t_ns)); }
  void on_timeout(const Timeout& t) override { kept.push_back("t@" + std::to_string(t.t_ns)); }
  std::vector<std::string> kept;
};

Frame frame_at(int64_t t_ns) {
  Frame f;
  f.t_ns = t_ns;
  return f;
}

Noise noise_at(int64_t t_ns) {
  Noise n;
  n.t_ns = t_ns;
  return n;
}

Timeout timeout_at(int64_t t_ns) {
  Timeout t;
  t.t_ns = t_ns;
  return t;
}

// -c N counts frames and noise, as tshark counts packets; a time-out is modtap's own record:
// it does not count, and passes after the limit only when it was known before the last record.
TEST(RecordLimit, CountsFramesAndNoiseAndKeepsTheTimeOutsBeforeTheLimit) {
  Seen seen;
  int reached = 0;
  RecordLimit limit(3, seen, [&] { ++reached; });
  limit.on_frame(frame_at(0));
  limit.on_timeout(timeout_at(10));
  limit.on_noise(noise_at(20));
  EXPECT_FALSE(limit.reached());
  limit.on_frame(frame_at(30));
  EXPECT_TRUE(limit.reached());
  limit.on_timeout(timeout_at(25));  // known before the third record: shown
  limit.on_timeout(timeout_at(40));  // after it: past the limit
  limit.on_noise(noise_at(50));
  limit.on_frame(frame_at(60));
  EXPECT_EQ(seen.kept, (std::vector<std::string>{"f@0", "t@10", "n@20", "f@30", "t@25"}));
  EXPECT_EQ(reached, 1);
}

// The clock of every record that goes through, for sinks behind a filter: the first record's
// time and the one before the record being handed on, whichever of them the filter keeps.
TEST(ClockStage, KnowsTheFirstRecordAndTheOneBeforeWhateverPassesOn) {
  struct Reader final : RecordSink {
    const RecordClock* clock = nullptr;
    std::vector<std::pair<int64_t, int64_t>> read;  // first, previous (-1: none)
    void on_frame(const Frame&) override { read.push_back({*clock->first_ns, previous()}); }
    void on_noise(const Noise&) override { read.push_back({*clock->first_ns, previous()}); }
    void on_timeout(const Timeout&) override { read.push_back({*clock->first_ns, previous()}); }
    int64_t previous() const { return clock->previous_ns.value_or(-1); }
  } reader;
  RecordClock clock;
  reader.clock = &clock;
  ClockStage stage(clock, reader);
  stage.on_noise(noise_at(5));
  stage.on_frame(frame_at(7));
  stage.on_timeout(timeout_at(12));
  EXPECT_EQ(reader.read, (std::vector<std::pair<int64_t, int64_t>>{{5, -1}, {5, 5}, {5, 7}}));
}

}  // namespace
}  // namespace modtap
