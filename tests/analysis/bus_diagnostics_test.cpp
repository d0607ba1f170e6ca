#include "decoder/analysis/bus_diagnostics.hpp"

#include <gtest/gtest.h>

#include <map>
#include <set>

#include "decoder/analysis/bus_statistics.hpp"
#include "decoder/models/model_interpreter.hpp"
#include "decoder/protocol/analyzer.hpp"
#include "decoder/protocol/checksum.hpp"
#include "tests/support/collector.hpp"
#include "tools/busgen/bus_simulator.hpp"
#include "tools/modtap/model_catalog.hpp"

namespace modtap {
namespace {

using testing::Collector;

// Records handed straight to the stage, as the analyzer would hand them; the stage hands them
// on to a collector and to the statistics, which keep the outages.
class History {
 public:
  explicit History(ClockQuality clock = ClockQuality::per_byte,
                   int64_t read_jitter_ns = default_read_jitter_ns)
      : statistics_(SerialFormat{}, clock), stage_(SerialFormat{}, clock, fan_, read_jitter_ns) {
    fan_.add(out);
    fan_.add(statistics_);
  }

  // A good frame from `hex` (slave, PDU; the CRC is added) at `t_ms`.
  uint32_t frame(Role role, const std::string& hex, int64_t t_ms, uint32_t findings = 0) {
    auto& adu = adus_.emplace_back(testing::hex(hex));
    const uint16_t crc = crc16(adu);
    adu.push_back(crc & 0xFF);
    adu.push_back(crc >> 8);
    Frame f;
    f.index = ++index_;
    f.role = role;
    f.raw = f.adu = adu;
    f.check_ok = true;
    f.findings = findings;
    f.t_ns = t_ms * 1'000'000;
    f.end_ns = f.t_ns + 4'000'000;
    stage_.on_frame(f);
    return out.records.back().findings;
  }
  void timeout(uint8_t slave, uint8_t function, uint64_t request, int64_t t_ms) {
    Timeout t;
    t.slave = slave;
    t.function = function;
    t.request = request;
    t.t_ns = t_ms * 1'000'000;
    t.waited_ns = 1'000'000'000;
    t.reason = TimeoutReason::silence;
    stage_.on_timeout(t);
  }
  // Junk where slave `slave`'s answer to `request` was awaited, as a frame with a bad check.
  void garbled_answer(uint8_t slave, uint64_t request, int64_t t_ms) {
    Frame f;
    f.index = ++index_;
    f.role = Role::response;
    f.raw = f.adu = adus_.emplace_back(testing::hex("5A 47 14 19 0F A5"));
    f.request = request;
    f.request_slave = slave;
    f.t_ns = t_ms * 1'000'000;
    f.end_ns = f.t_ns + 3'000'000;
    stage_.on_frame(f);
  }
  // The same as a noise record: bytes that are no frame at all.
  void garbled_noise(uint8_t slave, uint64_t request, int64_t t_ms) {
    Noise n;
    n.index = ++index_;
    n.raw = adus_.emplace_back(testing::hex("B2 A6 C6 18"));
    n.request = request;
    n.request_slave = slave;
    n.damaged_answer = true;
    n.t_ns = t_ms * 1'000'000;
    stage_.on_noise(n);
  }
  const BusStatistics& statistics() const { return statistics_; }
  Collector out;

