// The diagnosis on the simulator's buses: each fault of one slave is found as its problem, with
// that slave, and nothing else of severity warning or error; a healthy bus shows no problem.
#include "decoder/analysis/bus_problems.hpp"

#include <gtest/gtest.h>

#include <set>
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
  std::set<std::pair<std::string, int>> kinds() const {  // (kind, slave or -1)
    std::set<std::pair<std::string, int>> out;
    for (const Problem& p : problems)
      out.emplace(std::string(problem_info(p.kind).name), p.slave ? *p.slave : -1);
    return out;
  }
};

Diagnosed diagnose(const BusOptions& bus, Delivery delivery = Delivery::whole_frames) {
  const busgen::BusCapture capture = busgen::simulate(bus);
  AnalyzerOptions options;
  options.format = bus.format;
  options.clock = busgen::clock_of(delivery);
  options.timeout_ns = master_timeout_ns;
  BusStatistics statistics(bus.format, options.clock);
  ProblemEvidence evidence;
  FanOut sinks;
  sinks.add(statistics);
  sinks.add(evidence);
  BusDiagnostics history(bus.format, options.clock, sinks);
  Analyzer analyzer(options, {{"bus", ChannelRole::bus}}, history);
  for (const auto& c : busgen::deliver(capture, delivery, bus.seed))
    analyzer.push({0, c.t_ns, {capture.bytes.data() + c.offset, c.size}});
  analyzer.finish();
  return {find_problems(statistics, evidence, {master_timeout_ns})};
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

TEST(BusProblems, AnswersAfterTheMastersTimeoutAreLate) {
  const Diagnosed run = diagnose(scan(15, "5:late"));
  EXPECT_EQ(run.kinds(), (Found{{"late-responses", 5}})) << describe(run);
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

}  // namespace
}  // namespace modtap
