// The real logic-analyzer captures in captures/samples (from the sigrok project's public
// dumps): every frame CRC-good, with its role and its pair.
#include "captures/sigrok_reader.hpp"

#include <gtest/gtest.h>

#include "decoder/protocol/analyzer.hpp"
#include "tests/support/collector.hpp"

namespace modtap::captures {
namespace {
using testing::Collector;

Collector analyze(const std::string& file, const SigrokOptions& options) {
  SigrokReader reader(std::string(MODTAP_SAMPLES) + "/" + file, options);
  AnalyzerOptions a;
  a.format = options.format;
  a.clock = reader.clock();
  Collector out;
  Analyzer bus(a, reader.channels(), out);
  Chunk chunk;
  while (reader.next(chunk)) bus.push(chunk);
  bus.finish();
  return out;
}

void expect_clean_pairs(const Collector& out, size_t frames_expected) {
  const auto frames = out.frames();
  ASSERT_EQ(frames.size(), frames_expected);
  EXPECT_TRUE(out.noise().empty());
  EXPECT_TRUE(out.timeouts().empty());
  for (size_t i = 0; i < frames.size(); ++i) {
    EXPECT_TRUE(frames[i].check_ok) << "frame " << frames[i].index;
    EXPECT_EQ(frames[i].role, i % 2 ? Role::response : Role::request)
        << "frame " << frames[i].index;
    if (i % 2) {
      EXPECT_EQ(frames[i].request, frames[i - 1].index);
      EXPECT_EQ(frames[i].findings, 0u) << "frame " << frames[i].index;
    }
  }
}

TEST(SigrokCaptures, BrainchildSplitLinesGiveFifteenCleanPairs) {
  SigrokOptions o;
  o.lines = parse_sigrok_channels("tx=1,rx=0");
  o.invert = true;
  o.format = {19200, 8, Parity::even, 1};
  const auto out = analyze("brainchild-io-16do.sr", o);
  expect_clean_pairs(out, 30);
  // The slave answers about 3.9 character times after the request: just above t3.5.
  const auto frames = out.frames();
  const int64_t char_ns = o.format.char_time_ns();
  for (size_t i = 1; i < frames.size(); i += 2) {
    ASSERT_TRUE(frames[i].latency_ns);
    EXPECT_GT(*frames[i].latency_ns, char_ns * 3);
    EXPECT_LT(*frames[i].latency_ns, char_ns * 5);
  }
}

TEST(SigrokCaptures, FlowmeterBusProbeGivesCleanPairs) {
  SigrokOptions o;
  o.lines = parse_sigrok_channels("bus=RXTX");
  o.format = {9600, 8, Parity::none, 1};
  const auto graph = analyze("flowmeter_graph_tool.sr", o);
  expect_clean_pairs(graph, 18);
  const auto target = analyze("flowmeter_target_15liter_per_min.sr", o);
  ASSERT_GT(target.frames().size(), 20u);
  expect_clean_pairs(target, target.frames().size());
  for (const auto& f : target.frames()) EXPECT_EQ(f.raw[0], 0xF7);
}

TEST(SigrokCaptures, AWrongChannelNameIsAnErrorNotASilentDefault) {
  SigrokOptions o;
  o.lines = parse_sigrok_channels("bus=RX");
  try {
    SigrokReader reader(std::string(MODTAP_SAMPLES) + "/flowmeter_graph_tool.sr", o);
    FAIL() << "no error";
  } catch (const CaptureError& e) {
    EXPECT_NE(std::string(e.what()).find("no channel named \"RX\""), std::string::npos) << e.what();
  }
}

TEST(SigrokChannels, ParsesRolesAndRejectsNonsense) {
  EXPECT_EQ(parse_sigrok_channels("tx=1,rx=0").size(), 2u);
  EXPECT_THROW(parse_sigrok_channels("bus=A,tx=B"), std::invalid_argument);
  EXPECT_THROW(parse_sigrok_channels("up=A"), std::invalid_argument);
  EXPECT_THROW(parse_sigrok_channels("tx="), std::invalid_argument);
}

}  // namespace
}  // namespace modtap::captures
