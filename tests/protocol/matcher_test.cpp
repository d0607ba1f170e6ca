#include "decoder/protocol/matcher.hpp"

#include <gtest/gtest.h>

#include "tests/support/collector.hpp"

namespace modtap {
namespace {

using testing::analyze_untimed;
using testing::Collector;
using testing::hex;

std::vector<uint8_t> text_bytes(std::string_view text) {
  return {text.begin(), text.end()};
}

std::vector<uint8_t> join(std::initializer_list<const char*> frames) {
  std::vector<uint8_t> out;
  for (const char* f : frames) {
    auto b = hex(f);
    out.insert(out.end(), b.begin(), b.end());
  }
  return out;
}

// Reads stamped with their time (a clock per read, 30 ms late at most), each `at_ms` after the
// capture's start, or 10 ms after the one before.
struct Read {
  std::vector<uint8_t> bytes;
  int64_t at_ms = -1;
};
// The same with `options` (a clock per read, RTU unless they say otherwise).
Collector analyze_reads(const std::vector<Read>& reads, AnalyzerOptions options) {
  Collector out;
  options.clock = ClockQuality::per_chunk;
  Analyzer analyzer(options, {{"test", ChannelRole::bus}}, out);
  constexpr int64_t start = 1'000'000'000;
  int64_t t = start;
  for (const auto& read : reads) {
    t = read.at_ms < 0 ? t + 10'000'000 : start + read.at_ms * 1'000'000;
    analyzer.push({0, t, {read.bytes.data(), read.bytes.size()}});
  }
  analyzer.finish();
  return out;
}
Collector analyze_reads(const std::vector<Read>& reads, ModeChoice mode = ModeChoice::rtu) {
  AnalyzerOptions options;
  options.mode = mode;
  return analyze_reads(reads, options);
}

// A request and its answer in one read (a sniffer's packet, a hex log's block) are placed back
// to back: the turnaround between them is unknown, not zero. In reads of their own it is timed.
TEST(Matcher, AnAnswerInTheRequestsReadHasNoLatency) {
  const auto request = hex("01 03 00 00 00 01 84 0a"), answer = hex("01 03 02 00 07 f9 86");
  const auto ascii_request = text_bytes(":010300000001FB\r\n");
  const auto ascii_answer = text_bytes(":0103020007F3\r\n");
  struct Case {
    ModeChoice mode;
    std::vector<uint8_t> request, answer;
  };
  for (const Case& c : {Case{ModeChoice::rtu, request, answer},
                        Case{ModeChoice::ascii, ascii_request, ascii_answer}}) {
    std::vector<uint8_t> both = c.request;
    both.insert(both.end(), c.answer.begin(), c.answer.end());
    const auto one_read = analyze_reads({{both}}, c.mode).frames();
    ASSERT_EQ(one_read.size(), 2u);
    EXPECT_EQ(one_read[1].request, one_read[0].index);
    EXPECT_FALSE(one_read[1].latency_ns.has_value()) << *one_read[1].latency_ns;
    const auto two_reads = analyze_reads({{c.request}, {c.answer}}, c.mode).frames();
    ASSERT_EQ(two_reads.size(), 2u);
    EXPECT_TRUE(two_reads[1].latency_ns.has_value());
  }
}

TEST(Matcher, TellsAnEchoRequestFromItsResponseByOrder) {
  // FC06 request and response are the same bytes: the second is the answer.
  const auto out = analyze_untimed(join({"01 06 25 02 17 70 2d 12", "01 06 25 02 17 70 2d 12"}));
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[0].role, Role::request);
  EXPECT_EQ(frames[1].role, Role::response);
  EXPECT_EQ(frames[1].request, frames[0].index);
}

// Where the awaited answer belongs, a frame with a bad check is that answer even when the
// damage hit its address (D5H for 03H), and bytes past reading are the answer garbled: the
// slave answered, so no time-out, and both count for the slave that was asked. Both are still
// garbage after the request: nothing in them reads as its answer. Without a clock nothing
// tells them from junk after the master gave up.
TEST(Matcher, ADamagedAnswerIsTheAwaitedSlavesAnswerNotATimeout) {
  const auto request = hex("03 03 00 00 00 01 85 e8"), next = hex("04 03 00 00 00 01 84 5f");
  const auto bad_address = analyze_reads({{request}, {hex("d5 03 02 00 07 80 46")}, {next}});
  EXPECT_EQ(bad_address.timeouts().size(), 1u);  // the last request, at the capture's end
  const auto frames = bad_address.frames();
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(frames[1].role, Role::response);
  EXPECT_FALSE(frames[1].check_ok);
  EXPECT_EQ(frames[1].request, frames[0].index);
  EXPECT_EQ(frames[1].device, 3);
  EXPECT_NE(frames[1].findings & finding_garbage_after_request, 0u);

  const auto garbled = analyze_reads({{request}, {hex("9f 41")}, {next}});
  EXPECT_EQ(garbled.timeouts().size(), 1u);
  ASSERT_EQ(garbled.noise().size(), 1u);
  EXPECT_TRUE(garbled.noise()[0].damaged_answer);
  EXPECT_EQ(garbled.noise()[0].device, 3);
  EXPECT_EQ(garbled.noise()[0].request, garbled.frames()[0].index);

  std::vector<uint8_t> untimed = request;
  for (const auto& part : {hex("9f 41"), next})
    untimed.insert(untimed.end(), part.begin(), part.end());
  EXPECT_EQ(analyze_untimed(untimed).timeouts().size(), 2u);
}

TEST(Matcher, ReportsATimeoutWhenTheMasterMovesOn) {
  const auto out = analyze_untimed(join({"01 03 00 00 00 0a c5 cd", "01 03 00 00 00 0a c5 cd"}));
  const auto timeouts = out.timeouts();
  ASSERT_EQ(timeouts.size(), 2u);
  EXPECT_EQ(timeouts[0].request, 1u);
  EXPECT_EQ(timeouts[0].timeout_reason, TimeoutReason::next_request);
  EXPECT_EQ(timeouts[1].timeout_reason, TimeoutReason::end_of_capture);
}

// A request sooner after another than any master waits for an answer (50 ms) is a second
// master's: the first request's answer is still due, and comes after the second's exchange,
// paired and on time. Had the slave asked first not answered, its request times out once it
// is asked again; a request as late as a master waits moves on as a master does.
TEST(Matcher, ARequestCuttingInSoonerThanAMasterWaitsLeavesTheFirstAnswerDue) {
  const auto first = hex("01 03 00 00 00 01 84 0a"), answer = hex("01 03 02 00 07 f9 86");
  const auto cutting = hex("c9 03 01 00 00 01 95 be"), its_answer = hex("c9 03 02 00 2a d8 4b");
  const auto out =
      analyze_reads({{first, 0}, {cutting, 8}, {its_answer, 16}, {answer, 24}, {first, 300}});
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 5u);
  EXPECT_EQ(frames[2].request, frames[1].index);
  EXPECT_EQ(frames[3].role, Role::response);
  EXPECT_EQ(frames[3].request, frames[0].index);
  EXPECT_FALSE(frames[3].findings & finding_late_response);
  // Its latency holds the other exchange: marked so (the statistics leave it out).
  EXPECT_TRUE(frames[3].findings & finding_after_other_master);
  EXPECT_FALSE(frames[2].findings & finding_after_other_master);
  ASSERT_EQ(out.timeouts().size(), 1u);  // the last request's, at the end of the capture
  EXPECT_EQ(out.timeouts()[0].request, frames[4].index);