 private:
  FanOut fan_;
  BusStatistics statistics_;
  BusDiagnostics stage_;
  std::vector<std::vector<uint8_t>> adus_{};
  uint64_t index_ = 0;
};

TEST(BusDiagnostics, ASlaveThatGoesSilentAndComesBackIsAnOutageWithBothTimes) {
  History bus;
  int64_t t = 0;
  for (int i = 0; i < 4; ++i) {
    bus.frame(Role::request, "07 03 00 00 00 01", t);
    bus.timeout(7, 3, i + 1, t + 1004);
    t += 1100;
  }
  bus.frame(Role::request, "07 03 00 00 00 01", t);
  EXPECT_EQ(bus.frame(Role::response, "07 03 02 00 2A", t + 20) & finding_answers_again,
            finding_answers_again);
  ASSERT_EQ(bus.statistics().outages().size(), 1u);
  const Outage& outage = bus.statistics().outages()[0];
  EXPECT_EQ(outage.slave, 7);
  EXPECT_EQ(outage.first_request, 1u);
  EXPECT_EQ(outage.silent_from_ns, 4'000'000);  // the end of the first unanswered request
  EXPECT_EQ(outage.timeouts, 4u);
  EXPECT_EQ(outage.back_ns, (t + 20) * 1'000'000);
  // Two time-outs in a row are no outage, and the next answer says nothing.
  bus.timeout(7, 3, 9, t + 2000);
  bus.timeout(7, 3, 10, t + 3000);
  EXPECT_EQ(bus.frame(Role::response, "07 03 02 00 2A", t + 3100) & finding_answers_again, 0u);
  EXPECT_EQ(bus.statistics().outage_count(), 1u);
}

// An outage is a device gone silent; one that answers in junk (another baud rate, a broken
// driver) is there, and its problem is the junk, not silence.
TEST(BusDiagnostics, AGarbledAnswerEndsASilenceAsAGoodOneDoes) {
  for (const bool as_noise : {false, true}) {
    History bus;
    int64_t t = 0;
    for (uint64_t i = 0; i < 3; ++i) {
      bus.frame(Role::request, "07 03 00 00 00 01", t);
      bus.timeout(7, 3, bus.out.records.back().index, t + 1004);
      t += 1100;
    }
    bus.frame(Role::request, "07 03 00 00 00 01", t);
    const uint64_t request = bus.out.records.back().index;
    if (as_noise) {
      bus.garbled_noise(7, request, t + 20);
    } else {
      bus.garbled_answer(7, request, t + 20);
    }
    ASSERT_EQ(bus.statistics().outages().size(), 1u) << as_noise;
    EXPECT_EQ(bus.statistics().outages()[0].back_ns, (t + 20) * 1'000'000) << as_noise;
    // Silent again later: a second outage, counted from its own first time-out.
    for (uint64_t i = 0; i < 3; ++i) bus.timeout(7, 3, request + 1 + i, t + 2000 + 1000 * i);
    EXPECT_EQ(bus.statistics().outage_count(), 2u) << as_noise;
  }
}

TEST(BusDiagnostics, TheFifthSameExceptionInARowIsAStorm) {
  History bus;
  uint32_t found = 0;
  for (int i = 0; i < 6; ++i) {
    bus.frame(Role::request, "05 06 00 10 00 01", i * 100);
    found = bus.frame(Role::response, "05 86 02", i * 100 + 10);
    EXPECT_EQ((found & finding_exception_storm) != 0, i >= 4) << i;
  }
  // Another code, or an answer that is no exception, starts the count again.
  bus.frame(Role::response, "05 86 03", 700);
  EXPECT_EQ(bus.out.records.back().findings & finding_exception_storm, 0u);
  // Another slave's exceptions are its own.
  for (int i = 0; i < 4; ++i) bus.frame(Role::response, "06 86 03", 800 + i);
  EXPECT_EQ(bus.out.records.back().findings & finding_exception_storm, 0u);
}

TEST(BusDiagnostics, AnAnswerAfterItsRequestTimedOutIsLate) {
  History bus;
  bus.frame(Role::request, "09 04 00 00 00 02", 0);
  bus.timeout(9, 4, 1, 1004);
  EXPECT_EQ(bus.frame(Role::response, "09 04 04 00 01 00 02", 1200, finding_unsolicited) &
                finding_late_response,
            finding_late_response);
  // Once the master asked that slave again, an unsolicited answer is not this one's.
  bus.frame(Role::request, "09 04 00 00 00 02", 2000);
  bus.timeout(9, 4, 3, 3004);
  bus.frame(Role::request, "09 04 00 00 00 02", 3100);
  EXPECT_EQ(bus.frame(Role::response, "09 04 04 00 01 00 02", 3300, finding_unsolicited) &
                finding_late_response,
            0u);
}

TEST(BusDiagnostics, APollFarFromTheSlavesUsualIntervalIsPollJitter) {
  for (ClockQuality clock : {ClockQuality::per_byte, ClockQuality::per_chunk}) {
    History bus(clock);
    int64_t t = 0;
    // A cycle of 100 ms, give or take 10: the usual interval, learnt over eight polls.
    for (int i = 0; i < 12; ++i, t += 100 + (i % 3 - 1) * 10)
      EXPECT_EQ(bus.frame(Role::request, "05 03 00 00 00 04", t) & finding_poll_jitter, 0u) << i;
    t += 60;  // the cycle stalled: 160 ms
    EXPECT_EQ(bus.frame(Role::request, "05 03 00 00 00 04", t) & finding_poll_jitter,
              finding_poll_jitter);
    t += 40;  // and hurried to catch up
    EXPECT_EQ(bus.frame(Role::request, "05 03 00 00 00 04", t) & finding_poll_jitter,
              finding_poll_jitter);
    t += 100;
    EXPECT_EQ(bus.frame(Role::request, "05 03 00 00 00 04", t) & finding_poll_jitter, 0u);
    // A retry is the master's time-out at work: neither jitter nor a new start of the cycle.
    EXPECT_EQ(
        bus.frame(Role::request, "05 03 00 00 00 04", t + 30, finding_retry) & finding_poll_jitter,
        0u);
    EXPECT_EQ(bus.frame(Role::request, "05 03 00 00 00 04", t + 100) & finding_poll_jitter, 0u);
  }
}

// The usual interval is the median of the last sixteen: a master that slows its cycle for
// good is jitter only until the new cycle is most of what the slave has seen.
TEST(BusDiagnostics, ACycleThatChangesForGoodBecomesTheUsualOne) {
  History bus(ClockQuality::per_byte);
  int64_t t = 0;
  const auto jitter_after = [&](int64_t ms) {
    t += ms;
    return (bus.frame(Role::request, "05 03 00 00 00 04", t) & finding_poll_jitter) != 0;
  };
  for (int i = 0; i < 20; ++i) jitter_after(100);
  // 250 ms is off 100 ms until the sixteen hold as many 250s as 100s: eight polls.
  std::vector<int> flagged;
  for (int i = 0; i < 40; ++i)
    if (jitter_after(250)) flagged.push_back(i);
  EXPECT_EQ(flagged, (std::vector<int>{0, 1, 2, 3, 4, 5, 6, 7}));
  // Back to 100 ms: off the new usual 250 ms until the window turns again.
  flagged.clear();
  for (int i = 0; i < 40; ++i)
    if (jitter_after(100)) flagged.push_back(i);
  EXPECT_EQ(flagged, (std::vector<int>{0, 1, 2, 3, 4, 5, 6, 7, 8}));
}

TEST(BusDiagnostics, PollJitterNeedsAClockThatCanSeeIt) {
  // A raw file's times are nominal: no jitter at all.
  History untimed(ClockQuality::none);
  for (int i = 0; i < 20; ++i)
    EXPECT_EQ(untimed.frame(Role::request, "05 03 00 00 00 04", i * (i % 2 ? 10 : 300)) &
                  finding_poll_jitter,
              0u);
  // A clock per read is late by up to an adapter's latency: 12 ms off a 20 ms cycle may be it.
  History per_read(ClockQuality::per_chunk);
  int64_t t = 0;
  for (int i = 0; i < 12; ++i, t += 20) per_read.frame(Role::request, "05 03 00 00 00 04", t);
  EXPECT_EQ(per_read.frame(Role::request, "05 03 00 00 00 04", t + 12) & finding_poll_jitter, 0u);
  // An adapter known to stamp within 5 ms (`--chunk-jitter 5`) shows it.
  History prompt_reads(ClockQuality::per_chunk, 5'000'000);
  for (t = 0; t < 240; t += 20) prompt_reads.frame(Role::request, "05 03 00 00 00 04", t);
  EXPECT_NE(prompt_reads.frame(Role::request, "05 03 00 00 00 04", t + 12) & finding_poll_jitter,
            0u);
}

// A simulated capture through the analyzer, each byte with its exact time.
void analyze_per_byte(const busgen::BusCapture& capture, RecordSink& out) {
  AnalyzerOptions analyzer_options;
  analyzer_options.mode = ModeChoice::rtu;
  analyzer_options.clock = ClockQuality::per_byte;
  Analyzer analyzer(analyzer_options, {{"bus", ChannelRole::bus}}, out);
  for (size_t i = 0; i < capture.bytes.size(); ++i)
    analyzer.push({0, capture.end_ns[i], {&capture.bytes[i], 1}});
  analyzer.finish();
}

// The simulator's bus through the analyzer and the stage, timed per byte.
Collector simulated(const busgen::BusOptions& options) {
  Collector out;
  BusDiagnostics stage(options.format, ClockQuality::per_byte, out);
  analyze_per_byte(busgen::simulate(options), stage);
  return out;
}

// Frames sent back to back crowd each other; a master that waits 5 ms between transactions
// does not. With a scan list of `polled_slaves`, the master polls them in turn.
Collector simulated(bool back_to_back, unsigned polled_slaves = 0, bool faults = false) {
  busgen::BusOptions options;
  options.transactions = 2000;
  options.back_to_back = back_to_back;
  options.polled_slaves = polled_slaves;
  // A silent slave is a fault to a scan list too: its master's time-out stalls the cycle.
  if (polled_slaves && !faults) options.no_response_rate = 0;
  if (faults) options.noise_rate = options.truncation_rate = options.retry_rate = 0.02;
  return simulated(options);
}

size_t count(const Collector& out, uint32_t finding) {
  size_t n = 0;
  for (const auto& r : out.records) n += (r.findings & finding) != 0;
  return n;
}

TEST(BusDiagnostics, CleanTrafficShowsNoneAndCrowdedTrafficShowsShortGaps) {
  const Collector clean = simulated(false);
  for (uint32_t finding :
       {finding_short_gap, finding_late_response, finding_exception_storm, finding_answers_again})
    EXPECT_EQ(count(clean, finding), 0u) << finding;
  EXPECT_EQ(count(clean, finding_gap_in_frame | finding_garbage_after_request), 0u);
  const Collector crowded = simulated(true);
  EXPECT_GT(count(crowded, finding_short_gap), 1000u);
}

TEST(BusDiagnostics, AScanListPollsWithoutJitterUntilFaultsStallIt) {
  const Collector steady = simulated(false, 4);
  EXPECT_EQ(count(steady, finding_poll_jitter), 0u);
  for (uint32_t finding :
       {finding_short_gap, finding_late_response, finding_exception_storm, finding_answers_again})
    EXPECT_EQ(count(steady, finding), 0u) << finding;
  // Silent slaves, junk, broken-off requests sent again and retries after the master's time-out
  // stretch the cycle.
  EXPECT_GT(count(simulated(false, 4, true), finding_poll_jitter), 5u);
}

// Senders that stall inside a frame: each pause the simulator made is found in its frame, and
// no other frame has one, glitches and fast turnarounds around them notwithstanding.
TEST(BusDiagnostics, APauseLongerThanT15InsideAFrameIsAGapInFrame) {
  busgen::BusOptions options;
  options.transactions = 2000;
  options.pause_rate = 0.05;
  options.glitch_rate = options.request_glitch_rate = 0.3;
  const busgen::BusCapture capture = busgen::simulate(options);
  std::set<uint64_t> paused;
  for (const auto& frame : capture.frames)
    if (frame.findings & finding_gap_in_frame) paused.insert(frame.offset);
  ASSERT_GT(paused.size(), 100u);
  std::set<uint64_t> found;
  for (const auto& r : simulated(options).frames())
    if (r.findings & finding_gap_in_frame) found.insert(r.offset);
  EXPECT_EQ(found, paused);
}

// A slave answering at another baud rate: its bytes are marked where its answer was awaited
// (noise also names the request). A glitch as a driver turns on is not.
TEST(BusDiagnostics, NoiseWhereAnAnswerWasAwaitedNamesTheRequest) {
  busgen::BusOptions options;
  options.transactions = 2000;
  options.garbled_rate = 0.05;
  options.glitch_rate = options.request_glitch_rate = 0.3;
  const busgen::BusCapture capture = busgen::simulate(options);
  ASSERT_GT(capture.garbled.size(), 50u);
  const Collector out = simulated(options);
  std::map<uint64_t, testing::Record> frames;
  for (const auto& f : out.frames()) frames[f.index] = f;
  std::set<uint64_t> marked;
  for (const auto& r : out.noise()) {
    if (!(r.findings & finding_garbage_after_request)) continue;
    marked.insert(r.offset);
    ASSERT_TRUE(r.request.has_value());
    ASSERT_TRUE(frames.count(*r.request));
    EXPECT_EQ(frames[*r.request].role, Role::request);
    EXPECT_LT(frames[*r.request].offset, r.offset);
  }
  // Junk as long as its second byte's function code allows (any length, for a code the length
  // rules do not know) is a frame with a bad check (docs/framing.md), marked the same.
  size_t as_frames = 0;
  for (const auto& f : out.frames()) {
    if (!(f.findings & finding_garbage_after_request)) continue;
    EXPECT_FALSE(f.check_ok);
    marked.insert(f.offset);
    ++as_frames;
  }
  EXPECT_GT(as_frames, 0u);
  EXPECT_EQ(marked, std::set<uint64_t>(capture.garbled.begin(), capture.garbled.end()));
}

// A bus of NTA5000 drives, read through their model on a clock per byte: drives that keep the
// manual's 10 ms show no early-response; slaves that answer within a few characters show it
// on every answer.
TEST(BusDiagnostics, AnswersSoonerThanTheModelsTurnaroundAreEarly) {
  tools::ModelCatalog catalog;
  catalog.load_builtin();
  auto early_answers = [&](int64_t min_turnaround_ns) {
    busgen::BusOptions options;
    options.transactions = 1000;
    options.polled_slaves = 4;
    options.min_turnaround_ns = min_turnaround_ns;
    struct Counter final : RecordSink {
      size_t responses = 0, early = 0;
      void on_frame(const Frame& f) override {
        if (f.role != Role::response || !f.check_ok) return;
        ++responses;
        if (f.meaning)
          for (const RuleFinding& finding : f.meaning->findings)
            early += finding.kind == RuleKind::early_response;
      }
      void on_noise(const Noise&) override {}
      void on_timeout(const Timeout&) override {}
    } counter;
    ModelInterpreter models(catalog.all(), catalog.choose({"nta5000"}), ClockQuality::per_byte,
                            counter);
    analyze_per_byte(busgen::simulate(options), models);
    EXPECT_GT(counter.responses, 900u);
    return std::pair{counter.early, counter.responses};
  };
  EXPECT_EQ(early_answers(10'000'000).first, 0u);
  const auto [early, responses] = early_answers(0);
  EXPECT_EQ(early, responses);
}

}  // namespace
}  // namespace modtap
