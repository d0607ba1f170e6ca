// The modtap program end to end: its JSON Lines on a real capture, and its errors.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

namespace {

struct Outcome {
  int status = 0;
  std::vector<std::string> lines;
};

Outcome run(const std::string& args) {
  Outcome r;
  const std::string command = std::string(MODTAP_BINARY) + " " + args + " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  char buf[65536];
  while (pipe && std::fgets(buf, sizeof buf, pipe)) {
    std::string line(buf);
    if (!line.empty() && line.back() == '\n') line.pop_back();
    r.lines.push_back(line);
  }
  r.status = pipe ? pclose(pipe) : -1;
  return r;
}

const std::string brainchild = std::string("-r ") + MODTAP_SAMPLES +
                               "/brainchild-io-16do.sr --baud 19200 --parity even "
                               "--sigrok-channels tx=1,rx=0 --sigrok-invert";

TEST(Cli, JsonLinesCarryTheDocumentedKeys) {
  const Outcome r = run(brainchild + " -T json");
  ASSERT_EQ(r.status, 0);
  ASSERT_EQ(r.lines.size(), 30u);
  for (const char* key :
       {"\"type\":\"frame\"", "\"index\":", "\"t_ns\":", "\"channel\":", "\"mode\":\"rtu\"",
        "\"role\":", "\"slave\":1", "\"fc\":", "\"raw\":\"", "\"check\":\"ok\"",
        "\"exception\":null", "\"request\":", "\"latency_us\":"})
    EXPECT_NE(r.lines[1].find(key), std::string::npos) << key << " in " << r.lines[1];
  EXPECT_NE(r.lines[0].find("\"raw\":\"010100030001"), std::string::npos) << r.lines[0];
  EXPECT_NE(r.lines[1].find("\"role\":\"response\""), std::string::npos);
  EXPECT_NE(r.lines[1].find("\"request\":1,"), std::string::npos) << r.lines[1];
}

TEST(Cli, TextShowsOneLinePerFrameWithPairs) {
  const Outcome r = run(brainchild);
  ASSERT_EQ(r.status, 0);
  ASSERT_EQ(r.lines.size(), 30u);
  EXPECT_NE(r.lines[5].find("Read Holding Registers"), std::string::npos) << r.lines[5];
  EXPECT_NE(r.lines[5].find("req #5"), std::string::npos) << r.lines[5];
}

TEST(Cli, StatsSummariseTheCapture) {
  const Outcome r = run(brainchild + " -T stats");
  ASSERT_EQ(r.status, 0);
  ASSERT_FALSE(r.lines.empty());
  EXPECT_EQ(r.lines[0], "frames          30");
}

TEST(Cli, AMissingFileIsAClearErrorAndAnExitStatus) {
  const Outcome r = run("-r /nonexistent/capture.pcap");
  EXPECT_NE(r.status, 0);
  ASSERT_FALSE(r.lines.empty());
  EXPECT_EQ(r.lines.back().rfind("modtap: /nonexistent/capture.pcap: cannot open", 0), 0u)
      << r.lines.back();
}

}  // namespace