  const auto unanswered =
      analyze_reads({{first, 0}, {cutting, 8}, {its_answer, 16}, {first, 300}, {answer, 310}});
  ASSERT_EQ(unanswered.timeouts().size(), 1u);
  EXPECT_EQ(unanswered.timeouts()[0].request, unanswered.frames()[0].index);
  EXPECT_EQ(unanswered.timeouts()[0].timeout_reason, TimeoutReason::next_request);
  EXPECT_TRUE(unanswered.frames()[3].findings & finding_retry);

  const auto moved_on = analyze_reads({{first, 0}, {cutting, 120}, {its_answer, 128}});
  ASSERT_EQ(moved_on.timeouts().size(), 1u);
  EXPECT_EQ(moved_on.timeouts()[0].request, moved_on.frames()[0].index);
}

// Told the master's time-out, a copy of the request past it (less what the clock may take off)
// may be the master's retry however slowly its slave answers: a slave seen to answer in 190 ms
// of a 200 ms time-out does not make a FC07 retry 205 ms on the answer cut short.
TEST(Matcher, ToldTheTimeOutACopyPastItMayBeTheRetryWhateverTheSlavesTurnaround) {
  AnalyzerOptions options;
  options.timeout_ns = 200'000'000;
  options.timeout_told = true;
  const auto read = hex("05 03 00 00 00 01 85 8e"), value = hex("05 03 02 00 09 89 82");
  const auto status = hex("05 07 43 22"), its_answer = hex("05 07 18 63 fb");
  std::vector<Read> reads;
  for (const int64_t cycle : {0, 1000, 2000}) {
    reads.push_back({read, cycle});
    reads.push_back({value, cycle + 190});
  }
  reads.insert(reads.end(), {{status, 3000}, {status, 3205}, {its_answer, 3400}});
  const Collector out = analyze_reads(reads, options);
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 9u);
  EXPECT_EQ(frames[7].role, Role::request);
  EXPECT_TRUE(frames[7].check_ok);
  EXPECT_TRUE(frames[7].findings & finding_retry);
  EXPECT_EQ(frames[8].request, frames[7].index);
  ASSERT_EQ(out.timeouts().size(), 1u);
  EXPECT_EQ(out.timeouts()[0].request, frames[6].index);
}

TEST(Matcher, MarksBroadcastsAndExpectsNoResponse) {
  const auto out = analyze_untimed(join({"00 06 00 01 00 03 99 da"}));
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_TRUE(frames[0].findings & finding_broadcast);
  EXPECT_TRUE(out.timeouts().empty());
}

TEST(Matcher, FlagsAResponseWithNoRequest) {
  const auto out = analyze_untimed(join({"01 03 02 07 d0 bb e8"}));
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].role, Role::response);
  EXPECT_TRUE(frames[0].findings & finding_unsolicited);
  EXPECT_FALSE(frames[0].request.has_value());
}

