// The diagnosis on the simulator's buses: each fault of one slave is found as its problem, with
// that slave, and nothing else of severity warning or error; a healthy bus shows no problem.
#include "decoder/analysis/bus_problems.hpp"

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <utility>

#include "decoder/analysis/bus_diagnostics.hpp"
#include "decoder/protocol/analyzer.hpp"
#include "tools/busgen/bus_simulator.hpp"

namespace modtap {
namespace {

using busgen::BusOptions;
using busgen::Delivery;

// The master's time-out in the simulator (BusOptions::retry_after_ns), given to the analyzer as
// a technician gives modtap the master's own.
constexpr int64_t master_timeout_ns = 200'000'000;

struct Diagnosed {
  std::vector<Problem> problems;
  std::map<uint8_t, ExchangeCounts> counts;  // the statistics' of each slave
  std::map<uint8_t, uint64_t> outages;       // the statistics' silences of each
  struct Seen {
    bool frame = false, check_ok = false;
    uint8_t slave = 0;
    std::optional<int64_t> latency_ns;
    int64_t t_ns = 0;
  };
  std::map<uint64_t, Seen> records;  // what each record index was, for the problems' citations
  std::set<std::pair<std::string, int>> kinds() const {  // (kind, slave or -1)
    std::set<std::pair<std::string, int>> out;
    for (const Problem& p : problems)
      out.emplace(std::string(problem_info(p.kind).name), p.slave ? *p.slave : -1);
    return out;
  }
};

// What each record was, by its index.
struct RecordsSeen final : RecordSink {
  void on_frame(const Frame& f) override {
    records[f.index] = {true, f.check_ok, f.device(), f.latency_ns, f.t_ns};
  }
  void on_noise(const Noise& n) override { records[n.index] = {false, false, 0, {}, n.t_ns}; }
  void on_timeout(const Timeout&) override {}
  std::map<uint64_t, Diagnosed::Seen> records;
};

// The bus read as a technician who gives modtap the master's time-out (--timeout) reads it,
// or as one who does not know it (`told` false).
Diagnosed diagnose(const BusOptions& bus, Delivery delivery = Delivery::whole_frames,
                   bool told = true) {
  const busgen::BusCapture capture = busgen::simulate(bus);
  AnalyzerOptions options;
  options.format = bus.format;
  options.clock = busgen::clock_of(delivery);
  if (told) options.timeout_ns = bus.retry_after_ns;
  options.timeout_told = told;
  BusStatistics statistics(bus.format, options.clock);
  ProblemEvidence evidence;
  RecordsSeen seen;
  FanOut sinks;
  sinks.add(statistics);
  sinks.add(evidence);
  sinks.add(seen);
  BusDiagnostics history(bus.format, options.clock, sinks);
  Analyzer analyzer(options, {{"bus", ChannelRole::bus}}, history);
  for (const auto& c : busgen::deliver(capture, delivery, bus.seed))
    analyzer.push({0, c.t_ns, {capture.bytes.data() + c.offset, c.size}});
  analyzer.finish();
  Diagnosed run{find_problems(statistics, evidence, {options.timeout_ns, told}),
                {},
                {},
                std::move(seen.records)};
  statistics.for_each_slave(
      [&](uint8_t address, const SlaveStatistics& slave) { run.counts[address] = slave.counts; });
  for (const Outage& outage : statistics.outages()) ++run.outages[outage.slave];
  return run;
}

// A scan list of six slaves, nothing wrong but what real buses always have: a few exceptions,
// a few unanswered requests, broadcasts.
BusOptions scan(uint64_t seed, std::string_view fault = {}) {
  BusOptions o;
  o.seed = seed;
  o.transactions = 3000;
  o.polled_slaves = 6;
  if (!fault.empty()) busgen::add_slave_faults(o, fault);
  return o;
}

std::string describe(const Diagnosed& run) {
  std::string out;
  for (const Problem& p : run.problems) out += "\n  " + p.text;
  return out;
}

using Found = std::set<std::pair<std::string, int>>;

TEST(BusProblems, AHealthyBusHasNone) {
  for (uint64_t seed : {1, 2, 3})
    for (Delivery delivery :
         {Delivery::whole_frames, Delivery::per_byte, Delivery::bursts, Delivery::per_frame}) {
      const Diagnosed run = diagnose(scan(seed), delivery);
      EXPECT_TRUE(run.problems.empty()) << "seed " << seed << describe(run);
    }
}

// Collisions, garbled and cut answers and line noise that fall on every device alike give one
// of forty slaves a few more than the rest by chance: no device is named for them. A device
// with damaged answers of its own, two devices at one address and an absent slave (with the
// line's junk now and then where its answer would be) stand out of the same noise.
TEST(BusProblems, ChanceSpreadOverFortySlavesNamesNoDeviceButTheFaultyOnesStandOut) {
  for (uint64_t seed = 1; seed <= 4; ++seed) {
    BusOptions bus = scan(seed, "7:absent");
    busgen::add_slave_faults(bus, "12:bit-errors=0.3");
    busgen::add_slave_faults(bus, "20:duplicate");
    bus.polled_slaves = 40;
    bus.transactions = 4000;
    bus.cut_rate = bus.collision_rate = bus.garbled_rate = bus.noise_rate = 0.01;
    const Diagnosed run = diagnose(bus, Delivery::per_frame);
    std::set<int> named;
    for (const auto& [kind, slave] : run.kinds())
      if (kind == "collisions" || kind == "corrupted-responses" || kind == "no-response" ||
          kind == "device-restarts" || kind == "intermittent-response")
        named.insert(slave);
    EXPECT_EQ(named, (std::set<int>{7, 12, 20})) << "seed " << seed << describe(run);
    EXPECT_TRUE(run.kinds().count({"no-response", 7})) << "seed " << seed << describe(run);
  }
}

TEST(BusProblems, ASlaveThatNeverAnswersIsOneNoResponse) {
  const Diagnosed run = diagnose(scan(11, "3:absent"));
  EXPECT_EQ(run.kinds(), (Found{{"no-response", 3}})) << describe(run);
  ASSERT_FALSE(run.problems.empty());
  EXPECT_EQ(run.problems[0].severity, Severity::error);
  EXPECT_NE(run.problems[0].text.find("Slave 3 never answers"), std::string::npos);
}

TEST(BusProblems, ASlaveThatStopsIsStoppedRespondingSinceThen) {
  const Diagnosed run = diagnose(scan(12, "4:stops=60s"));
  EXPECT_EQ(run.kinds(), (Found{{"stopped-responding", 4}})) << describe(run);
  ASSERT_FALSE(run.problems.empty());
  // From its first time-out in the silence that lasted: at 60 s, or the poll before it that
  // happened to go unanswered too.
  EXPECT_NEAR(run.problems[0].since_ns, 60'000'000'000, 1'000'000'000) << run.problems[0].text;
}

TEST(BusProblems, ASlaveThatDropsAShareIsIntermittent) {
  const Diagnosed run = diagnose(scan(13, "2:drop=0.28"));
  EXPECT_EQ(run.kinds(), (Found{{"intermittent-response", 2}})) << describe(run);
  ASSERT_FALSE(run.problems.empty());
  EXPECT_EQ(run.problems[0].severity, Severity::error);  // over a quarter
}

TEST(BusProblems, ASlowSlaveIsSlowResponse) {
  const Diagnosed run = diagnose(scan(14, "2:slow=131ms"));
  EXPECT_EQ(run.kinds(), (Found{{"slow-response", 2}})) << describe(run);
  ASSERT_FALSE(run.problems.empty());
  EXPECT_NE(run.problems[0].text.find("Slave 2 answers in 13"), std::string::npos)
      << run.problems[0].text;
}

// The problem says how late against the master's time-out: the figure to set it by.
TEST(BusProblems, AnswersAfterTheMastersTimeoutAreLate) {
  const Diagnosed run = diagnose(scan(15, "5:late"));
  EXPECT_EQ(run.kinds(), (Found{{"late-responses", 5}})) << describe(run);
  ASSERT_EQ(run.problems.size(), 1u);
  EXPECT_THAT(run.problems[0].text,
              ::testing::MatchesRegex("Slave 5 answers after the master has given up: [0-9]+ of "
                                      "its [0-9]+ requests \\([0-9]+%\\) were answered too late, "
                                      "20[0-9] to 20[0-9] ms after their requests where the "
                                      "master waits 200 ms"));
}

TEST(BusProblems, BitErrorsInOneSlavesAnswersAreCorruptedResponses) {
  const Diagnosed run = diagnose(scan(16, "5:bit-errors=0.1"));
  EXPECT_EQ(run.kinds(), (Found{{"corrupted-responses", 5}})) << describe(run);
}

TEST(BusProblems, BitErrorsEverywhereAreBusNoise) {
  BusOptions o = scan(17);
  o.corruption_rate = 0.03;
  const Diagnosed run = diagnose(o);
  EXPECT_EQ(run.kinds(), (Found{{"bus-noise", -1}})) << describe(run);
}

TEST(BusProblems, ABlockTheSlaveLacksIsARejectedRequestNamedByItsAddress) {
  const Diagnosed run = diagnose(scan(18, "4:missing-block=0400H+4"));
  EXPECT_EQ(run.kinds(), (Found{{"rejected-requests", 4}})) << describe(run);
  ASSERT_FALSE(run.problems.empty());
  EXPECT_NE(run.problems[0].text.find("read of 0400H (4 registers) with exception 02H (Illegal "
                                      "Data Address)"),
            std::string::npos)
      << run.problems[0].text;
}

TEST(BusProblems, TwoDevicesOnOneAddressAreCollisions) {
  const Diagnosed run = diagnose(scan(19, "6:duplicate"));
  EXPECT_EQ(run.kinds(), (Found{{"collisions", 6}})) << describe(run);
}

TEST(BusProblems, AGlitchBeforeEveryAnswerOfOneSlaveIsItsTurnaroundGlitch) {
  const Diagnosed run = diagnose(scan(20, "1:glitch"), Delivery::per_byte);
  EXPECT_EQ(run.kinds(), (Found{{"turnaround-glitches", 1}})) << describe(run);
}

// One cause is one problem, on every delivery and seed: one device's damaged answers, or two
// devices at its address, are no bad line (bus-noise), nor are two bad devices among six; a
// slave that never answers is no intermittent one, a late one no slow one; a stray byte after
// every slave's requests alike is one problem at the master's side, not one a slave.
TEST(BusProblems, OneCauseIsOneProblemWhateverTheSeedAndClock) {
  struct Case {
    std::vector<std::string_view> faults;
    double glitch_rate;
    Found found;
    double reflection_rate = 0;
    double corruption_rate = 0;
    bool random_traffic = false;  // every function, every length, not a scan list's reads
    int64_t noise_burst_period_ns = 0;
    int64_t second_master_period_ns = 0;
  };
  const Case cases[] = {
      {{"5:bit-errors=0.3"}, 0, {{"corrupted-responses", 5}}},
      {{"2:bit-errors=0.3", "5:bit-errors=0.3"},
       0,
       {{"corrupted-responses", 2}, {"corrupted-responses", 5}}},
      {{"6:duplicate"}, 0, {{"collisions", 6}}},
      {{"4:half-baud"}, 0, {{"wrong-baud-device", 4}}},
      {{"3:restarts=20s"}, 0, {{"device-restarts", 3}}},
      {{"2:slow-block=0400H+10"}, 0, {{"slow-block", 2}}},
      {{"2:slow-block=0400H+10", "5:absent"}, 0, {{"slow-block", 2}, {"no-response", 5}}},
      {{"3:restarts=20s", "5:bit-errors=0.3"},
       0,
       {{"device-restarts", 3}, {"corrupted-responses", 5}}},
      {{"4:half-baud", "2:late"}, 0, {{"wrong-baud-device", 4}, {"late-responses", 2}}},
      {{"3:absent"}, 0, {{"no-response", 3}}},
      {{"2:late"}, 0, {{"late-responses", 2}}},
      {{}, 0.5, {{"turnaround-glitches", -1}}},
      {{}, 0, {{"reflections", -1}}, 0.15, 0, true},
      {{"3:absent"}, 0, {{"reflections", -1}, {"no-response", 3}}, 0.15, 0, true},
      {{}, 0, {{"bus-noise", -1}}, 0, 0.05, true},
      {{}, 0, {{"noise-bursts", -1}}, 0, 0, false, 700'000'000},
      {{}, 0, {{"second-master", -1}}, 0, 0, false, 0, 1'000'000'000},
      {{"3:absent"}, 0, {{"second-master", -1}, {"no-response", 3}}, 0, 0, false, 0, 1'000'000'000},
      {{"2:late"},
       0,
       {{"second-master", -1}, {"late-responses", 2}},
       0,
       0,
       false,
       0,
       1'000'000'000},
      {{"5:bit-errors=0.3"},
       0,
       {{"second-master", -1}, {"corrupted-responses", 5}},
       0,
       0,
       false,
       0,
       1'000'000'000},
      {{"4:half-baud"},
       0,
       {{"noise-bursts", -1}, {"wrong-baud-device", 4}},
       0,
       0,
       false,
       700'000'000},
      // A burst that falls in an absent slave's answer time is the line's junk, not its answer.
      {{"3:absent"}, 0, {{"noise-bursts", -1}, {"no-response", 3}}, 0, 0, false, 700'000'000},
      {{"5:restarts=20s"},
       0,
       {{"noise-bursts", -1}, {"device-restarts", 5}},
       0,
       0,
       false,
       700'000'000},
  };
  for (const Case& c : cases)
    for (uint64_t seed = 30; seed < 36; ++seed)
      for (Delivery delivery :
           {Delivery::whole_frames, Delivery::per_byte, Delivery::bursts, Delivery::per_frame}) {
        BusOptions o = scan(seed);
        for (const std::string_view fault : c.faults) busgen::add_slave_faults(o, fault);
        if (c.random_traffic) o.polled_slaves = 0;
        o.glitch_rate = c.glitch_rate;
        o.reflection_rate = c.reflection_rate;
        o.noise_burst_period_ns = c.noise_burst_period_ns;
        o.second_master_period_ns = c.second_master_period_ns;
        o.corruption_rate = c.corruption_rate;
        const Diagnosed run = diagnose(o, delivery);
        EXPECT_EQ(run.kinds(), c.found)
            << (c.faults.empty() ? "glitches" : c.faults[0]) << " seed " << seed << " delivery "
            << static_cast<int>(delivery) << describe(run);
      }
}

// A master whose own time-out is short (30 ms) sends its next request that soon after an
// unanswered one: its own program, not a second master's. Told, its time-out says so; not
// told, no answer comes after the request it moved on from, as one would after another
// master's exchange.
TEST(BusProblems, AMasterWithAShortTimeOutIsNoSecondMaster) {
  BusOptions o = scan(22, "3:absent");
  o.retry_after_ns = 30'000'000;
  o.format = {115200, 8, Parity::even, 1};
  for (const bool told : {true, false}) {
    const Diagnosed run = diagnose(o, Delivery::per_byte, told);
    EXPECT_EQ(run.kinds(), (Found{{"no-response", 3}})) << "told " << told << describe(run);
  }
}

// One set of numbers: a slave that misses some requests and answers others late has, in its
// problems, as many time-outs as the statistics count, the late ones as their late responses.
TEST(BusProblems, TheProblemsCountTheTimeOutsTheStatisticsCount) {
  for (const Delivery delivery : {Delivery::per_byte, Delivery::bursts}) {
    const Diagnosed run = diagnose(scan(21, "2:late,drop=0.2"), delivery);
    const auto figure = [&](std::string_view kind, std::string_view name) {
      for (const Problem& p : run.problems)
        if (problem_info(p.kind).name == kind && p.slave == 2)
          for (const auto& [key, value] : p.evidence)
            if (key == name) return static_cast<uint64_t>(value);
      ADD_FAILURE() << kind << " " << name << describe(run);
      return uint64_t{0};
    };
    const ExchangeCounts& counts = run.counts.at(2);
    EXPECT_EQ(figure("late-responses", "late_answers"), counts.late);
    EXPECT_EQ(figure("intermittent-response", "timeouts") + counts.late, counts.timeouts);
    EXPECT_EQ(figure("intermittent-response", "requests"), counts.requests);
    EXPECT_EQ(counts.answered_in_time() + counts.timeouts, counts.requests);
  }
}

// One set of numbers: a restarting device's silences, and the one the capture may end in, are
// the outages the statistics list for it; a device that answers in junk beside it has none.
TEST(BusProblems, ARestartingDevicesSilencesAreItsOutages) {
  uint64_t ended_silent = 0;
  for (const Delivery delivery : {Delivery::per_byte, Delivery::bursts, Delivery::usb_packets})
    for (int period_s = 11; period_s < 32; period_s += 2) {
      const std::string period = std::to_string(period_s) + "s";
      BusOptions bus = scan(30, "2:restarts=" + period);
      busgen::add_slave_faults(bus, "4:half-baud");
      const Diagnosed run = diagnose(bus, delivery);
      uint64_t silences = 0;
      for (const Problem& p : run.problems)
        if (p.kind == ProblemKind::device_restarts && p.slave == 2)
          for (const auto& [key, value] : p.evidence) {
            if (key == "silences") silences += static_cast<uint64_t>(value);
            if (key == "silent_at_end") {
              silences += static_cast<uint64_t>(value);
              ended_silent += static_cast<uint64_t>(value);
            }
          }
      EXPECT_GE(silences, 2u) << period << describe(run);
      EXPECT_EQ(run.outages.count(2) ? run.outages.at(2) : 0, silences) << period << describe(run);
      EXPECT_EQ(run.outages.count(4), 0u) << period << describe(run);
    }
  EXPECT_GT(ended_silent, 0u);  // the capture ended in a silence in some of these
}

// A slow block cites its first slow answers, and a contactor's bursts the first of its bursts:
// records a report links, each what the problem says.
TEST(BusProblems, ASlowBlockAndNoiseBurstsCiteTheirFirstRecords) {
  const Diagnosed slow = diagnose(scan(40, "2:slow-block=0400H+10"), Delivery::per_byte);
  ASSERT_EQ(slow.problems.size(), 1u) << describe(slow);
  EXPECT_EQ(slow.problems[0].first_records.size(), ProblemEvidence::kept_records);
  for (const uint64_t index : slow.problems[0].first_records) {
    const Diagnosed::Seen& r = slow.records.at(index);
    EXPECT_TRUE(r.frame && r.check_ok && r.slave == 2) << index;
    EXPECT_GE(r.latency_ns.value_or(0), 60'000'000) << index;
  }
  BusOptions bus = scan(41);
  bus.noise_burst_period_ns = 700'000'000;
  const Diagnosed bursts = diagnose(bus, Delivery::per_byte);
  ASSERT_EQ(bursts.problems.size(), 1u) << describe(bursts);
  const auto& first = bursts.problems[0].first_records;
  ASSERT_EQ(first.size(), ProblemEvidence::kept_records);
  for (size_t i = 0; i < first.size(); ++i) {
    const Diagnosed::Seen& r = bursts.records.at(first[i]);
    EXPECT_FALSE(r.check_ok) << first[i];  // junk, or a frame a burst fell on
    if (i > 0) {
      EXPECT_GT(r.t_ns - bursts.records.at(first[i - 1]).t_ns, 600'000'000) << i;
    }
  }
}

// A slave asked 200 times that answered once (a record read as its answer that was none, or
// one it got through) is silent, not "fails to answer 100 %": fewer answers than a few, and
// one in a hundred at most.
TEST(BusProblems, ASlaveThatAnsweredOnceInHundredsAlmostNeverAnswers) {
  const std::vector<uint8_t> request{3, 0x03, 0x00, 0x00, 0x00, 0x01, 0x85, 0xE8};
  const std::vector<uint8_t> answer{3, 0x03, 0x02, 0x00, 0x07, 0x80, 0x46};
  ProblemEvidence evidence;
  uint64_t index = 0;
  for (int i = 0; i < 200; ++i) {
    Frame frame;
    frame.index = ++index;
    frame.adu = frame.raw = request;
    frame.check_ok = true;
    frame.role = Role::request;
    frame.t_ns = i * 300'000'000LL;
    evidence.on_frame(frame);
    if (i == 7) {
      Frame reply;
      reply.index = ++index;
      reply.adu = reply.raw = answer;
      reply.check_ok = true;
      reply.role = Role::response;
      reply.request = frame.index;
      reply.request_slave = 3;
      reply.t_ns = frame.t_ns + 10'000'000;
      evidence.on_frame(reply);
      continue;
    }
    Timeout timeout;
    timeout.request = frame.index;
    timeout.slave = 3;
    timeout.function = 0x03;
    timeout.t_ns = frame.t_ns + master_timeout_ns;
    timeout.waited_ns = master_timeout_ns;
    evidence.on_timeout(timeout);
  }
  const BusStatistics statistics(SerialFormat{}, ClockQuality::per_byte);
  const std::vector<Problem> problems =
      find_problems(statistics, evidence, {master_timeout_ns, true});
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_EQ(problems[0].kind, ProblemKind::no_response);
  EXPECT_EQ(problems[0].text,
            "Slave 3 almost never answers: 199 of 200 requests timed out, 1 answered");
}

// docs/output.md is where a technician reads what a problem advises: every kind's advice, as
// the outputs give it, in its table.
TEST(BusProblems, TheOutputDocsGiveEveryKindsAdvice) {
  std::ifstream file(std::string(MODTAP_SOURCE) + "/docs/output.md");
  ASSERT_TRUE(file) << "docs/output.md";
  std::stringstream docs;
  docs << file.rdbuf();
  for (size_t kind = 0; kind < problem_kind_count; ++kind) {
    const ProblemInfo& info = problem_info(static_cast<ProblemKind>(kind));
    const std::string row = fmt::format("| `{}` | {} |", info.name, std::string_view(info.advice));
    EXPECT_NE(docs.str().find(row), std::string::npos) << row;
  }
}

}  // namespace
}  // namespace modtap