TEST(Matcher, FlagsAByteCountThatDoesNotFitTheRequest) {
  // Asked for 10 registers, got 1.
  const auto out = analyze_untimed(join({"01 03 00 00 00 0a c5 cd", "01 03 02 07 d0 bb e8"}));
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[1].request, frames[0].index);
  EXPECT_TRUE(frames[1].findings & finding_length_mismatch);
}

TEST(Matcher, PairsAnExceptionWithItsRequest) {
  const auto out = analyze_untimed(join({"01 03 25 23 00 01 7e cc", "01 83 02 c0 f1"}));
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[1].role, Role::response);
  EXPECT_EQ(frames[1].request, frames[0].index);
}

TEST(Matcher, TakesAnExceptionForAResponseEvenWithABadCheckFromAnotherSlave) {
  // N3's RTU error example: 02 83 52 printed with the CRC of 01 83 52, after a request to 01.
  const auto out = analyze_untimed(join({"01 03 25 23 00 01 7e cc", "02 83 52 c0 cd"}));
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_FALSE(frames[1].check_ok);
  EXPECT_EQ(frames[1].role, Role::response);
  EXPECT_EQ(frames[1].expected_check, 0xCD30);  // wire order 30 CD, as 000 prints it
}

TEST(Matcher, CountsTheSameRequestAfterNoAnswerAsARetry) {
  const auto out = analyze_untimed(join({"01 03 00 00 00 0a c5 cd", "01 03 00 00 00 0a c5 cd",
                                         "01 03 00 00 00 0a c5 cd", "01 03 00 01 00 0a 94 0d"}));
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 4u);
  EXPECT_FALSE(frames[0].findings & finding_retry);
  EXPECT_TRUE(frames[1].findings & finding_retry);
  EXPECT_TRUE(frames[2].findings & finding_retry);
  EXPECT_FALSE(frames[3].findings & finding_retry);  // another request: the next poll
}

TEST(Matcher, AnAnsweredRequestAskedAgainIsNoRetry) {
  const auto out = analyze_untimed(
      join({"01 03 00 00 00 01 84 0a", "01 03 02 00 05 78 47", "01 03 00 00 00 01 84 0a"}));
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(frames[1].request, frames[0].index);
  EXPECT_FALSE(frames[2].findings & finding_retry);
}

// Frames at given times through a timed matcher on one bus channel; returns them with their
// verdicts, and the time-outs in `timeouts`.
struct Timed {
  const char* bytes;
  int64_t t_ms;
};
std::vector<Frame> match_timed(std::initializer_list<Timed> frames, std::vector<Timeout>& timeouts,
                               std::vector<std::vector<uint8_t>>& keep, int64_t clock_lag_ns = 0,
                               std::optional<int64_t> told_timeout_ns = std::nullopt) {
  MatcherOptions options;
  options.clock_lag_ns = clock_lag_ns;
  if (told_timeout_ns) options.timeout_ns = *told_timeout_ns;
  options.timeout_told = told_timeout_ns.has_value();
  Matcher matcher(options, [&](const Timeout& t) { timeouts.push_back(t); });
  std::vector<Frame> out;
  uint64_t index = 0;
  for (const Timed& f : frames) {
    keep.push_back(hex(f.bytes));
    Frame frame;
    frame.index = ++index;
    frame.adu = frame.raw = keep.back();
    frame.check_ok = true;
    frame.fit = {true, true};  // the echo codes read both ways
    frame.t_ns = f.t_ms * 1'000'000;
    frame.end_ns = frame.t_ns + static_cast<int64_t>(frame.adu.size()) * 573'000;  // 19200 8E1
    matcher.on_frame(frame, ChannelRole::bus);
    out.push_back(frame);
  }
  matcher.finish(out.back().end_ns);
  return out;
}

// The framer learns an answer's length from its request where every good answer is the
// request again: Return Query Data's header does not tell its length, whatever the query's.
TEST(Matcher, TellsTheFramerTheLengthOfAnAnswerThatIsTheRequestAgain) {
  struct Case {
    const char* request;
    bool echoed;
  };
  for (const Case& c : {
           Case{"11 08 00 00 a5 37 00 00", true},  // Return Query Data
           Case{"11 08 00 00 01 02 03 04 05 06 07 08 09 0a 0b 0c 00 00", true},  // past 8 bytes
           Case{"11 08 00 0b 00 00 00 00", false},  // a counter: its answer carries the count
           Case{"11 06 00 01 00 03 00 00", true},   // a write's echo, whose length is fixed
           Case{"11 03 00 6b 00 03 00 00", false},
       }) {
    Matcher matcher(MatcherOptions{}, [](const Timeout&) {});
    const auto bytes = hex(c.request);
    Frame frame;
    frame.adu = frame.raw = bytes;
    frame.check_ok = true;
    frame.fit = {true, false};
    matcher.on_frame(frame, ChannelRole::bus);
    EXPECT_EQ(matcher.expectation().echo_size, c.echoed ? bytes.size() : 0u) << c.request;
  }
}

// A slave that answers in 41 ms on a clock 30 ms late at most: a copy of an echo request
// 106 ms after it may be the answer or the master's retry, as far as its turnaround tells. The
// master's retry of a read, which no echo can fake, showed it retries 107 ms after a request:
// the copy is that retry, and the echo after it its answer.
TEST(Matcher, TheMastersRetryIntervalFromReadsTellsAnEchoFromARetry) {
  const auto read = hex("01 03 00 00 00 01 84 0a"), write = hex("01 06 00 01 00 03 98 0b");
  const auto frames = analyze_reads({{read, 0},
                                     {hex("01 03 02 00 05 78 47"), 45},
                                     {read, 300},
                                     {read, 412},  // its retry
                                     {hex("01 03 02 00 05 78 47"), 420},
                                     {write, 600},
                                     {write, 711},  // its retry, or its echo?
                                     {write, 720}})
                          .frames();
  ASSERT_EQ(frames.size(), 8u);
  EXPECT_TRUE(frames[3].findings & finding_retry);
  EXPECT_EQ(frames[6].role, Role::request);
  EXPECT_TRUE(frames[6].findings & finding_retry);
  EXPECT_FALSE(frames[6].findings & finding_ambiguous_echo);
  EXPECT_EQ(frames[7].role, Role::response);
  EXPECT_EQ(frames[7].request, frames[6].index);
}

// Slave 5 answers in 150 ms, so a slave not heard yet might take as long. But the master has
// shown it sends a read again 112 ms after it: a copy of slave 2's write that late is as late
// as its retries come, so it may be one, and the echo right after it says it was.
TEST(Matcher, NoCopyAsLateAsTheMastersRetriesIsTooSoonForOneWhateverASlowSlaveTaught) {
  const auto read = hex("01 03 00 00 00 01 84 0a"), answer = hex("01 03 02 00 05 78 47");
  const auto write = hex("02 06 00 01 00 03 98 38");
  const auto frames = analyze_reads({{hex("05 03 00 00 00 01 85 8e"), 0},
                                     {hex("05 03 02 00 05 89 87"), 150},
                                     {read, 300},
                                     {answer, 310},
                                     {read, 500},
                                     {read, 612},  // its retry
                                     {answer, 620},
                                     {write, 800},
                                     {write, 912},  // as late as a retry
                                     {write, 920}})
                          .frames();
  ASSERT_EQ(frames.size(), 10u);
  EXPECT_TRUE(frames[5].findings & finding_retry);
  EXPECT_EQ(frames[8].role, Role::request);
  EXPECT_TRUE(frames[8].findings & finding_retry);
  EXPECT_EQ(frames[9].role, Role::response);
  EXPECT_EQ(frames[9].request, frames[8].index);
}

// Slaves 1, 3 and 4 answer in 10 ms, slave 5 in 150 ms. Slave 2, not heard yet, is taken to
// answer as the middle of them does, not as the slowest: a copy of its write 112 ms on is past
// its answer's time, the master's retry, and the echo right after it answers that.
TEST(Matcher, ASlaveNotHeardYetIsTakenToAnswerAsTheMiddleOfTheBusNotTheSlowest) {
  const auto write = hex("02 06 00 01 00 03 98 38");
  const auto frames = analyze_reads({{hex("05 03 00 00 00 01 85 8e"), 0},
                                     {hex("05 03 02 00 05 89 87"), 150},
                                     {hex("01 03 00 00 00 01 84 0a"), 300},
                                     {hex("01 03 02 00 05 78 47"), 310},
                                     {hex("03 03 00 00 00 01 85 e8"), 400},
                                     {hex("03 03 02 00 05 01 87"), 410},
                                     {hex("04 03 00 00 00 01 84 5f"), 500},
                                     {hex("04 03 02 00 05 b4 47"), 510},
                                     {write, 800},
                                     {write, 912},
                                     {write, 920}})
                          .frames();
  ASSERT_EQ(frames.size(), 11u);
  EXPECT_EQ(frames[9].role, Role::request);
  EXPECT_TRUE(frames[9].findings & finding_retry);
  EXPECT_EQ(frames[10].role, Role::response);
  EXPECT_EQ(frames[10].request, frames[9].index);
}

// Slave 5 answers FC07 in 205 ms; the master has shown it sends a read again 112 ms after it.
// A copy of FC07's 4-byte request 120 ms on is as late as the master's retries: the framer too
// reads it as the master's request, whole, not as slave 5's 5-byte answer cut short.
TEST(Matcher, TheFramerReadsACopyAsLateAsTheMastersRetriesAsItsRequest) {
  const auto status = hex("05 07 43 22"), status_answer = hex("05 07 00 63 f1");
  const auto read = hex("01 03 00 00 00 01 84 0a"), answer = hex("01 03 02 00 05 78 47");
  const auto frames = analyze_reads({{status, 0},
                                     {status_answer, 205},
                                     {read, 500},
                                     {answer, 510},
                                     {read, 700},
                                     {read, 812},  // its retry
                                     {answer, 820},
                                     {status, 1000},
                                     {status, 1120},  // as late as a retry
                                     {status_answer, 1325},
                                     {read, 1340}})
                          .frames();
  ASSERT_EQ(frames.size(), 11u);
  EXPECT_TRUE(frames[8].check_ok);
  EXPECT_EQ(frames[8].role, Role::request);
  EXPECT_TRUE(frames[8].findings & finding_retry);
  EXPECT_EQ(frames[9].role, Role::response);
  EXPECT_EQ(frames[9].request, frames[8].index);
}

TEST(Matcher, AnEchoCopyLongAfterTheSlavesTurnaroundIsARetry) {
  // Slave 1 answers a read in 5 ms; then a write goes unanswered and the master, after its
  // 100 ms time-out, sends it again, byte for byte what the echo would have been.
  std::vector<Timeout> timeouts;
  std::vector<std::vector<uint8_t>> keep;
  const auto frames = match_timed({{"01 03 00 00 00 01 84 0a", 0},
                                   {"01 03 02 00 05 78 47", 10},
                                   {"01 06 00 01 00 03 98 0b", 100},
                                   {"01 06 00 01 00 03 98 0b", 205},
                                   {"01 06 00 01 00 03 98 0b", 215}},
                                  timeouts, keep);
  EXPECT_EQ(frames[1].role, Role::response);
  EXPECT_EQ(frames[2].role, Role::request);
  EXPECT_EQ(frames[3].role, Role::request);  // the retry, not the slave coming alive
  EXPECT_TRUE(frames[3].findings & finding_retry);
  ASSERT_EQ(timeouts.size(), 1u);
  EXPECT_EQ(timeouts[0].request, frames[2].index);
  EXPECT_EQ(frames[4].role, Role::response);  // 5 ms after the retry: the answer
  EXPECT_EQ(frames[4].request, frames[3].index);
  EXPECT_FALSE(frames[4].findings & finding_ambiguous_echo);
}

TEST(Matcher, AnEchoCopyOnAClockThatStampsReadsLateMayStillBeTheAnswer) {
  // Slave 1 once answered within half a millisecond. A read stamped when the frame after it
  // ended (a USB adapter's latency timer) puts the echo of a write 23 ms on: with reads that
  // may be 30 ms late that is the answer, marked as possibly the retry; on a clock that times
  // each byte, a retry. Past 51 ms (twice the turnaround, 20 ms, 30 ms) it is a retry either way.
  std::vector<Timeout> timeouts;
  std::vector<std::vector<uint8_t>> keep;
  const auto bus = [&](int64_t copy_ms, int64_t clock_lag_ns) {
    return match_timed({{"01 03 00 00 00 01 84 0a", 0},
                        {"01 03 02 00 05 78 47", 5},
                        {"01 06 00 01 00 03 98 0b", 100},
                        {"01 06 00 01 00 03 98 0b", copy_ms}},
                       timeouts, keep, clock_lag_ns);
  };
  const auto per_read = bus(128, 30'000'000);
  EXPECT_EQ(per_read[3].role, Role::response);
  EXPECT_EQ(per_read[3].request, per_read[2].index);
  EXPECT_TRUE(per_read[3].findings & finding_ambiguous_echo);
  const auto per_byte = bus(128, 0);
  EXPECT_EQ(per_byte[3].role, Role::request);
  EXPECT_TRUE(per_byte[3].findings & finding_retry);
  const auto late = bus(160, 30'000'000);
  EXPECT_EQ(late[3].role, Role::request);
  EXPECT_TRUE(late[3].findings & finding_retry);
}

TEST(Matcher, AnotherWriteLongAfterAnAnswerWasDueIsTheMastersNextRequest) {
  // Slave 1 answers in 5 ms. A write of 3 goes unanswered; 220 ms on, the master writes 4:
  // the same slave and function, read both ways, but no answer comes that late.
  std::vector<Timeout> timeouts;
  std::vector<std::vector<uint8_t>> keep;
  const auto frames = match_timed({{"01 03 00 00 00 01 84 0a", 0},
                                   {"01 03 02 00 05 78 47", 10},
                                   {"01 06 00 01 00 03 98 0b", 100},
                                   {"01 06 00 01 00 04 d9 c9", 320},
                                   {"01 06 00 01 00 04 d9 c9", 330}},
                                  timeouts, keep);
  EXPECT_EQ(frames[3].role, Role::request);
  ASSERT_EQ(timeouts.size(), 1u);
  EXPECT_EQ(timeouts[0].request, frames[2].index);
  EXPECT_EQ(frames[4].role, Role::response);
  EXPECT_EQ(frames[4].request, frames[3].index);
  // The same with FC21, whose answer echoes its request whole: other file records 220 ms on
  // are the master's next write.
  const auto files = match_timed({{"01 03 00 00 00 01 84 0a", 0},
                                  {"01 03 02 00 05 78 47", 10},
                                  {"01 15 09 06 00 04 00 01 00 01 12 34 03 f5", 100},
                                  {"01 15 09 06 00 04 00 01 00 01 56 79 f0 c0", 320},
                                  {"01 15 09 06 00 04 00 01 00 01 56 79 f0 c0", 330}},
                                 timeouts, keep);
  EXPECT_EQ(files[3].role, Role::request);
  EXPECT_EQ(files[4].role, Role::response);
  EXPECT_EQ(files[4].request, files[3].index);
  // The same with FC20, whose request and answer have one layout: a read of other records
  // 220 ms on is the master's next request, the records it asked for its answer.
  const auto reads = match_timed({{"01 03 00 00 00 01 84 0a", 0},
                                  {"01 03 02 00 05 78 47", 10},
                                  {"01 14 07 06 00 04 00 01 00 02 d8 e5", 100},
                                  {"01 14 07 06 00 04 00 07 00 02 38 e4", 320},
                                  {"01 14 06 05 06 12 34 56 78 92 fe", 330}},
                                 timeouts, keep);
  EXPECT_EQ(reads[3].role, Role::request);
  EXPECT_EQ(reads[4].role, Role::response);
  EXPECT_EQ(reads[4].request, reads[3].index);
  // With no answer seen yet, past the shortest time-out masters use (50 ms): the bus's first
  // write, unanswered, then the next.
  const auto first = match_timed({{"01 06 00 01 00 03 98 0b", 0},
                                  {"01 06 00 01 00 04 d9 c9", 220},
                                  {"01 06 00 01 00 04 d9 c9", 230}},
                                 timeouts, keep);
  EXPECT_EQ(first[1].role, Role::request);
  EXPECT_EQ(first[2].role, Role::response);
  EXPECT_EQ(first[2].request, first[1].index);
  // Within the slave's time, a reply that does not echo is still its answer, unfit.
  const auto soon = match_timed({{"01 03 00 00 00 01 84 0a", 0},
                                 {"01 03 02 00 05 78 47", 10},
                                 {"01 06 00 01 00 03 98 0b", 100},
                                 {"01 06 00 01 00 04 d9 c9", 110}},
                                timeouts, keep);
  EXPECT_EQ(soon[3].role, Role::response);
  EXPECT_EQ(soon[3].request, soon[2].index);
  // A late answer that fits its request (a FC08 counter, as long as its request) stays the
  // answer, however late.
  const auto counter = match_timed({{"01 03 00 00 00 01 84 0a", 0},
                                    {"01 03 02 00 05 78 47", 10},
                                    {"01 08 00 0b 00 00 91 c9", 100},
                                    {"01 08 00 0b 00 05 51 ca", 320}},
                                   timeouts, keep);
  EXPECT_EQ(counter[3].role, Role::response);
  EXPECT_EQ(counter[3].request, counter[2].index);
}

// A master told to wait 200 ms (--timeout) sends nothing again sooner: a copy of its write
// 180 ms on, long after slave 1's 5 ms turnaround, is the slave's echo, slow but in time. Not
// told, that copy is the master's retry after a time-out of its own.
TEST(Matcher, ACopySoonerThanTheMastersToldTimeOutIsTheAnswer) {
  const auto bus = [](std::optional<int64_t> told_timeout_ns, std::vector<Timeout>& timeouts) {
    std::vector<std::vector<uint8_t>> keep;
    return match_timed({{"01 03 00 00 00 01 84 0a", 0},
                        {"01 03 02 00 05 78 47", 10},
                        {"01 06 00 01 00 03 98 0b", 100},
                        {"01 06 00 01 00 03 98 0b", 285}},
                       timeouts, keep, 0, told_timeout_ns);
  };
  std::vector<Timeout> told_timeouts;
  const auto told = bus(200'000'000, told_timeouts);
  EXPECT_EQ(told[3].role, Role::response);
  EXPECT_EQ(told[3].request, told[2].index);
  EXPECT_FALSE(told[3].findings & (finding_retry | finding_ambiguous_echo));
  EXPECT_TRUE(told_timeouts.empty());
  std::vector<Timeout> untold_timeouts;
  const auto untold = bus(std::nullopt, untold_timeouts);
  EXPECT_EQ(untold[3].role, Role::request);
  EXPECT_TRUE(untold[3].findings & finding_retry);
}

// On a clock per read (16 ms late at most) an echo 202 ms after its write, past the master's
// told 200 ms less what the clock may take off, may be the retry or the answer, in time or
// late: the master's next move tells. Its request to slave 2 10 ms on, sooner than it would
// wait for a retry's answer, makes the copy the answer to the write, never a request.
TEST(Matcher, ACopyNearTheMastersToldTimeOutIsTheAnswerWhereTheMasterMovesOnAtOnce) {
  const auto write = hex("01 06 00 01 00 03 98 0b");
  const auto moves_on = hex("02 03 00 00 00 01 84 39");
  for (const bool timer_lag : {false, true}) {
    AnalyzerOptions options;
    options.chunk_jitter_ns = timer_lag ? 16'000'000 : 0;
    options.timeout_ns = 200'000'000;
    options.timeout_told = true;
    const Collector out = analyze_reads({{hex("01 03 00 00 00 01 84 0a"), 1000},
                                         {hex("01 03 02 00 05 78 47"), 1010},
                                         {write, 1100},
                                         {write, 1302},
                                         {moves_on, 1312}},
                                        options);
    const auto frames = out.frames();
    ASSERT_EQ(frames.size(), 5u);
    EXPECT_EQ(frames[3].role, Role::response) << timer_lag;
    EXPECT_EQ(frames[3].request, frames[2].index) << timer_lag;
    EXPECT_EQ(frames[4].role, Role::request);
    EXPECT_FALSE(frames[4].findings & finding_retry);
  }
}

// Slave 1's answer comes whole with bits flipped, its address among them (a trunk that reflects
// long frames): the answer, damaged, which ends the wait. The master's next request, damaged
// too, 20 ms on, is a request, not a second answer to the first.
TEST(Matcher, ADamagedAnswerWholeByItsLengthEndsTheWait) {
  AnalyzerOptions options;
  options.chunk_jitter_ns = 0;
  const Collector out = analyze_reads({{hex("01 03 00 00 00 02 c4 0b"), 1000},
                                       {hex("03 03 04 00 01 00 02 00 00"), 1010},
                                       {hex("02 03 00 00 00 01 00 00"), 1030}},
                                      options);
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(frames[1].role, Role::response);
  EXPECT_EQ(frames[1].request, frames[0].index);
  EXPECT_FALSE(frames[1].check_ok);
  EXPECT_EQ(frames[2].role, Role::request);
  EXPECT_FALSE(frames[2].check_ok);
  EXPECT_TRUE(out.timeouts().empty());
}

// Slave 1 answers 204 ms after each request, past the master's time-out (not told): its
// turnaround, learned so, makes a copy of its write 234 ms on read as the echo. The same bytes
// again 204 ms after that, and the master's request to slave 2 at once, show otherwise: the
// second copy was the answer, the first the master's retry. Where the master waits on after the
// second copy, nothing tells, and the copies stay as the slave's turnaround reads them.
TEST(Matcher, TheSameCopyAgainAndTheMasterMovingOnShowTheFirstWasTheRetry) {
  const auto write = hex("01 06 00 01 00 03 98 0b");
  const auto read = hex("01 03 00 00 00 01 84 0a");
  const auto other = hex("02 03 00 00 00 01 84 39");
  for (const bool moves_on : {true, false}) {
    const Collector out = analyze_reads({{read, 1000},
                                         {hex("01 03 02 00 05 78 47"), 1204},
                                         {write, 1300},
                                         {write, 1534},
                                         {write, 1738},
                                         {other, moves_on ? 1742 : 2400}},
                                        AnalyzerOptions{});
    const auto frames = out.frames();
    ASSERT_EQ(frames.size(), 6u);
    if (moves_on) {
      EXPECT_EQ(frames[3].role, Role::request);
      EXPECT_TRUE(frames[3].findings & finding_retry);
      EXPECT_EQ(frames[4].role, Role::response);
      EXPECT_EQ(frames[4].request, frames[3].index);
      const auto timeouts = out.timeouts();
      ASSERT_FALSE(timeouts.empty());
      EXPECT_EQ(timeouts.front().request, frames[2].index);
    } else {
      EXPECT_EQ(frames[3].role, Role::response);
      EXPECT_EQ(frames[3].request, frames[2].index);
      EXPECT_EQ(frames[4].role, Role::request);
    }
    EXPECT_EQ(frames[5].role, Role::request);
  }
}

// A late answer that reads as a request too may be the master's next one: it teaches no
// turnaround. Slave 1 answers in 5 ms, slave 2's FC08 counter comes 211 ms on; slave 3's
// write, copied 120 ms on, is then past every answer's time: the master's retry.
TEST(Matcher, ALateAnswerThatReadsAsARequestTooTeachesNoTurnaround) {
  std::vector<Timeout> timeouts;
  std::vector<std::vector<uint8_t>> keep;
  const auto frames = match_timed({{"01 03 00 00 00 01 84 0a", 0},
                                   {"01 03 02 00 05 78 47", 10},
                                   {"02 08 00 0b 00 00 91 fa", 100},
                                   {"02 08 00 0b 00 05 51 f9", 315},
                                   {"03 06 00 01 00 03 99 e9", 400},
                                   {"03 06 00 01 00 03 99 e9", 520}},
                                  timeouts, keep);
  EXPECT_EQ(frames[3].request, frames[2].index);
  EXPECT_EQ(frames[5].role, Role::request);
  EXPECT_TRUE(frames[5].findings & finding_retry);
}

// FC20's answer carries records, never its request again: a copy of the request, however soon,
// is the master's retry, and the answer after it answers that.
TEST(Matcher, ACopyOfARequestNoAnswerRepeatsIsARetry) {
  std::vector<Timeout> timeouts;
  std::vector<std::vector<uint8_t>> keep;
  const auto frames = match_timed({{"01 14 07 06 00 04 00 01 00 02 d8 e5", 0},
                                   {"01 14 07 06 00 04 00 01 00 02 d8 e5", 10},
                                   {"01 14 06 05 06 0d fe 00 20 8b 4e", 20}},
                                  timeouts, keep);
  EXPECT_EQ(frames[1].role, Role::request);
  EXPECT_TRUE(frames[1].findings & finding_retry);
  EXPECT_FALSE(frames[1].findings & finding_ambiguous_echo);
  EXPECT_EQ(frames[2].role, Role::response);
  EXPECT_EQ(frames[2].request, frames[1].index);
  EXPECT_EQ(frames[2].findings & finding_length_mismatch, 0u);
}

TEST(Matcher, AnEchoCopyWithNothingToJudgeByIsAResponseMarkedAmbiguous) {
  std::vector<Timeout> timeouts;
  std::vector<std::vector<uint8_t>> keep;
  // No answer learned yet: a copy 5 ms on is the response, a copy 120 ms on may be a retry.
  const auto soon = match_timed({{"01 06 00 01 00 03 98 0b", 0}, {"01 06 00 01 00 03 98 0b", 10}},
                                timeouts, keep);
  EXPECT_EQ(soon[1].role, Role::response);
  EXPECT_FALSE(soon[1].findings & finding_ambiguous_echo);
  const auto late = match_timed({{"01 06 00 01 00 03 98 0b", 0}, {"01 06 00 01 00 03 98 0b", 125}},
                                timeouts, keep);
  EXPECT_EQ(late[1].role, Role::response);
  EXPECT_TRUE(late[1].findings & finding_ambiguous_echo);
  // With no clock at all (a raw file), every echo pair is ambiguous.
  const auto out = analyze_untimed(join({"01 06 25 02 17 70 2d 12", "01 06 25 02 17 70 2d 12"}));
  EXPECT_TRUE(out.frames()[1].findings & finding_ambiguous_echo);
}

// Right after an ambiguous echo, with no clock: a third copy may be the retry's echo or the
// master's next request, and says so; an answer only an answer can be (an exception) shows the
// echo was the retry, and answers it.
TEST(Matcher, WhatFollowsAnAmbiguousEchoSaysWhatItCanOfIt) {
  const char* write = "01 06 25 02 17 70 2d 12";
  const auto three = analyze_untimed(join({write, write, write})).frames();
  ASSERT_EQ(three.size(), 3u);
  EXPECT_EQ(three[2].role, Role::request);
  EXPECT_TRUE(three[2].findings & finding_ambiguous_echo);
  const auto refused = analyze_untimed(join({write, write, "01 86 02 c3 a1"})).frames();
  ASSERT_EQ(refused.size(), 3u);
  EXPECT_EQ(refused[2].role, Role::response);
  EXPECT_EQ(refused[2].request, refused[1].index);
  EXPECT_FALSE(refused[2].findings & finding_unsolicited);
  // Another write after the pair is no answer to it: the master's next request, unmarked.
  const auto next = analyze_untimed(join({write, write, "01 06 25 02 00 05 e3 05"})).frames();
  ASSERT_EQ(next.size(), 3u);
  EXPECT_EQ(next[2].role, Role::request);
  EXPECT_FALSE(next[2].findings & finding_ambiguous_echo);
}

// FC21's answer is its request again (Modbus application protocol 6.15): other file records
// are no answer to it, but a write the master sends next.
TEST(ResponseFit, AFileRecordWriteIsAnsweredByItsEcho) {
  const auto write = hex("15 09 06 00 04 00 01 00 01 12 34");
  EXPECT_EQ(check_response_fit(write, write), finding_none);
  EXPECT_EQ(check_response_fit(write, hex("15 09 06 00 04 00 01 00 01 56 79")),
            finding_echo_mismatch);
}

// FC20 answers each record asked with its length byte, the reference type 6 and its registers
// (Modbus application protocol 6.14).
TEST(ResponseFit, AFileRecordReadIsAnsweredByTheRecordsItAsked) {
  const auto read = hex("14 0e 06 00 04 00 01 00 02 06 00 03 00 09 00 01");
  EXPECT_EQ(check_response_fit(read, hex("14 0a 05 06 0d fe 00 20 03 06 33 cd")), finding_none);
  // Another request of the same layout; records of other lengths; a reference type not 6; one
  // record short; a byte count that is not the answer's.
  EXPECT_EQ(check_response_fit(read, read), finding_length_mismatch);
  EXPECT_EQ(check_response_fit(read, hex("14 0a 03 06 0d fe 05 06 33 cd 00 20")),
            finding_length_mismatch);
  EXPECT_EQ(check_response_fit(read, hex("14 0a 05 00 0d fe 00 20 03 06 33 cd")),
            finding_length_mismatch);
  EXPECT_EQ(check_response_fit(read, hex("14 06 05 06 0d fe 00 20")), finding_length_mismatch);
  EXPECT_EQ(check_response_fit(read, hex("14 0b 05 06 0d fe 00 20 03 06 33 cd")),
            finding_length_mismatch);
}

TEST(ResponseFit, CountersOfDiagnosticsNeedNotEcho) {
  EXPECT_EQ(check_response_fit(hex("08 00 0b 00 00"), hex("08 00 0b 01 23")), finding_none);
  EXPECT_EQ(check_response_fit(hex("08 00 00 12 ab"), hex("08 00 00 12 ac")),
            finding_echo_mismatch);
  EXPECT_EQ(check_response_fit(hex("01 00 00 00 0a"), hex("01 02 ff 03")), finding_none);
  EXPECT_EQ(check_response_fit(hex("01 00 00 00 0a"), hex("01 01 ff")), finding_length_mismatch);
}

}  // namespace
}  // namespace modtap
