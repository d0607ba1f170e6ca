// The modtap program end to end: its JSON Lines on a real capture, and its errors.
#include <fcntl.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "captures/pcap_chunk_writer.hpp"
#include "decoder/protocol/checksum.hpp"
#include "tools/busgen/bus_simulator.hpp"
#include "tools/modtap/model_catalog.hpp"

namespace {

struct Outcome {
  int status = 0;
  std::vector<std::string> lines;
};

// Runs a shell command; its standard output as lines.
Outcome run_shell(const std::string& command) {
  Outcome r;
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

Outcome run(const std::string& args) {
  return run_shell(std::string(MODTAP_BINARY) + " " + args + " 2>&1");
}

std::string hexlog(const std::string& name, const std::vector<std::string>& timed_frames);

const std::string brainchild = std::string("-r ") + MODTAP_SAMPLES +
                               "/brainchild-io-16do.sr --baud 19200 --parity even "
                               "--sigrok-channels tx=1,rx=0 --sigrok-invert";

// A raw RTU capture of `bodies` (slave + PDU, CRC added) in a temporary file.
std::string raw_capture(const std::string& name, const std::vector<std::vector<uint8_t>>& bodies) {
  const auto path = std::filesystem::temp_directory_path() / name;
  std::ofstream out(path, std::ios::binary);
  for (auto body : bodies) {
    const uint16_t crc = modtap::crc16(body);
    body.push_back(static_cast<uint8_t>(crc & 0xFF));
    body.push_back(static_cast<uint8_t>(crc >> 8));
    out.write(reinterpret_cast<const char*>(body.data()),
              static_cast<std::streamsize>(body.size()));
  }
  return path.string();
}

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
  ASSERT_GE(r.lines.size(), 3u);
  // The conclusions first: a real bus with nothing wrong.
  EXPECT_EQ(r.lines[0], "problems        none found");
  EXPECT_EQ(r.lines[2], "capture         0.267 s, 19200 8E1, clock per-byte");
  EXPECT_EQ(r.lines[3], "frames          30 (112.5 a second), bus load 50.5%");
  EXPECT_THAT(
      r.lines,
      ::testing::Contains(
          "latency         p50 2.1 ms, p95 2.1 ms, p99 2.1 ms, max 2.1 ms over 15 responses"));
  EXPECT_EQ(r.lines[r.lines.size() - 2],
            "slave  requests  responses  timeouts   rate  excepts  bad  retries"
            "      p50     p95     p99     max      p50     p95");
  EXPECT_EQ(r.lines.back(),
            "    1        15         15         0   0.0%        0    0        0"
            "       2.1     2.1     2.1     2.1       14      67");
}

TEST(Cli, StatsCountTheModelsFindingsByKind) {
  const std::string capture =
      raw_capture("modtap-stats-model.raw", {{0x01, 0x06, 0x25, 0x20, 0x00, 0x01},
                                             {0x01, 0x86, 0x52},
                                             {0x01, 0x06, 0x25, 0x03, 0x00, 0x01}});
  const Outcome r = run("-r " + capture + " --format raw --mode rtu --model nta5000 -T stats");
  ASSERT_EQ(r.status, 0);
  ASSERT_GE(r.lines.size(), 4u);
  const std::vector<std::string> tail(r.lines.end() - 4, r.lines.end());
  EXPECT_EQ(tail, (std::vector<std::string>{"findings                 count  first records",
                                            "  reserved-write             1  #3",
                                            "  read-only-write            1  #1",
                                            "  exception                  1  #2"}));
}

// A register's last value is what the device's good answers say: a write it refused, or never
// answered, changed nothing; a write it acknowledged (FC16: no echo of the values) did.
TEST(Cli, LastValuesAreWhatTheDeviceConfirmed) {
  const std::string capture =
      raw_capture("modtap-confirmed-values.raw",
                  {{0x01, 0x03, 0x25, 0x20, 0x00, 0x01},
                   {0x01, 0x03, 0x02, 0x00, 0x07},  // status 7
                   {0x01, 0x06, 0x25, 0x20, 0x00, 0x01},
                   {0x01, 0x86, 0x52},  // refused
                   {0x01, 0x10, 0x25, 0x01, 0x00, 0x02, 0x04, 0x00, 0x01, 0x17, 0x70},
                   {0x01, 0x10, 0x25, 0x01, 0x00, 0x02},    // acknowledged
                   {0x01, 0x06, 0x25, 0x03, 0x00, 0x01}});  // never answered
  const std::string options = "-r " + capture + " --format raw --mode rtu --model nta5000";
  const Outcome stats = run(options + " -T stats");
  ASSERT_EQ(stats.status, 0);
  EXPECT_THAT(stats.lines,
              ::testing::Contains("  slave 1   2520H status                       Run, Reverse, "
                                  "Ready (7)"));
  EXPECT_THAT(stats.lines,
              ::testing::Contains("  slave 1   2502H frequency_command            60.00 Hz"));
  EXPECT_THAT(stats.lines, ::testing::Not(::testing::Contains(::testing::HasSubstr("2503H"))));
  const Outcome csv = run(options + " -T csv");
  ASSERT_EQ(csv.status, 0);
  ASSERT_EQ(csv.lines.size(), 4u);  // the header, status, and the two registers FC16 wrote
  EXPECT_THAT(csv.lines[1], ::testing::HasSubstr(",1,2520H,status,7,"));
  EXPECT_THAT(csv.lines[3], ::testing::HasSubstr(",1,2502H,frequency_command,60.00,"));
}

// The --stats JSON of a run of modtap with `options` (and -q), written to a file `name`.
std::string stats_json(const std::string& options, const std::string& name) {
  const auto path = (std::filesystem::temp_directory_path() / name).string();
  EXPECT_EQ(run(options + " -q --stats " + path).status, 0);
  std::ifstream file(path);
  std::stringstream json;
  json << file.rdbuf();
  return json.str();
}

// A simulated scan of six slaves at 19200 8E1, one packet a frame (or as `delivery` says), with
// `faults` (busgen's syntax).
std::string faulty_bus(const std::string& name, const std::vector<std::string>& faults,
                       modtap::busgen::Delivery delivery = modtap::busgen::Delivery::whole_frames) {
  modtap::busgen::BusOptions o;
  o.transactions = 1200;
  o.polled_slaves = 6;
  for (const auto& fault : faults) modtap::busgen::add_slave_faults(o, fault);
  const auto capture = modtap::busgen::simulate(o);
  const auto path = (std::filesystem::temp_directory_path() / name).string();
  modtap::captures::PcapChunkWriter writer(path, 147);
  for (const auto& c : modtap::busgen::deliver(capture, delivery, 1))
    writer.write(
        {0, 1'700'000'000'000'000'000 + c.t_ns, {capture.bytes.data() + c.offset, c.size}});
  return path;
}

// The statistics lead with what is wrong, by device, with what to check; --stats has the same
// problems first, each with its evidence.
TEST(Cli, StatsLeadWithTheProblemsEachFaultyDeviceNamed) {
  const std::string capture =
      faulty_bus("modtap-problems.pcap", {"3:absent", "4:missing-block=0400H+4"});
  const Outcome r = run("-r " + capture + " -T stats");
  ASSERT_EQ(r.status, 0);
  ASSERT_GE(r.lines.size(), 8u);
  EXPECT_EQ(r.lines[0], "problems");
  EXPECT_THAT(r.lines[1], ::testing::MatchesRegex(
                              "  error   Slave 3 never answers: [0-9]+ requests, all timed out"));
  EXPECT_THAT(r.lines[2], ::testing::StartsWith("          advice: check that a device"));
  EXPECT_THAT(r.lines, ::testing::Contains(::testing::HasSubstr(
                           "warning Slave 4 answers nearly every read of 0400H (4 registers) "
                           "with exception 02H")));
  const std::string json = stats_json("-r " + capture, "modtap-problems.json");
  EXPECT_NE(json.find("\"problems\":[{\"problem\":\"no-response\",\"slave\":3,"
                      "\"severity\":\"error\",\"since_ns\":"),
            std::string::npos)
      << json.substr(0, 400);
  EXPECT_NE(json.find(",\"evidence\":{\"requests\":"), std::string::npos);
  EXPECT_NE(json.find("{\"problem\":\"rejected-requests\",\"slave\":4,"), std::string::npos);
}

// One count, one number: an exception answer whose check fails may have its code damaged, so
// neither the exceptions nor the model's "exception" finding count it.
TEST(Cli, AnExceptionWithABadCheckIsNoException) {
  std::string capture = raw_capture("modtap-bad-exception.raw",
                                    {{0x01, 0x03, 0x00, 0x00, 0x00, 0x01}, {0x01, 0x83, 0x02}});
  {
    std::fstream file(capture, std::ios::in | std::ios::out | std::ios::binary);
    file.seekp(10);  // the exception code: 02H becomes DBH, the CRC no longer holds
    file.put(static_cast<char>(0xDB));
  }
  const Outcome r = run("-r " + capture + " --format raw --mode rtu --model generic -T stats");
  ASSERT_EQ(r.status, 0);
  EXPECT_THAT(r.lines, ::testing::Contains(::testing::HasSubstr("(exceptions 0, unsolicited 0)")));
  EXPECT_THAT(r.lines, ::testing::Not(::testing::Contains(::testing::StartsWith("  exception "))));
}

// --stats writes the statistics as JSON beside any output; a pipe reader would get text.
TEST(Cli, StatsFileIsJsonBesideTheTextOutput) {
  const auto path = (std::filesystem::temp_directory_path() / "modtap-cli-stats.json").string();
  std::filesystem::remove(path);
  const Outcome r = run(brainchild + " --stats " + path);
  ASSERT_EQ(r.status, 0);
  EXPECT_EQ(r.lines.size(), 30u);  // the frames, as without --stats
  std::ifstream file(path);
  std::stringstream json;
  json << file.rdbuf();
  EXPECT_EQ(
      json.str().rfind(
          "{\"complete\":true,\"clock\":\"per-byte\",\"read_lag_ms\":0,\"serial\":\"19200 8E1\"",
          0),
      0u)
      << json.str();
  EXPECT_NE(json.str().find("\"frames\":30,\"requests\":15,\"responses\":15"), std::string::npos);
  EXPECT_NE(json.str().find("\"slaves\":[{\"slave\":1,\"requests\":15,"), std::string::npos);
}

// dumpcap's autostop: after so many frames, so much capture time, or a -w file so large; the
// first condition reached wins. Conditions that are none are refused before any work.
TEST(Cli, AutostopEndsTheRunAtTheFirstConditionReached) {
  // The records, then which condition stopped the run.
  EXPECT_EQ(run(brainchild + " -a frames:5 -T json").lines.size(), 5u + 1);
  EXPECT_EQ(run(brainchild + " -a frames:5 -c 3 -T json").lines.size(), 3u);
  // The capture spans 262 ms; its first 100 ms hold 14 frames.
  const Outcome early = run(brainchild + " -a duration:0.1 -T json");
  ASSERT_EQ(early.status, 0);
  EXPECT_EQ(early.lines.size(), 14u + 1);
  EXPECT_EQ(early.lines.back(), "modtap: stopped at -a duration:0.1");
  const auto pcapng = (std::filesystem::temp_directory_path() / "modtap-autostop.pcapng").string();
  std::filesystem::remove(pcapng);
  ASSERT_EQ(run(brainchild + " -a filesize:1 -a duration:10 -w " + pcapng).status, 0);
  const auto size = std::filesystem::file_size(pcapng);
  EXPECT_GE(size, 1000u);
  EXPECT_LT(size, 1400u);
  const Outcome written = run("-r " + pcapng + " -T json");
  EXPECT_GT(written.lines.size(), 2u);
  EXPECT_LT(written.lines.size(), 30u);
  std::filesystem::remove(pcapng);
  for (const char* bad : {"size:3", "frames:2.5", "duration:0", "duration:", "frames"}) {
    const Outcome refused = run(brainchild + " -a " + bad);
    EXPECT_NE(refused.status, 0) << bad;
    ASSERT_FALSE(refused.lines.empty()) << bad;
    EXPECT_THAT(refused.lines.back(), ::testing::HasSubstr(std::string("-a ") + bad)) << bad;
  }
  const Outcome no_file = run(brainchild + " -a filesize:1");
  EXPECT_NE(no_file.status, 0);
  EXPECT_THAT(no_file.lines.back(), ::testing::HasSubstr("give -w"));
}

// tshark's habits: -c stops after N frames (statistics included), -q keeps only the summary,
// -t chooses the time column, --version says which modtap this is.
TEST(Cli, TsharkHabitsCountQuietTimeAndVersion) {
  const Outcome three = run(brainchild + " -c 3");
  EXPECT_EQ(three.lines.size(), 3u);
  const Outcome counted = run(brainchild + " -c 4 -q -T stats");
  ASSERT_GE(counted.lines.size(), 4u);
  EXPECT_EQ(counted.lines[3].rfind("frames          4 ", 0), 0u) << counted.lines[3];
  EXPECT_TRUE(run(brainchild + " -q").lines.empty());

  const Outcome pcap = run_shell("TZ=UTC " + std::string(MODTAP_BINARY) + " -r " + MODTAP_SAMPLES +
                                 "/drives-manual-examples.log -c 2 -t ad");
  ASSERT_EQ(pcap.lines.size(), 2u);
  EXPECT_EQ(pcap.lines[0].substr(0, 35), "     1 2026-11-22 09:00:00.000000 r") << pcap.lines[0];
  const Outcome delta = run(brainchild + " -c 2 -t d");
  ASSERT_EQ(delta.lines.size(), 2u);
  EXPECT_EQ(delta.lines[0].substr(0, 18), "     1    0.000000");

  const Outcome version = run("--version");
  EXPECT_EQ(version.status, 0);
  EXPECT_THAT(version.lines,
              ::testing::ElementsAre(std::string("modtap ") + MODTAP_PROJECT_VERSION));
}

// One version, CMake's project(VERSION), wherever modtap says one: the extcap tells Wireshark
// the same as modtap --version.
TEST(Cli, TheExtcapSaysTheProjectsVersion) {
  const Outcome extcap = run_shell(std::string(MODTAP_EXTCAP) + " --extcap-interfaces");
  EXPECT_THAT(extcap.lines, ::testing::Contains(::testing::StartsWith(
                                std::string("extcap {version=") + MODTAP_PROJECT_VERSION + "}")));
}

// -Y picks lines, it does not move them in time: each line shown reads as it does without the
// filter, with -t r (since the capture's first record) and -t d (since the record before, shown
// or not, as tshark's -t d); -t dd counts from the line shown before, as tshark's.
TEST(Cli, FilterLeavesTheTimeColumnAsWithoutIt) {
  for (const std::string format : {"r", "d"}) {
    const Outcome all = run(brainchild + " -t " + format);
    const Outcome picked = run(brainchild + " -t " + format + " -Y 'fc == 3'");
    ASSERT_EQ(picked.lines.size(), 4u) << format;
    for (const std::string& line : picked.lines)
      EXPECT_THAT(all.lines, ::testing::Contains(line)) << "-t " << format;
  }
  const Outcome shown = run(brainchild + " -t dd -Y 'fc == 3'");
  ASSERT_EQ(shown.lines.size(), 4u);
  std::vector<std::string> times;
  for (const std::string& line : shown.lines) times.push_back(line.substr(6, 12));
  EXPECT_EQ(times, (std::vector<std::string>{"    0.000000", "    0.006695", "    0.162314",
                                             "    0.006678"}));
}

// Every error speaks as modtap and exits 2, the command line's own too, in words a person
// reads; --help says what the line's settings are when none are given.
TEST(Cli, OptionErrorsSpeakAsModtapAndExitTwo) {
  const Outcome zero = run("-r x -c 0");
  EXPECT_EQ(zero.status >> 8, 2);
  EXPECT_EQ(zero.lines, std::vector<std::string>{
                            "modtap: -c: needs at least 1 (modtap --help lists the options)"});
  for (const std::string args : {"--bogus", "-r x -T xml", "-r x --timeout 0", "-r x --parity 9"}) {
    const Outcome refused = run(args);
    EXPECT_EQ(refused.status >> 8, 2) << args;
    ASSERT_EQ(refused.lines.size(), 1u) << args;
    EXPECT_EQ(refused.lines[0].rfind("modtap: ", 0), 0u) << refused.lines[0];
  }
  const Outcome help = run("--help");
  EXPECT_EQ(help.status, 0);
  const std::string text = fmt::format("{}", fmt::join(help.lines, "\n"));
  for (const char* shown : {"(default 19200)", "even (default)", "Stop bits (default 1)",
                            "Data bits (default 8 for RTU, 7 for ASCII)"})
    EXPECT_THAT(text, ::testing::HasSubstr(shown));
}

// An option this run would not use is said, never ignored in silence; a model for the
// broadcast address or a misspelt model name is refused, the latter with the name it likely
// meant.
TEST(Cli, OptionsThatDoNothingAreSaid) {
  const Outcome idle = run(brainchild + " -c 1 --link bare -V -T stats");
  EXPECT_EQ(idle.status, 0);
  EXPECT_THAT(idle.lines, ::testing::Contains("modtap: warning: --link sets the link type of -w; "
                                              "this run has none, so it does nothing"));
  EXPECT_THAT(idle.lines,
              ::testing::Contains("modtap: warning: -V adds the field tree to the text output "
                                  "(-T text); this run has none, so it does nothing"));
  const Outcome used = run(brainchild + " -c 1 -V");
  EXPECT_THAT(used.lines, ::testing::Not(::testing::Contains(::testing::HasSubstr("warning"))));
  const Outcome broadcast = run(brainchild + " --model 0=gd20");
  EXPECT_EQ(broadcast.status >> 8, 2);
  EXPECT_EQ(broadcast.lines,
            std::vector<std::string>{"modtap: --model 0=gd20: slave 0 is the broadcast address, "
                                     "which no device answers as: give the device's own address"});
  EXPECT_EQ(
      run(brainchild + " --model 2=nta500").lines,
      std::vector<std::string>{
          "modtap: no model named 'nta500'; did you mean nta5000? (modtap models lists them)"});
}

// Raw bytes have no clock: no time of day to show (-t ad counts from the first byte, and says
// so), and no frames a second in the statistics, whose span says the time is nominal.
TEST(Cli, RawBytesHaveNoClockToShow) {
  const std::string raw =
      "-r " + raw_capture("modtap-no-clock.raw", {{1, 3, 0, 0, 0, 1}, {1, 3, 2, 0, 5}});
  const Outcome dated = run(raw + " -t ad");
  EXPECT_EQ(dated.status, 0);
  EXPECT_THAT(dated.lines, ::testing::Contains(::testing::HasSubstr("has no clock (raw bytes)")));
  EXPECT_THAT(dated.lines, ::testing::Not(::testing::Contains(::testing::HasSubstr("1970"))));
  const Outcome stats = run(raw + " -T stats");
  EXPECT_THAT(stats.lines,
              ::testing::Contains(::testing::StartsWith("capture         no clock (raw bytes): ")));
  EXPECT_THAT(stats.lines, ::testing::Contains("frames          2"));
}

// A filter of blanks filters nothing, as an empty one does.
TEST(Cli, ABlankFilterFiltersNothing) {
  const Outcome all = run(brainchild);
  const Outcome blank = run(brainchild + " -Y '  '");
  EXPECT_EQ(blank.status, 0);
  EXPECT_EQ(blank.lines, all.lines);
}

// -c N counts records as tshark counts packets: noise too (random bytes read as RTU are nearly
// all noise), time-outs not (modtap makes them; the one before the limit is shown). Reading
// stops at the limit: an endless pipe ends.
TEST(Cli, CountStopsAfterNRecordsNoiseIncluded) {
  const auto random_file = (std::filesystem::temp_directory_path() / "modtap-random.raw").string();
  {
    std::mt19937 random(7);
    std::ofstream out(random_file, std::ios::binary);
    for (int i = 0; i < 2'000'000; ++i) out.put(static_cast<char>(random() & 0xFF));
  }
  const std::string modtap = MODTAP_BINARY;
  const Outcome two =
      run_shell(modtap + " -r " + random_file + " --format raw --mode rtu -c 2 2>/dev/null");
  EXPECT_EQ(two.status, 0);
  ASSERT_EQ(two.lines.size(), 2u);
  EXPECT_THAT(two.lines[0], ::testing::HasSubstr("noise"));
  const Outcome endless = run_shell("timeout 30 sh -c 'cat /dev/urandom | " + modtap +
                                    " -r - --format raw --mode rtu -c 2' 2>/dev/null");
  EXPECT_EQ(endless.status, 0);
  EXPECT_EQ(endless.lines.size(), 2u);

  std::vector<std::string> asked;  // a request timed out, its retry, the retry's time-out
  for (const char* t : {"00.000000", "00.450000"})
    asked.insert(asked.end(), {t, "02 03 01 20 00 01 84 0F"});
  const Outcome retried = run("-r " + hexlog("modtap-limit.log", asked) + " --model 2=n3 -c 2");
  ASSERT_EQ(retried.lines.size(), 3u);
  EXPECT_THAT(retried.lines[1], ::testing::HasSubstr("TIMEOUT request #1"));
}

// --follow: the values of chosen registers over time, by name or address, as the device's
// answers to reads and writes give them: a row a good response.
// A run to a file says what it wrote, and a run -a stopped says which condition did.
TEST(Cli, WriteAndAutostopSayWhatTheyDid) {
  const std::string drives = std::string("-r ") + MODTAP_SAMPLES + "/drives-manual-examples.log";
  const auto file = (std::filesystem::temp_directory_path() / "modtap-said.pcapng").string();
  const Outcome all = run(drives + " -w " + file);
  ASSERT_EQ(all.status, 0);
  EXPECT_THAT(all.lines, ::testing::Contains(::testing::MatchesRegex(
                             "modtap: wrote 29 packets \\([0-9]+ bytes\\) to " + file)));
  const Outcome stopped = run(drives + " -q -a frames:3");
  EXPECT_EQ(stopped.lines, std::vector<std::string>{"modtap: stopped at -a frames:3"});
  const Outcome by_size = run(drives + " -w " + file + " -a filesize:2");
  EXPECT_THAT(by_size.lines, ::testing::Contains("modtap: stopped at -a filesize:2"));
  EXPECT_THAT(run(drives + " -q -c 3 -a frames:5").lines, ::testing::IsEmpty());
}

// Modbus ASCII's characters have 7 data bits: the line's settings and its load say so, unless
// --data-bits says otherwise.
TEST(Cli, AsciiIsSevenDataBitsUnlessTold) {
  const auto capture = (std::filesystem::temp_directory_path() / "modtap-ascii-7e1.log").string();
  std::ofstream(capture) << "2026-11-22 09:00:00.008500:\n3A 30 31 30 33 30 30 30 30 30 30 30 31 "
                            "46 42 0D 0A\n";
  for (const std::string mode : {"", " --mode ascii"})
    EXPECT_THAT(run("-r " + capture + mode + " -T stats").lines,
                ::testing::Contains(::testing::HasSubstr("19200 7E1")))
        << mode;
  EXPECT_THAT(run("-r " + capture + " --data-bits 8 -T stats").lines,
              ::testing::Contains(::testing::HasSubstr("19200 8E1")));
}

// One write of two values past their range is two out-of-range findings in one record: the
// count says two, the first records name the record once.
TEST(Cli, AFindingsFirstRecordsNameEachRecordOnce) {
  const std::string capture =
      raw_capture("modtap-two-out-of-range.bin",
                  {{0x03, 0x10, 0x00, 0x0B, 0x00, 0x02, 0x04, 0x9C, 0x40, 0x9C, 0x40},
                   {0x03, 0x10, 0x00, 0x0B, 0x00, 0x02}});
  const Outcome r = run("-r " + capture + " --model 3=gd20 -T stats");
  ASSERT_EQ(r.status, 0);
  EXPECT_THAT(r.lines, ::testing::Contains(::testing::MatchesRegex(" *out-of-range +2 +#1")))
      << ::testing::PrintToString(r.lines);
  const std::string json = stats_json("-r " + capture + " --model 3=gd20", "modtap-two.json");
  EXPECT_NE(json.find("\"out-of-range\":{\"count\":2,\"severity\":\"warning\",\"first\":[1]}"),
            std::string::npos)
      << json;
}

// --models-dir with a meter that identifies itself by 0010H = 1234H, and `more` of its YAML.
std::string meter_models(const std::string& name, const std::string& more) {
  const auto dir = std::filesystem::temp_directory_path() / name;
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "meter.yaml") << "model: meter\ntitle: A meter\nsource: a test\n"
                                       "identify: {address: 0x0010, value: 0x1234}\n"
                                    << more;
  return " --models-dir " + dir.string();
}

// A pcap of RTU frames (slave + PDU, CRC added), each in a packet of its own at its time in ms.
std::string timed_pcap(const std::string& name,
                       const std::vector<std::pair<int64_t, std::vector<uint8_t>>>& frames) {
  const auto path = (std::filesystem::temp_directory_path() / name).string();
  modtap::captures::PcapChunkWriter writer(path, 147);
  for (auto [t_ms, body] : frames) {
    const uint16_t crc = modtap::crc16(body);
    body.push_back(static_cast<uint8_t>(crc & 0xFF));
    body.push_back(static_cast<uint8_t>(crc >> 8));
    writer.write({0, 1'700'000'000'000'000'000 + t_ms * 1'000'000, body});
  }
  return path;
}

// A slave that identifies itself as a model with a time-out of its own is waited for as long
// as that model says from then on, as a slave given the model with --model is.
TEST(Cli, AnIdentifiedSlaveIsWaitedForAsItsModelSays) {
  const std::string models = meter_models(
      "modtap-meter-models",
      "timeout: {response_ms: 50}\nregisters:\n  - {address: 0x0010, name: meter_id}\n");
  const std::vector<uint8_t> ask{0x05, 0x03, 0x00, 0x10, 0x00, 0x01};
  const std::string path =
      timed_pcap("modtap-meter.pcap", {{0, ask},
                                       {10, {0x05, 0x03, 0x02, 0x12, 0x34}},  // identifies as meter
                                       {300, ask},                            // unanswered
                                       {700, {0x06, 0x03, 0x00, 0x00, 0x00, 0x01}},
                                       {710, {0x06, 0x03, 0x02, 0x00, 0x07}}});
  const Outcome r = run("-r " + path + models + " -Y 'slave == 5'");
  ASSERT_EQ(r.status, 0) << ::testing::PrintToString(r.lines);
  EXPECT_THAT(r.lines, ::testing::Contains(::testing::HasSubstr("identifies as meter")));
  EXPECT_THAT(r.lines, ::testing::Contains(::testing::MatchesRegex(
                           "-  +0\\.35[0-9]+ TIMEOUT request #3 slave 5 .*\\(silence\\)")))
      << ::testing::PrintToString(r.lines);
}

// Read from a file, a slave's rows before it identifies itself are named by the model it
// identifies as, as its rows after are; another slave's rows keep their place in time.
TEST(Cli, CsvNamesASlavesRowsFromBeforeItIdentifiesItself) {
  const std::string models = meter_models("modtap-naming-models",
                                          "registers:\n  - {address: 0x0010, name: meter_id}\n"
                                          "  - {address: 0x0011, name: power, unit: W}\n");
  const std::string path =
      timed_pcap("modtap-naming.pcap",
                 {{0, {0x05, 0x03, 0x00, 0x11, 0x00, 0x01}},
                  {50, {0x05, 0x03, 0x02, 0x00, 0x64}},  // power, before slave 5 says what it is
                  {100, {0x06, 0x03, 0x00, 0x00, 0x00, 0x01}},
                  {150, {0x06, 0x03, 0x02, 0x00, 0x07}},
                  {200, {0x05, 0x03, 0x00, 0x10, 0x00, 0x02}},
                  {250, {0x05, 0x03, 0x04, 0x12, 0x34, 0x00, 0x65}},  // identifies as meter
                  {300, {0x06, 0x03, 0x00, 0x00, 0x00, 0x01}},
                  {350, {0x06, 0x03, 0x02, 0x00, 0x08}}});
  const std::string read = "-r " + path + models;
  const Outcome all = run(read + " -T csv");
  ASSERT_EQ(all.status, 0) << ::testing::PrintToString(all.lines);
  std::vector<std::string> rows;  // without the time column
  for (const std::string& line : all.lines) rows.push_back(line.substr(line.find(',') + 1));
  EXPECT_EQ(rows, (std::vector<std::string>{"slave,address,name,value,unit,raw,text",
                                            "5,0011H,power,100,W,100,", "6,0000H,,7,,7,",
                                            "5,0010H,meter_id,4660,,4660,",
                                            "5,0011H,power,101,W,101,", "6,0000H,,8,,8,"}));
  const Outcome power = run(read + " --follow power");
  ASSERT_EQ(power.lines.size(), 3u) << ::testing::PrintToString(power.lines);
  EXPECT_THAT(power.lines[1], ::testing::EndsWith(",5,0011H,power,100,W,100,"));
  EXPECT_THAT(power.lines[2], ::testing::EndsWith(",5,0011H,power,101,W,101,"));
  // Named with --model, the slave's rows are as they come; a slave 6 given one is not held.
  const Outcome told = run(read + " -T csv --model 5=meter");
  EXPECT_EQ(told.lines, all.lines);
}

// A status register's meaning beside its number; -t ad, the date and time its name promises.
TEST(Cli, CsvGivesAnEnumerationsTextAndTheDateWithTad) {
  const std::string drives = std::string("-r ") + MODTAP_SAMPLES +
                             "/drives-manual-examples.log --model 1=nta5000 --model 2=n3";
  const Outcome status = run(drives + " --follow 2520H");
  ASSERT_EQ(status.status, 0);
  ASSERT_GE(status.lines.size(), 2u);
  EXPECT_THAT(status.lines[1], ::testing::EndsWith(",status,7,,7,\"Run, Reverse, Ready\""))
      << status.lines[1];
  const Outcome dated = run(drives + " --follow 2502H -t ad");
  ASSERT_GE(dated.lines.size(), 2u);
  EXPECT_THAT(dated.lines[1], ::testing::MatchesRegex("2026-11-2[12] [0-9:]{8}\\.061176,1,.*"))
      << dated.lines[1];
}

TEST(Cli, FollowWritesRegisterValuesOverTimeAsCsv) {
  const std::string drives = std::string("-r ") + MODTAP_SAMPLES +
                             "/drives-manual-examples.log --model 1=nta5000 --model 2=n3";
  const Outcome r = run(drives + " --follow output_frequency,2502H");
  ASSERT_EQ(r.status, 0);
  // t counts from the capture's first record, as the text's time column: the first row is an
  // answer, 61 ms after the request that opens the capture.
  EXPECT_EQ(r.lines,
            (std::vector<std::string>{"t,slave,address,name,value,unit,raw,text",
                                      "0.061176,1,2502H,frequency_command,60.00,Hz,6000,",
                                      "0.117207,1,2502H,frequency_command,60.00,Hz,6000,",
                                      "0.170373,1,2524H,output_frequency,60.00,Hz,6000,"}));
  // A filter picks rows; it does not move them in time.
  EXPECT_EQ(run(drives + " --follow output_frequency -Y 'fc == 3'").lines,
            (std::vector<std::string>{"t,slave,address,name,value,unit,raw,text",
                                      "0.170373,1,2524H,output_frequency,60.00,Hz,6000,"}));
  const Outcome all = run(drives + " -T csv");
  EXPECT_GT(all.lines.size(), r.lines.size());
  EXPECT_EQ(run(drives + " --follow ,x").lines,
            std::vector<std::string>{"modtap: --follow: an empty name in \",x\""});
}

// --follow names registers a loaded model knows (any of them without --model: a slave may
// identify itself) or addresses: another name is an error with the closest known name, and a
// register no frame read or wrote is said at the end.
TEST(Cli, FollowRefusesUnknownNamesAndSaysWhatNoFrameTouched) {
  const std::string log = std::string("-r ") + MODTAP_SAMPLES + "/drives-manual-examples.log";
  const Outcome typo = run(log + " --model 1=nta5000 --follow output_frequncy");
  EXPECT_EQ(typo.status >> 8, 2);
  EXPECT_EQ(typo.lines, std::vector<std::string>{
                            "modtap: --follow: no model names a register \"output_frequncy\"; "
                            "did you mean output_frequency?"});
  EXPECT_EQ(run(log + " --follow zzzz").lines,
            std::vector<std::string>{"modtap: --follow: no model names a register \"zzzz\""});
  const Outcome any_model = run(log + " --follow frequency_setting");  // GD20's, slave 3 says
  EXPECT_EQ(any_model.status, 0);
  EXPECT_EQ(any_model.lines.size(), 2u);
  EXPECT_THAT(any_model.lines[1], ::testing::EndsWith(",3,2001H,frequency_setting,50.00,Hz,5000,"));
  const Outcome unseen = run(log + " --model 1=nta5000 --follow output_frequency,2200H,P00.04");
  EXPECT_EQ(unseen.status, 0);
  ASSERT_GE(unseen.lines.size(), 2u);
  EXPECT_EQ(std::vector<std::string>(unseen.lines.end() - 2, unseen.lines.end()),
            (std::vector<std::string>{"modtap: --follow 2200H: no frame read or wrote it",
                                      "modtap: --follow P00.04: no frame read or wrote it"}));
}

// --register-base: registers numbered as mbpoll (1-based) or Modicon (40001) number them, in
// text lines, -V trees, CSV and --follow alike; JSON keeps the wire's address.
TEST(Cli, RegisterBaseNumbersRegistersAsThePlcManualDoes) {
  const std::string drives =
      std::string("-r ") + MODTAP_SAMPLES + "/drives-manual-examples.log --model 1=nta5000 -c 4";
  const std::vector<std::pair<std::string, std::string>> bases{
      {"hex", "2502H"}, {"0", "9474"}, {"1", "9475"}, {"4xxxx", "49475"}};
  for (const auto& [base, written] : bases) {
    const Outcome text = run(drives + " --register-base " + base);
    ASSERT_EQ(text.lines.size(), 4u) << base;
    EXPECT_NE(text.lines[2].find("Write Single Register address=" + written + " value=6000"),
              std::string::npos)
        << text.lines[2];
    const Outcome tree = run(drives + " -V --register-base " + base);
    EXPECT_TRUE(std::any_of(tree.lines.begin(), tree.lines.end(), [&](const std::string& line) {
      return line ==
             "      " + written + " frequency_command \"Frequency command\" = 0x1770 -> 60.00 Hz";
    })) << base;
    const Outcome csv = run(drives + " --register-base " + base + " --follow " + written);
    ASSERT_EQ(csv.lines.size(), 2u) << base;
    EXPECT_EQ(csv.lines[1], "0.061176,1," + written + ",frequency_command,60.00,Hz,6000,");
  }
  EXPECT_NE(run(drives + " --register-base 4xxxx -T json").lines[2].find("\"address\":9474"),
            std::string::npos);
  // Modicon's first digit is the table: coils are 0xxxx.
  const auto coil_write = (std::filesystem::temp_directory_path() / "modtap-coil.raw").string();
  std::ofstream(coil_write, std::ios::binary) << std::string("\x01\x05\x00\x07\xff\x00\x3d\xfb", 8);
  const std::string coils =
      run("-r " + coil_write + " --format raw --register-base 4xxxx").lines.at(0);
  EXPECT_NE(coils.find("address=00008"), std::string::npos) << coils;
}

// A capture from standard input or a pipe reads as the same file does, its format told from
// its first bytes; a capture named without -r too. What a pipe cannot do is said plainly.
TEST(Cli, ReadsStandardInputAndPipesAsTheSameFile) {
  const std::string modtap = MODTAP_BINARY;
  const std::string log = std::string(MODTAP_SAMPLES) + "/drives-manual-examples.log";
  const auto pcapng = (std::filesystem::temp_directory_path() / "modtap-cli-piped.pcapng").string();
  ASSERT_EQ(run("-r " + log + " -w " + pcapng).status, 0);
  for (const std::string& file : {log, pcapng}) {
    const Outcome direct = run("-r " + file + " -T json");
    ASSERT_GT(direct.lines.size(), 10u);
    const Outcome piped = run_shell("cat " + file + " | " + modtap + " -r - -T json 2>&1");
    EXPECT_EQ(piped.status, 0) << file;
    ASSERT_EQ(piped.lines.size(), direct.lines.size()) << file;
    for (size_t i = 0; i < direct.lines.size(); ++i) {
      // The same records; only the channel's name says where they came from.
      std::string line = piped.lines[i];
      const std::string from = "\"channel\":\"standard input\"";
      if (const size_t at = line.find(from); at != std::string::npos)
        line.replace(at, from.size(), "\"channel\":\"" + file + "\"");
      EXPECT_EQ(line, direct.lines[i]) << file << " record " << i;
    }
    EXPECT_EQ(run(file + " -T json").lines, direct.lines) << "named without -r: " << file;
  }
  EXPECT_EQ(run_shell(modtap + " -r - < /dev/null 2>&1").lines,
            std::vector<std::string>{"modtap: standard input: the input is empty"});
  const Outcome twice = run_shell("cat " + log + " | " + modtap + " -r - --baud auto 2>&1");
  EXPECT_EQ(twice.status >> 8, 2);
  ASSERT_FALSE(twice.lines.empty());
  EXPECT_NE(twice.lines[0].find("a pipe can be read only once"), std::string::npos);
}

TEST(Cli, AMissingFileIsAClearErrorAndAnExitStatus) {
  const Outcome r = run("-r /nonexistent/capture.pcap");
  EXPECT_NE(r.status, 0);
  ASSERT_FALSE(r.lines.empty());
  EXPECT_EQ(r.lines.back().rfind("modtap: /nonexistent/capture.pcap: cannot open", 0), 0u)
      << r.lines.back();
}

const std::string brainchild_lines = std::string("-r ") + MODTAP_SAMPLES +
                                     "/brainchild-io-16do.sr --sigrok-channels tx=1,rx=0 "
                                     "--sigrok-invert";

TEST(Cli, AnEmptyFileOrADirectoryIsSaidPlainly) {
  const auto dir = std::filesystem::temp_directory_path() / "modtap-a-directory";
  std::filesystem::create_directories(dir);
  const auto empty = std::filesystem::temp_directory_path() / "modtap-empty.pcap";
  std::ofstream{empty};
  const Outcome on_dir = run("-r " + dir.string());
  EXPECT_EQ(on_dir.status >> 8, 2);
  EXPECT_THAT(on_dir.lines, ::testing::ElementsAre("modtap: " + dir.string() +
                                                   ": is a directory, not a capture file"));
  for (const char* format : {"", " --format raw", " --format pcap"}) {
    const Outcome on_empty = run("-r " + empty.string() + format);
    EXPECT_EQ(on_empty.status >> 8, 2) << format;
    EXPECT_THAT(on_empty.lines,
                ::testing::ElementsAre("modtap: " + empty.string() + ": the file is empty"));
  }
}

// The demo's capture (scripts/demo.sh): its two faulty drives lead the statistics, nothing else.
TEST(Cli, TheDemoCaptureNamesItsTwoFaultyDrivesFirst) {
  const Outcome r =
      run(std::string("-r ") + MODTAP_SAMPLES + "/six-drives-two-faults.pcap -T stats");
  ASSERT_EQ(r.status, 0);
  std::vector<std::string> problems;
  for (const auto& line : r.lines) {
    if (line.empty()) break;
    if (line.rfind("  error", 0) == 0 || line.rfind("  warning", 0) == 0) problems.push_back(line);
  }
  ASSERT_EQ(problems.size(), 2u) << ::testing::PrintToString(r.lines);
  EXPECT_THAT(problems[0], ::testing::StartsWith("  error   Slave 2 went silent 3 times"));
  EXPECT_THAT(problems[1], ::testing::StartsWith("  error   Slave 4 answers in junk every time"));
}

// The demo's drive 2 goes silent three times; drive 4 answers in junk, which is speaking, so
// none of its dropped requests runs into a silence. The list shows what -Y keeps, as every
// other list of the statistics does.
TEST(Cli, OnlyASlaveThatWentSilentIsListedAsStoppedAndTheFilterPicksFromTheList) {
  const std::string demo = std::string("-r ") + MODTAP_SAMPLES + "/six-drives-two-faults.pcap";
  const auto silences = [](const Outcome& r) {
    std::vector<std::string> listed;
    for (const auto& line : r.lines)
      if (line.find(" silent from ") != std::string::npos) listed.push_back(line.substr(0, 11));
    return listed;
  };
  const std::vector<std::string> drive_2(3, "  slave 2  ");
  EXPECT_EQ(silences(run(demo + " -T stats")), drive_2);
  EXPECT_EQ(silences(run(demo + " -T stats -Y 'slave == 2'")), drive_2);
  EXPECT_THAT(silences(run(demo + " -T stats -Y 'slave != 2'")), ::testing::IsEmpty());
  const std::string json = stats_json(demo + " -Y 'slave != 2'", "modtap-demo-filtered.json");
  EXPECT_NE(json.find("\"outage_count\":0,\"outages\":[]"), std::string::npos);
}

// A pcap of one byte a packet, each stamped as it ended, is a clock per byte, and says so; a
// pcap of frames, or of bytes that share their reads' moments, a clock per packet.
TEST(Cli, APcapOfOneByteAPacketIsAClockPerByte) {
  using modtap::busgen::Delivery;
  const auto clock_line = [](const std::string& capture) {
    for (const auto& line : run("-r " + capture + " -T stats").lines)
      if (line.rfind("capture ", 0) == 0) return line.substr(line.find("clock "));
    return std::string();
  };
  EXPECT_EQ(clock_line(faulty_bus("modtap-bytes.pcap", {}, Delivery::per_byte)), "clock per-byte");
  EXPECT_EQ(clock_line(faulty_bus("modtap-frames.pcap", {})),
            "clock per-chunk, a read up to 30 ms late");
  EXPECT_EQ(clock_line(faulty_bus("modtap-frames.pcap", {}) + " --chunk-jitter 8"),
            "clock per-chunk, a read up to 8 ms late");
  // The same bytes, one a packet, but each USB read's bytes stamped a microsecond apart.
  const auto path = (std::filesystem::temp_directory_path() / "modtap-read-bytes.pcap").string();
  {
    const std::vector<uint8_t> read{0x01, 0x03, 0x00, 0x00, 0x00, 0x01, 0x84, 0x0A};
    modtap::captures::PcapChunkWriter writer(path, 147);
    for (int64_t r = 0; r < 8; ++r)
      for (size_t i = 0; i < read.size(); ++i)
        writer.write({0,
                      1'700'000'000'000'000'000 + r * 16'000'000 + static_cast<int64_t>(i) * 1000,
                      {read.data() + i, 1}});
  }
  EXPECT_EQ(clock_line(path), "clock per-chunk, a read up to 30 ms late");
}

// A pcap of one byte a packet read at half its baud: the bytes come twice as fast as 9600
// carries them. That is the problem, first and alone (an absent slave's waits until the
// settings read the bus), in the statistics and in --stats; at the line's baud, the slave's.
TEST(Cli, ReadAtHalfItsBaudACaptureShowsItsSettingsAsTheProblem) {
  const std::string capture =
      faulty_bus("modtap-half-baud.pcap", {"3:absent"}, modtap::busgen::Delivery::per_byte);
  const Outcome half = run("-r " + capture + " --baud 9600 -T stats");
  ASSERT_EQ(half.status, 0);
  ASSERT_GE(half.lines.size(), 3u);
  EXPECT_EQ(half.lines[0], "problems");
  EXPECT_THAT(half.lines[1],
              ::testing::StartsWith("  error   The line's settings look wrong: the bytes "
                                    "arrive faster than 9600 8E1 carries them"));
  EXPECT_THAT(half.lines, ::testing::Not(::testing::Contains(::testing::HasSubstr("Slave 3"))));
  const std::string json = stats_json("-r " + capture + " --baud 9600", "modtap-half-baud.json");
  EXPECT_NE(json.find("\"problems\":[{\"problem\":\"settings-look-wrong\",\"slave\":null,"
                      "\"severity\":\"error\""),
            std::string::npos)
      << json.substr(0, 400);
  const Outcome right = run("-r " + capture + " -T stats");
  ASSERT_GE(right.lines.size(), 2u);
  EXPECT_THAT(right.lines[1], ::testing::HasSubstr("Slave 3 never answers"));
}

TEST(Cli, AWrongBaudGivesNoiseAndAHintNotACrash) {
  const Outcome r = run(brainchild_lines + " --baud 9600 --parity even");
  ASSERT_EQ(r.status, 0);
  size_t noise = 0;
  for (const auto& line : r.lines) noise += line.find(" noise ") != std::string::npos;
  EXPECT_GT(noise, 5u);
  // The hint names the settings that read the capture, as its problem does.
  EXPECT_EQ(r.lines.back(),
            "modtap: hint: only 9% of 119 bytes formed frames with a good check; at 19200 8E1, "
            "100% do: read it with --baud 19200 --parity even");
}

// A logic-analyzer capture of a 19200 8E1 bus decoded at 9600: most of its bytes are junk, and
// the settings that read it are found and named in the problem, in every output, so that a
// report says what to change rather than "check the termination".
TEST(Cli, TheSettingsThatReadACaptureAreNamedInItsSettingsProblem) {
  const Outcome wrong = run(brainchild_lines + " --baud 9600 --parity even -T stats");
  ASSERT_EQ(wrong.status, 0);
  ASSERT_GE(wrong.lines.size(), 3u);
  EXPECT_EQ(wrong.lines[0], "problems");
  // The problem's text, its lines joined again.
  std::string problem = wrong.lines[1];
  for (size_t i = 2; i < wrong.lines.size() && wrong.lines[i].starts_with("          ") &&
                     !wrong.lines[i].starts_with("          advice:");
       ++i)
    problem.append(" ").append(wrong.lines[i], 10);
  EXPECT_THAT(problem, ::testing::HasSubstr("only 9% of 119 bytes form frames with a good check"));
  EXPECT_THAT(problem, ::testing::HasSubstr("good check at 9600 8E1; at 19200 8E1, 100% do: read "
                                            "it with --baud 19200 --parity even"));
  const std::string json =
      stats_json(brainchild_lines + " --baud 9600 --parity even", "modtap-better-settings.json");
  EXPECT_NE(json.find("\"better_baud\":19200"), std::string::npos) << json.substr(0, 600);
  // Read at its own settings, nothing is doubted.
  const Outcome right = run(brainchild_lines + " --baud 19200 --parity even -T stats");
  EXPECT_THAT(right.lines, ::testing::Not(::testing::Contains(::testing::HasSubstr("settings"))));
}

// A hint names the setting the evidence points at: the mode where the other one reads the
// capture, and no baud where the capture has no timing to tell bauds apart.
TEST(Cli, AHintNamesTheSettingTheEvidencePointsAt) {
  const std::string drives = std::string("-r ") + MODTAP_SAMPLES + "/drives-manual-examples.log";
  const Outcome ascii = run(drives + " --mode ascii -q");
  ASSERT_EQ(ascii.status, 0);
  EXPECT_THAT(ascii.lines,
              ::testing::Contains("modtap: hint: the traffic reads as Modbus RTU: try --mode rtu "
                                  "(or auto)"));
  std::vector<std::vector<uint8_t>> junk;
  for (int i = 0; i < 40; ++i) junk.push_back({0x41, 0x42, static_cast<uint8_t>(i), 0x43});
  const std::string untimed = raw_capture("modtap-untimed-junk.raw", junk);
  const Outcome any_baud = run("-r " + untimed + " --format raw --mode rtu --baud auto -q");
  EXPECT_THAT(any_baud.lines,
              ::testing::Contains(::testing::HasSubstr("without timing no baud or parity reads "
                                                       "them otherwise")));
  EXPECT_THAT(any_baud.lines,
              ::testing::Not(::testing::Contains(::testing::HasSubstr("try --baud auto"))));
}

// A logic-analyzer capture read on its first channel, where nothing is: the hint lists the
// capture's channels rather than leaving a silent success.
TEST(Cli, NothingOnTheDefaultSigrokChannelListsTheChannels) {
  const Outcome r =
      run(std::string("-r ") + MODTAP_SAMPLES + "/flowmeter_target_15liter_per_min.sr");
  ASSERT_EQ(r.status, 0);
  EXPECT_EQ(r.lines, std::vector<std::string>{
                         "modtap: hint: nothing was decoded on channel 0, the capture's first; it "
                         "has 0, 1, RXTX, 3, 4, 5, 6, 7: name the lines with --sigrok-channels "
                         "tx=NAME,rx=NAME or bus=NAME"});
}

// Read at half its baud, a bus of quick answers places each answer's start before its request
// ended: the clock says the line is faster than told.
TEST(Cli, AnswersBeforeTheirQuestionsSayTheLineIsFaster) {
  const auto path = (std::filesystem::temp_directory_path() / "modtap-quick-answers.pcap").string();
  {
    modtap::captures::PcapChunkWriter pcap(path, 147);
    const std::vector<uint8_t> request{0x01, 0x03, 0x00, 0x00, 0x00, 0x01, 0x84, 0x0A};
    const std::vector<uint8_t> answer{0x01, 0x03, 0x02, 0x00, 0x07, 0xF9, 0x86};
    // 19200 baud: each answer 1 ms after its request, each packet stamped at its end.
    for (int64_t k = 0; k < 12; ++k) {
      pcap.write({0, 1'700'000'000'000'000'000 + k * 50'000'000, request});
      pcap.write({0, 1'700'000'000'000'000'000 + k * 50'000'000 + 5'000'000, answer});
    }
  }
  const std::string hint =
      "modtap: hint: 12 of 12 answers would begin before their request ended at 9600 8E1; the "
      "line is faster: try --baud auto";
  EXPECT_THAT(run("-r " + path + " --baud 9600 -q").lines, ::testing::Contains(hint));
  EXPECT_THAT(run("-r " + path + " -q").lines, ::testing::IsEmpty());
}

TEST(Cli, BaudAutoFindsTheLinesSettingsAndShowsItsEvidence) {
  const Outcome r = run(brainchild_lines + " --baud auto --parity auto -T stats");
  ASSERT_EQ(r.status, 0);
  ASSERT_GE(r.lines.size(), 3u);
  EXPECT_EQ(r.lines[0], "modtap: settings tried on the capture's start:");
  EXPECT_EQ(r.lines[1], "  * 19200 8E1: 30 of 30 frames good, 100% of 235 bytes");
  bool all_good = false;
  for (const auto& line : r.lines) all_good |= line == "  bad checks    0";
  EXPECT_TRUE(all_good);
}

TEST(Cli, ParityAutoOnALogicAnalyzerCaptureCountsParityErrors) {
  // The flow meter's line is 8N1: under even and odd parity sigrok flags parity errors, which
  // decide between settings whose frames read alike.
  const Outcome r = run(std::string("-r ") + MODTAP_SAMPLES +
                        "/flowmeter_graph_tool.sr --sigrok-channels bus=RXTX --baud 9600 "
                        "--parity auto -T none");
  ASSERT_EQ(r.status, 0);
  EXPECT_THAT(r.lines,
              ::testing::ElementsAre(
                  "modtap: settings tried on the capture's start:",
                  "    9600 8E1: 18 of 18 frames good, 100% of 153 bytes, 111 parity errors",
                  "  * 9600 8N1: 18 of 18 frames good, 100% of 153 bytes",
                  "    9600 8O1: 18 of 18 frames good, 100% of 153 bytes, 42 parity errors"));
}

TEST(Cli, ALogicAnalyzerCaptureThatReadsAsNothingSuggestsInversionAndChannels) {
  const Outcome r = run(std::string("-r ") + MODTAP_SAMPLES +
                        "/brainchild-io-16do.sr --baud 19200 --parity even "
                        "--sigrok-channels tx=1,rx=0 -T none");
  ASSERT_EQ(r.status, 0);
  ASSERT_FALSE(r.lines.empty());
  EXPECT_EQ(r.lines.back().rfind("modtap: hint: no frame had a good check; is the line inverted "
                                 "(try --sigrok-invert), are the channels right",
                                 0),
            0u)
      << r.lines.back();
}

TEST(Cli, BaudAutoOnAnUntimedFileSaysItCannotTell) {
  const std::string capture =
      raw_capture("modtap-untimed.raw", {{0x01, 0x03, 0x00, 0x00, 0x00, 0x01}});
  const Outcome r = run("-r " + capture + " --format raw --baud auto -T none");
  ASSERT_EQ(r.status, 0);
  ASSERT_EQ(r.lines.size(), 1u);
  EXPECT_NE(
      r.lines[0].find("has no timing, so every baud and parity read it alike; using 19200 8E1"),
      std::string::npos)
      << r.lines[0];
}

TEST(Cli, SaveRawKeepsTheReadsToReadAgain) {
  const auto saved = std::filesystem::temp_directory_path() / "modtap-raw.pcapng";
  const Outcome first =
      run(brainchild_lines + " --baud 19200 -T json --save-raw " + saved.string());
  ASSERT_EQ(first.status, 0);
  const Outcome again = run("-r " + saved.string() + " --baud 19200 --mode rtu -T json");
  ASSERT_EQ(again.status, 0);
  auto raws = [](const Outcome& o) {
    std::vector<std::string> out;
    for (const auto& line : o.lines) {
      const auto at = line.find("\"raw\":\"");
      if (at != std::string::npos) out.push_back(line.substr(at, line.find('"', at + 7) - at));
    }
    return out;
  };
  EXPECT_EQ(raws(again), raws(first));
  EXPECT_EQ(raws(first).size(), 30u);
}

TEST(Cli, ModelsListsTheBuiltInModels) {
  const Outcome r = run("models");
  ASSERT_EQ(r.status, 0);
  std::string names;
  for (const auto& line : r.lines) names += line.substr(0, line.find(' ')) + " ";
  EXPECT_EQ(names, "gd20 generic n3 nta5000 nta5000-cn ");
}

TEST(Cli, ModelsCheckReportsTheFileAndLine) {
  const auto path = std::filesystem::temp_directory_path() / "modtap-bad-model.yaml";
  std::ofstream(path) << "model: bad\nregisters:\n  - {address: 0x2502, name: f, unit: [Hz]}\n";
  const Outcome bad = run("models check " + path.string());
  EXPECT_NE(bad.status, 0);
  ASSERT_EQ(bad.lines.size(), 1u);
  EXPECT_EQ(bad.lines[0], path.string() + ":3: expected text");
  const std::string gd20 = std::string(MODTAP_SOURCE) + "/plugins/models/gd20.yaml";
  const Outcome good = run("models check " + gd20);
  EXPECT_EQ(good.status, 0);
  // Several files: each is checked, and one bad file fails the run.
  const Outcome both = run("models check " + gd20 + " " + path.string());
  EXPECT_NE(both.status, 0);
  EXPECT_THAT(both.lines, ::testing::Contains(path.string() + ":3: expected text"));
  EXPECT_THAT(both.lines, ::testing::Contains(::testing::StartsWith(gd20 + ": model gd20")));
}

// A file that extends a model of --models-dir checks against it; a file that cannot be read is
// said and the next one checked, the run failing at the end.
TEST(Cli, ModelsCheckReadsTheModelsDirAndGoesOnPastAnUnreadableFile) {
  const auto dir = std::filesystem::temp_directory_path() / "modtap-check-dir";
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "base.yaml") << "model: mybase\nregisters:\n  - {address: 1, name: a}\n";
  const auto mine = std::filesystem::temp_directory_path() / "modtap-check-mine.yaml";
  std::ofstream(mine) << "model: mine\nextends: mybase\nregisters:\n  - {address: 2, name: b}\n";
  const std::string missing = (dir / "missing.yaml").string();
  const Outcome r =
      run("models check --models-dir " + dir.string() + " " + missing + " " + mine.string());
  EXPECT_EQ(r.status >> 8, 1);
  EXPECT_THAT(r.lines, ::testing::Contains(missing + ": cannot open"));
  EXPECT_THAT(r.lines, ::testing::Contains(::testing::StartsWith(mine.string() + ": model mine")));
}

TEST(Cli, JsonCarriesRegistersOfTheSlavesModel) {
  const std::string capture =
      raw_capture("modtap-models.raw", {{0x01, 0x06, 0x25, 0x02, 0x17, 0x70},
                                        {0x01, 0x06, 0x25, 0x02, 0x17, 0x70},
                                        {0x02, 0x06, 0x25, 0x02, 0x17, 0x70},
                                        {0x02, 0x06, 0x25, 0x02, 0x17, 0x70}});
  const Outcome r = run("-r " + capture + " --format raw --mode rtu --model 1=nta5000 -T json");
  ASSERT_EQ(r.status, 0);
  ASSERT_EQ(r.lines.size(), 4u);
  EXPECT_NE(r.lines[0].find("\"model\":\"nta5000\",\"registers\":[{\"addr\":9474,\"name\":"
                            "\"frequency_command\",\"raw\":6000,\"value\":60.00,\"unit\":\"Hz\","
                            "\"text\":null}]"),
            std::string::npos)
      << r.lines[0];
  EXPECT_NE(r.lines[2].find("\"model\":\"generic\",\"registers\":[{\"addr\":9474,\"name\":null,"
                            "\"raw\":6000,\"value\":6000,\"unit\":null,\"text\":null}]"),
            std::string::npos)
      << r.lines[2];
}

TEST(Cli, TextHighlightsRuleFindingsAndIdentifiesGd20) {
  const std::string capture =
      raw_capture("modtap-gd20.raw", {{0x03, 0x03, 0x21, 0x03, 0x00, 0x01},
                                      {0x03, 0x03, 0x02, 0x01, 0x06},
                                      {0x03, 0x03, 0x80, 0x07, 0x00, 0x01}});
  const Outcome r = run("-r " + capture + " --format raw --mode rtu");
  ASSERT_EQ(r.status, 0);
  ASSERT_GE(r.lines.size(), 3u);
  EXPECT_NE(r.lines[1].find("!! slave 3 identifies as gd20"), std::string::npos) << r.lines[1];
  EXPECT_NE(r.lines[2].find("!! 8007H is the write-only RAM alias of P00.07"), std::string::npos)
      << r.lines[2];
}

TEST(Cli, ModelsDirAddsTheUsersModels) {
  const auto dir = std::filesystem::temp_directory_path() / "modtap-user-models";
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "pump.yaml")
      << "model: pump\nextends: gd20\nregisters:\n"
         "  - {address: 0x3000, name: pump_speed, scale: 0.1, unit: rpm}\n";
  const std::string capture = raw_capture(
      "modtap-pump.raw", {{0x07, 0x03, 0x30, 0x00, 0x00, 0x01}, {0x07, 0x03, 0x02, 0x00, 0x64}});
  const Outcome listed = run("models --models-dir " + dir.string());
  ASSERT_EQ(listed.status, 0);
  ASSERT_EQ(listed.lines.size(), 6u);
  EXPECT_EQ(listed.lines[5].rfind("pump ", 0), 0u) << listed.lines[5];
  const Outcome r = run("-r " + capture + " --format raw --mode rtu --models-dir " + dir.string() +
                        " --model 7=pump");
  ASSERT_EQ(r.status, 0);
  ASSERT_EQ(r.lines.size(), 2u);
  EXPECT_NE(r.lines[1].find("| pump_speed=10.0 rpm"), std::string::npos) << r.lines[1];
}

// One broken file among the user's models is said, naming it, and the good ones stay usable.
TEST(Cli, ABrokenModelFileIsLeftOutAndSaid) {
  const auto dir = std::filesystem::temp_directory_path() / "modtap-broken-models";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "pump.yaml")
      << "model: pump\nextends: gd20\nregisters:\n"
         "  - {address: 0x3000, name: pump_speed, scale: 0.1, unit: rpm}\n";
  std::ofstream(dir / "broken.yaml") << "model: [\n";
  std::ofstream(dir / "orphan.yaml") << "model: orphan\nextends: broken\n";
  const std::string capture = raw_capture(
      "modtap-pump2.raw", {{0x07, 0x03, 0x30, 0x00, 0x00, 0x01}, {0x07, 0x03, 0x02, 0x00, 0x64}});
  const Outcome r = run("-r " + capture + " --format raw --mode rtu --models-dir " + dir.string() +
                        " --model 7=pump");
  ASSERT_EQ(r.status, 0);
  EXPECT_THAT(r.lines,
              ::testing::Contains(::testing::AllOf(
                  ::testing::HasSubstr("modtap: warning: " + (dir / "broken.yaml").string()),
                  ::testing::HasSubstr("left out of --models-dir"))));
  EXPECT_THAT(r.lines, ::testing::Contains(::testing::HasSubstr("extends 'broken'")));
  EXPECT_THAT(r.lines, ::testing::Contains(::testing::HasSubstr("| pump_speed=10.0 rpm")));
  EXPECT_NE(run("models check " + (dir / "broken.yaml").string()).status, 0);
}

// A timed hex log: one "time:" line, then the frame's bytes, per frame.
std::string hexlog(const std::string& name, const std::vector<std::string>& timed_frames) {
  const auto path = std::filesystem::temp_directory_path() / name;
  std::ofstream out(path);
  for (size_t i = 0; i + 1 < timed_frames.size(); i += 2)
    out << "2026-11-22 09:00:" << timed_frames[i] << ":\n" << timed_frames[i + 1] << "\n";
  return path.string();
}

// The sample's first byte is placed 0.3 us before 09:00:00 (its read's stamp less its bytes'
// time); its record prints 09:00:00.000000, and the statistics' header says the same second.
TEST(Cli, TheStatisticsHeaderSaysTheSecondTheFirstRecordPrints) {
  const std::string sample = std::string(MODTAP_SAMPLES) + "/drives-manual-examples.log";
  const Outcome text = run("-r " + sample + " -t ad -c 1");
  ASSERT_EQ(text.status, 0);
  ASSERT_FALSE(text.lines.empty());
  EXPECT_THAT(text.lines[0], ::testing::HasSubstr(" 2026-11-22 09:00:00.000000 "));
  const Outcome stats = run("-r " + sample + " -T stats");
  ASSERT_EQ(stats.status, 0);
  EXPECT_THAT(stats.lines,
              ::testing::Contains(::testing::HasSubstr(" from 2026-11-22 09:00:00 UTC, ")));
}

TEST(Cli, TheDrivesSampleReadsInEachDrivesTerms) {
  const Outcome r = run(std::string("-r ") + MODTAP_SAMPLES +
                        "/drives-manual-examples.log --model 1=nta5000 --model 2=n3");
  ASSERT_EQ(r.status, 0);
  ASSERT_EQ(r.lines.size(), 30u);
  auto line_has = [&](size_t i, const std::string& text) {
    EXPECT_NE(r.lines[i].find(text), std::string::npos) << r.lines[i];
  };
  line_has(3, "| frequency_command=60.00 Hz");
  line_has(9, "!! vendor exception 53H: Data amount error (nta5000)");
  line_has(13, "| frequency_command=50.00 Hz");
  line_has(17, "!! slave 3 identifies as gd20");
  line_has(17, "identifying_code=Goodrive20 vector inverter (0106H)");  // as 7.4.2 writes it
  line_has(19, "| control_command=Forward running (1)");
  line_has(23, "output_torque=-10.0 %");
  line_has(26, "!! P00.01 = 3 is outside 0..2");
  // GD20's 04H is its own "Operation failed", not also Modbus's "Server Device Failure".
  line_has(27, "exception_code=04H  crc ok");
  line_has(27, "!! vendor exception 04H: Operation failed");
  EXPECT_EQ(r.lines[27].find("Failure"), std::string::npos) << r.lines[27];
  // The log ends while the last request waits: unanswered, not a time-out "after 0 ms".
  EXPECT_EQ(r.lines[29],
            "-         0.764953 UNANSWERED request #29 slave 1 Read Holding "
            "Registers: the capture ends 0.000 ms after it");
}

TEST(Cli, N3sErrorExampleIsAResponseWithItsExpectedCrcInWireOrder) {
  // 002, 3.Error code: slave 02, 83H, 52H, CRC printed C0H CDH (that of 01 83 52). A frame
  // whose check fails may have any byte changed, so the model does not read its exception code.
  const std::string log = hexlog("modtap-n3-error.log", {"00.000000", "02 83 52 C0 CD"});
  const Outcome r = run("-r " + log + " --model 2=n3 -V");
  ASSERT_EQ(r.status, 0);
  ASSERT_GE(r.lines.size(), 8u);
  EXPECT_NE(r.lines[0].find("rsp slave 2"), std::string::npos) << r.lines[0];
  EXPECT_NE(r.lines[0].find("crc BAD (expected 30 CD)"), std::string::npos) << r.lines[0];
  EXPECT_EQ(r.lines[0].find("!!"), std::string::npos) << r.lines[0];
  EXPECT_THAT(r.lines, ::testing::Contains("    CRC: C0 CD (bad), expected 30 CD"));
}

TEST(Cli, AResponseCutShortSaysSoInsteadOfAnExpectedCheck) {
  // 6 of the response's 25 bytes, then silence and the master's next request.
  const std::string log =
      hexlog("modtap-cut.log", {"00.000000", "01 03 00 00 00 0a c5 cd", "00.010000",
                                "01 03 14 00 01 00", "00.500000", "01 03 00 00 00 0a c5 cd"});
  const Outcome r = run("-r " + log + " -V");
  ASSERT_EQ(r.status, 0);
  EXPECT_THAT(r.lines, ::testing::Contains(::testing::HasSubstr("crc BAD (cut)  req #1")));
  // Its last bytes are what it held, not a CRC: the value that came is read.
  EXPECT_THAT(r.lines, ::testing::Contains("    CRC: none, the frame was cut before it"));
  EXPECT_THAT(r.lines, ::testing::Contains("    values: [1]"));
}

// N3's manual prints its ASCII exception answer without an LRC (002, the FC03 fault example:
// ":028352" CR LF). Too short for its LRC, it is a cut frame, and every output gives its
// exception code as the 52H that came.
TEST(Cli, AnAsciiFrameEndingBeforeItsLrcIsCutWithTheCodeItHolds) {
  const auto path = std::filesystem::temp_directory_path() / "modtap-n3-ascii-error.raw";
  std::ofstream(path, std::ios::binary) << ":020301200001D9\r\n:028352\r\n";
  const std::string args = "-r " + path.string() + " --mode ascii --model n3";
  const Outcome text = run(args + " -V");
  EXPECT_THAT(text.lines, ::testing::Contains(
                              ::testing::HasSubstr("exception_code=52H  lrc BAD (cut)  req #1")));
  EXPECT_THAT(text.lines, ::testing::Contains("    exception_code: 52H"));
  EXPECT_THAT(text.lines, ::testing::Contains("    LRC: none, the frame was cut before it"));
  const Outcome json = run(args + " -T json");
  ASSERT_EQ(json.lines.size(), 2u);
  EXPECT_THAT(json.lines[1], ::testing::HasSubstr("\"check_value\":null,\"expected_check\":null,"
                                                  "\"damage\":\"cut\",\"exception\":82,"));
  EXPECT_THAT(json.lines[1], ::testing::HasSubstr("\"exception_code\":82"));
}

// A write's answer is the request again. One that comes after the master's time-out (100 ms)
// is the slave's late answer where the master's next request follows it without waiting for an
// answer to it, and the master's retry where its own answer follows.
TEST(Cli, AnEchoAfterTheTimeOutIsTheLateAnswerWhereTheMasterMovesOnAtOnce) {
  const std::string write = "01 06 00 01 00 03 98 0B";
  const std::string late = hexlog("modtap-late-echo.log",
                                  {"00.000000", write, "00.125000", write, "00.130000",
                                   "02 03 00 00 00 01 84 39", "00.140000", "02 03 02 00 05 3C 47"});
  const Outcome moved_on = run("-r " + late + " --timeout 0.1");
  ASSERT_EQ(moved_on.lines.size(), 5u);
  EXPECT_NE(moved_on.lines[1].find("TIMEOUT request #1"), std::string::npos) << moved_on.lines[1];
  EXPECT_NE(moved_on.lines[2].find("rsp slave 1"), std::string::npos) << moved_on.lines[2];
  EXPECT_NE(moved_on.lines[2].find("req #1 120.417 ms [late-response]"), std::string::npos)
      << moved_on.lines[2];
  EXPECT_NE(moved_on.lines[3].find("req slave 2"), std::string::npos) << moved_on.lines[3];
  EXPECT_NE(moved_on.lines[4].find("req #3"), std::string::npos) << moved_on.lines[4];

  const std::string retried =
      hexlog("modtap-retry-echo.log", {"00.000000", write, "00.125000", write, "00.135000", write,
                                       "00.300000", "02 03 00 00 00 01 84 39"});
  const Outcome retry = run("-r " + retried + " --timeout 0.1");
  ASSERT_GE(retry.lines.size(), 4u);
  EXPECT_NE(retry.lines[2].find("req slave 1"), std::string::npos) << retry.lines[2];
  EXPECT_NE(retry.lines[2].find("[retry]"), std::string::npos) << retry.lines[2];
  EXPECT_NE(retry.lines[3].find("rsp slave 1"), std::string::npos) << retry.lines[3];
  EXPECT_NE(retry.lines[3].find("req #2"), std::string::npos) << retry.lines[3];
}

TEST(Cli, AnN3SlaveTimesOutAfterItsManualsTimeUnlessTimeoutSaysOtherwise) {
  // 002, 2.3 "TIME-OUT (400ms) & RETRY (max. : 2 times)": an answer 500 ms late is too late.
  const std::string log = hexlog("modtap-n3-late.log", {"00.000000", "02 03 01 20 00 01 84 0F",
                                                        "00.500000", "02 03 02 00 05 3C 47"});
  const Outcome n3 = run("-r " + log + " --model 2=n3");
  ASSERT_EQ(n3.status, 0);
  ASSERT_EQ(n3.lines.size(), 3u);
  EXPECT_NE(n3.lines[1].find("TIMEOUT request #1 slave 2 Read Holding Registers: no response "
                             "after 400.000 ms"),
            std::string::npos)
      << n3.lines[1];
  // The answer to the request that timed out, late: paired with it, never unsolicited.
  EXPECT_NE(n3.lines[2].find("req #1 495.990 ms [late-response]"), std::string::npos)
      << n3.lines[2];
  const Outcome told = run("-r " + log + " --model 2=n3 --timeout 1");
  ASSERT_EQ(told.lines.size(), 2u);
  // From the end of the request to the start of the answer, each block ending at its stamp.
  EXPECT_NE(told.lines[1].find("req #1 495.990 ms"), std::string::npos) << told.lines[1];
  const Outcome generic = run("-r " + log);  // 1 s by default
  ASSERT_EQ(generic.lines.size(), 2u);
  EXPECT_NE(generic.lines[1].find("req #1"), std::string::npos) << generic.lines[1];
}

TEST(Cli, AThirdRetryIsMoreThanAnN3MasterMakes) {
  std::vector<std::string> asked;
  for (const char* t : {"00.000000", "00.450000", "00.900000", "01.350000"})
    asked.insert(asked.end(), {t, "02 03 01 20 00 01 84 0F"});
  const Outcome r = run("-r " + hexlog("modtap-n3-retries.log", asked) + " --model 2=n3 -T json");
  ASSERT_EQ(r.status, 0);
  ASSERT_EQ(r.lines.size(), 8u);  // four requests, three timed out, the last unanswered
  EXPECT_NE(r.lines[0].find("\"findings\":[]"), std::string::npos) << r.lines[0];
  EXPECT_NE(r.lines[2].find("\"findings\":[\"retry\"]"), std::string::npos) << r.lines[2];
  EXPECT_NE(r.lines[6].find("\"findings\":[\"retry\",\"too-many-retries\"]"), std::string::npos)
      << r.lines[6];
  EXPECT_EQ(r.lines[7].rfind("{\"type\":\"unanswered\",\"request\":4,", 0), 0u) << r.lines[7];
  const Outcome stats =
      run("-r " + hexlog("modtap-n3-retries.log", asked) + " --model 2=n3 -T stats");
  EXPECT_THAT(stats.lines, ::testing::Contains("timeouts        3"));
  EXPECT_THAT(stats.lines, ::testing::Contains("unanswered at end of capture  1"));
}

TEST(Cli, TimeStampsThatGoBackwardsWarnOnceAndGiveNoNegativeLatency) {
  const std::string log = hexlog("modtap-backwards.log", {"00.500000", "02 03 01 20 00 01 84 0F",
                                                          "00.100000", "02 03 02 00 05 3C 47"});
  const Outcome r = run("-r " + log + " -T json");
  ASSERT_EQ(r.status, 0);
  ASSERT_EQ(r.lines.size(), 3u);  // the warning (standard error) and two frames
  EXPECT_THAT(r.lines, ::testing::Contains("modtap: warning: " + log +
                                           ": the time stamps go backwards 1 time; latencies "
                                           "across those steps are not measured"));
  for (const auto& line : r.lines)
    if (line.find("\"role\":\"response\"") != std::string::npos) {
      EXPECT_NE(line.find("\"request\":1,\"latency_us\":null"), std::string::npos) << line;
    }
}

TEST(Cli, ItsOwnPcapngReadsBackToTheSameRecordsOnBothChannels) {
  // A logic-analyzer capture of a split tap: per-byte times, two channels with their roles.
  for (const char* link : {"user", "exported-pdu"}) {
    const auto path =
        std::filesystem::temp_directory_path() / (std::string("modtap-rt-") + link + ".pcapng");
    Outcome first = run(brainchild + " -T json --link " + link + " -w " + path.string());
    const Outcome again = run("-r " + path.string() + " --baud 19200 --parity even -T json");
    ASSERT_EQ(first.status, 0);
    ASSERT_EQ(again.status, 0) << link;
    ASSERT_EQ(first.lines.back(), "modtap: wrote 30 packets (" +
                                      std::to_string(std::filesystem::file_size(path)) +
                                      " bytes) to " + path.string());
    first.lines.pop_back();
    EXPECT_EQ(again.lines, first.lines) << link;
    EXPECT_NE(again.lines[1].find("\"channel\":\"rx:0\""), std::string::npos) << again.lines[1];
  }
}

TEST(Cli, AnUnknownModelIsAClearError) {
  const Outcome r = run(brainchild + " --model nosuch");
  EXPECT_NE(r.status, 0);
  ASSERT_FALSE(r.lines.empty());
  EXPECT_EQ(r.lines.back(), "modtap: no model named 'nosuch' (modtap models lists them)");
}

// Writes that fail: a full disk, a closed pipe, outputs that would destroy the input.

// A raw capture of `n` read requests, big enough to fill pipes and small size limits.
std::string many_requests(const std::string& name, int n) {
  std::vector<std::vector<uint8_t>> bodies;
  for (int i = 0; i < n; ++i)
    bodies.push_back({1, 0x03, static_cast<uint8_t>(i >> 8), static_cast<uint8_t>(i), 0, 1});
  return raw_capture(name, bodies);
}

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  return {std::istreambuf_iterator<char>(in), {}};
}

TEST(Cli, AFullDeviceIsAnErrorNamingTheFileNotASilentSuccess) {
  const std::string capture = many_requests("full-device.raw", 50);
  for (const char* args :
       {" -w /dev/full 2>&1", " -T json 2>&1 >/dev/full", " -T none --save-raw /dev/full 2>&1"}) {
    const Outcome r =
        run_shell(std::string(MODTAP_BINARY) + " -r " + capture + " --baud 9600" + args);
    EXPECT_NE(r.status, 0) << args;
    ASSERT_FALSE(r.lines.empty()) << args;
    const std::string name =
        std::string(args).find(">/dev/full") != std::string::npos ? "standard output" : "/dev/full";
    EXPECT_EQ(r.lines.back(), "modtap: cannot write " + name + ": No space left on device") << args;
  }
}

TEST(Cli, ADiskThatFillsLeavesAPcapngThatReadsUpToItsLastCompleteBlock) {
  const std::string capture = many_requests("disk-fills.raw", 2000);
  const auto cut = (std::filesystem::temp_directory_path() / "disk-fills.pcapng").string();
  // The shell's file-size limit stands in for a full disk: writes past it fail with EFBIG. Its
  // 63 blocks of 512 bytes end inside a packet's block (at 64, the alike packets here ended
  // exactly there).
  const std::string limited = "sh -c 'trap \"\" XFSZ; ulimit -f 63; " + std::string(MODTAP_BINARY) +
                              " -r " + capture + " --baud 9600 -w " + cut + "' 2>&1";
  FILE* pipe = popen(limited.c_str(), "r");
  char message[512] = {};
  const bool said = std::fgets(message, sizeof message, pipe) != nullptr;
  EXPECT_NE(pclose(pipe), 0);
  ASSERT_TRUE(said);
  EXPECT_EQ(std::string(message), "modtap: cannot write " + cut + ": File too large\n");

  const Outcome back = run("-r " + cut + " -T json");
  EXPECT_NE(back.status, 0);  // the file is cut: reading it says so, after its frames
  ASSERT_GT(back.lines.size(), 100u);
  EXPECT_NE(back.lines.back().find("truncated"), std::string::npos) << back.lines.back();
  for (size_t i = 0; i + 1 < back.lines.size(); ++i) {
    ASSERT_EQ(back.lines[i].find("\"check\":\"bad\""), std::string::npos) << back.lines[i];
    ASSERT_EQ(back.lines[i].find("noise"), std::string::npos) << back.lines[i];
  }
}

// A FIFO whose writer sends a few frames and waits: their lines come at once, as from a port,
// not when 64 KiB have gathered or the writer closes.
TEST(Cli, AFifoGivesItsFramesAsTheyComeNotWhenABlockFills) {
  const auto fifo = (std::filesystem::temp_directory_path() / "modtap-slow.fifo").string();
  std::filesystem::remove(fifo);
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const std::string command =
      std::string(MODTAP_BINARY) + " -r " + fifo + " --format raw --baud 9600 2>&1";
  FILE* lines = popen(command.c_str(), "r");
  ASSERT_NE(lines, nullptr);
  const int writer = ::open(fifo.c_str(), O_WRONLY);  // once modtap opens its end
  ASSERT_GE(writer, 0);
  // Two exchanges: with no clock, the bytes after a frame tell where it ends, so the first
  // shows while the second waits for what follows it.
  std::vector<uint8_t> bytes;
  for (int exchange = 0; exchange < 2; ++exchange)
    bytes.insert(bytes.end(), {0x01, 0x03, 0x00, 0x00, 0x00, 0x01, 0x84, 0x0A, 0x01, 0x03, 0x02,
                               0x00, 0x2A, 0x39, 0x9B});
  ASSERT_EQ(::write(writer, bytes.data(), bytes.size()), static_cast<ssize_t>(bytes.size()));
  std::string seen;
  for (int waited = 0; waited < 100 && std::count(seen.begin(), seen.end(), '\n') < 2; ++waited) {
    pollfd ready{fileno(lines), POLLIN, 0};
    if (::poll(&ready, 1, 100) <= 0) continue;
    char part[512];
    const ssize_t n = ::read(fileno(lines), part, sizeof part);
    if (n <= 0) break;
    seen.append(part, static_cast<size_t>(n));
  }
  ::close(writer);
  pclose(lines);
  EXPECT_THAT(seen, ::testing::HasSubstr("req slave 1   Read Holding Registers"));
  EXPECT_THAT(seen, ::testing::HasSubstr("values=[42]  crc ok  req #1"));
}

TEST(Cli, AClosedPipeEndsTheRunWithoutAMessageAndClosesItsFiles) {
  const std::string capture = many_requests("closed-pipe.raw", 20000);
  const auto dir = std::filesystem::temp_directory_path();
  const auto errors = (dir / "closed-pipe.err").string(),
             kept = (dir / "closed-pipe.pcapng").string();
  const std::string command = std::string(MODTAP_BINARY) + " -r " + capture +
                              " --baud 9600 -T json -w " + kept + " 2>" + errors +
                              " | head -1 >/dev/null";
  ASSERT_EQ(std::system(command.c_str()), 0);  // head's status: the pipeline ran
  EXPECT_EQ(read_text(errors), "");
  // The pcapng beside the pipe ends on a whole block: it reads back without an error.
  const Outcome back = run("-r " + kept + " -T none");
  EXPECT_EQ(back.status, 0);
  EXPECT_TRUE(back.lines.empty()) << back.lines[0];
}

TEST(Cli, RefusesOutputsThatWouldOverwriteTheInputOrEachOther) {
  const std::string capture = many_requests("refused.raw", 10);
  const auto size = std::filesystem::file_size(capture);
  const auto other = (std::filesystem::temp_directory_path() / "refused.pcapng").string();
  const std::vector<std::pair<std::string, std::string>> cases{
      {"-w " + capture, "modtap: -w " + capture + " would overwrite the capture being read"},
      {"--save-raw " + capture,
       "modtap: --save-raw " + capture + " would overwrite the capture being read"},
      {"-w " + other + " --save-raw " + other, "modtap: -w and --save-raw both name " + other},
      {"--report " + capture,
       "modtap: --report " + capture + " would overwrite the capture being read"},
      {"--stats " + other + " --report " + other,
       "modtap: --stats and --report both name " + other},
      {"-w - -T text", "modtap: -w - and -T text would both write to standard output"},
      {"-w - -T json", "modtap: -w - and -T json would both write to standard output"},
  };
  for (const auto& [args, message] : cases) {
    const Outcome r = run("-r " + capture + " --baud 9600 " + args);
    EXPECT_EQ(r.status >> 8, 2) << args;
    ASSERT_EQ(r.lines.size(), 1u) << args;
    EXPECT_EQ(r.lines[0], message);
  }
  EXPECT_EQ(std::filesystem::file_size(capture), size);
}

}  // namespace

namespace {

std::string file_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

bool holds(const std::vector<std::string>& lines, const std::string& text) {
  return std::any_of(lines.begin(), lines.end(),
                     [&](const std::string& line) { return line.find(text) != std::string::npos; });
}

}  // namespace

// Where a model gives an exception code its own meaning (GD20's 04H: "Operation failed", not
// "Server Device Failure"), that meaning is the code's name in every output: -V, JSON, the
// pcapng comment the Wireshark plugin shows, and the problem the statistics and the report
// give. Every code of every model's table, each answering a read the master repeats.
TEST(Cli, AModelsMeaningOfAnExceptionCodeIsItsNameInEveryOutput) {
  modtap::tools::ModelCatalog catalog;
  catalog.load_builtin();
  for (const modtap::DeviceModel* model : catalog.all()) {
    if (model->exceptions.empty()) continue;
    std::vector<std::vector<uint8_t>> bodies;
    for (const auto& [code, meaning] : model->exceptions)
      for (int i = 0; i < 5; ++i) {
        bodies.push_back({1, 0x03, 0x00, code, 0x00, 0x01});
        bodies.push_back({1, 0x83, code});
      }
    const std::string capture = raw_capture("modtap-exceptions-" + model->name + ".raw", bodies);
    const std::string pcapng = capture + ".pcapng";
    const std::string with_model = "-r " + capture + " --model " + model->name;
    const Outcome json = run(with_model + " -T json");
    const Outcome verbose = run(with_model + " -V");
    const std::string stats_path = capture + ".json";
    ASSERT_EQ(run(with_model + " -q -w " + pcapng + " --stats " + stats_path).status, 0);
    const std::string comments = file_text(pcapng);
    const std::string stats = file_text(stats_path);
    for (const auto& [code, meaning] : model->exceptions) {
      SCOPED_TRACE(model->name + " exception " + std::to_string(code));
      EXPECT_TRUE(holds(json.lines, "\"exception_code\":" + std::to_string(code) +
                                        ",\"exception_name\":\"" + meaning + "\""));
      EXPECT_TRUE(holds(verbose.lines, "exception_name: \"" + meaning + "\""));
      EXPECT_NE(comments.find("exception_name=\"" + meaning + "\""), std::string::npos);
      EXPECT_NE(stats.find(fmt::format("with exception {:02X}H ({})", code, meaning)),
                std::string::npos);
    }
  }
}

// FC06's echo cut a byte short, the next request's address its missing CRC byte: the span
// is refuted as the answer and so, the same bytes, as the request again; no frame starts
// there, and the bytes are the cut answer.
TEST(Cli, ExplainSaysASpanRefutedInOneRoleIsRefutedInTheOther) {
  const std::string log =
      hexlog("modtap-explain-span.log", {"00.000000", "11 06 00 01 00 03 9A 9B", "00.020000",
                                         "11 06 00 01 00 03 9A 9B 03 00 00 00 01 99 F0"});
  const Outcome r = run("-r " + log + " --explain 2");
  ASSERT_EQ(r.status, 0);
  ASSERT_EQ(r.lines.size(), 20u) << ::testing::PrintToString(r.lines);
  EXPECT_THAT(r.lines[0], ::testing::HasSubstr("crc BAD (cut)"));
  EXPECT_EQ(r.lines[2], "    response, 8 bytes: refuted, -4 bits");
  EXPECT_THAT(r.lines[4], ::testing::StartsWith("       -20  answer-cut-before-request: "));
  EXPECT_THAT(r.lines[7], ::testing::StartsWith("    request, 8 bytes: refuted, the same span"));
  EXPECT_EQ(r.lines[8],
            "  no frame here (0 bits), by 4 bits over the runner-up: the response of 8 bytes");
  // 03 9A and 9A 9B: exception and function codes of no public function.
  EXPECT_EQ(r.lines[9], "  at 2 starts inside it, every reading refuted whatever its end:");
  EXPECT_EQ(r.lines[13],
            "  then, no reading holding, the bytes up to the next good frame or silence were one "
            "piece: the awaited answer, whose structure says 8 bytes; 7 came: cut");
  EXPECT_EQ(r.lines[14],
            "  the matcher read it as a response: its structure fits an answer "
            "and no request");
  EXPECT_EQ(r.lines[15], "  paired with #1, the pending request");
  EXPECT_EQ(r.lines[17], "    #1 bytes 0-7: request, 8 bytes, check ok");
  EXPECT_EQ(r.lines[18], "    #2 bytes 8-14: this record");
  EXPECT_EQ(r.lines[19], "    #3 bytes 15-22: request, 8 bytes, check ok");
}

// A vendor's function code has no length of its own: its end is where a CRC search found one
// and something confirmed it, here the silence before the next request. --explain says which.
TEST(Cli, ExplainSaysWhatConfirmedAnEndACrcSearchFound) {
  const std::string log =
      hexlog("modtap-explain-search.log",
             {"00.000000", "01 41 02 03 10 AD", "00.100000", "01 03 00 00 00 01 84 0A"});
  const Outcome r = run("-r " + log + " --explain 1");
  ASSERT_EQ(r.status, 0);
  ASSERT_GE(r.lines.size(), 5u) << ::testing::PrintToString(r.lines);
  EXPECT_EQ(r.lines[2], "    request, 6 bytes: kept, +16 bits");
  EXPECT_THAT(r.lines[3],
              ::testing::StartsWith("            its end (silence-after): a CRC search"));
  EXPECT_THAT(r.lines[4], ::testing::StartsWith("              confirmed, 8 bits of the search's "
                                                "8: silence-after: "));
  const Outcome known = run("-r " + log + " --explain 2");
  EXPECT_THAT(known.lines, ::testing::Not(::testing::Contains(::testing::HasSubstr("its end ("))));
}

// FC08 Return Query Data has no length of its own either; with junk after it, nothing after its
// end confirms it, and its header does, once nothing more can: --explain names the feature.
TEST(Cli, ExplainSaysAPublicHeaderConfirmedAnEndNothingAfterItDid) {
  const std::string log =
      hexlog("modtap-explain-header-alone.log", {"00.000000", "11 08 00 00 12 34 EF EC A5 5A 3C"});
  ASSERT_EQ(modtap::crc16(std::vector<uint8_t>{0x11, 0x08, 0x00, 0x00, 0x12, 0x34}), 0xECEF);
  const Outcome r = run("-r " + log + " --explain 1");
  ASSERT_EQ(r.status, 0);
  ASSERT_GE(r.lines.size(), 5u) << ::testing::PrintToString(r.lines);
  EXPECT_EQ(r.lines[2], "    request, 8 bytes: kept, +16 bits");
  EXPECT_THAT(r.lines[3],
              ::testing::StartsWith("            its end (header-alone): a CRC search"));
  EXPECT_THAT(r.lines[4], ::testing::StartsWith("              confirmed, 16 bits of the search's "
                                                "8: public-header: "));
}

// A frame found by CRC search whose end has a 0x00 beside it has a runner-up end, and --explain
// weighs it. A vendor frame ending in 0x00 before a silence: one byte shorter would make the
// 0x00 the next driver's glitch, but a glitch comes before a frame, not before a silence, and 8
// bits rule that end out. The same bytes with the next request right behind: the frame one byte
// shorter, confirmed by the 0x00 as a glitch and the request, has the longer end beside it, and
// nothing tells them apart: ambiguous-end.
TEST(Cli, ExplainWeighsAnEndsRunnerUpAndSaysWhenItStands) {
  const std::string apart =
      hexlog("modtap-explain-end-apart.log",
             {"00.000000", "01 41 02 03 10 AD 00", "00.100000", "01 03 00 00 00 01 84 0A"});
  const Outcome ruled_out = run("-r " + apart + " --explain 1");
  ASSERT_EQ(ruled_out.status, 0);
  ASSERT_GE(ruled_out.lines.size(), 8u) << ::testing::PrintToString(ruled_out.lines);
  EXPECT_THAT(ruled_out.lines[0], ::testing::Not(::testing::HasSubstr("ambiguous-end")));
  EXPECT_EQ(ruled_out.lines[2], "    request, 7 bytes: kept, +16 bits");
  EXPECT_EQ(ruled_out.lines[6],
            "            its end's runner-up: the same frame one byte shorter, its last 0x00 the "
            "next driver's glitch");
  EXPECT_THAT(ruled_out.lines[7],
              ::testing::StartsWith("              ruled out, 8 bits: silence-after: "));

  const std::string together =
      hexlog("modtap-explain-end-together.log",
             {"00.000000", "01 41 02 03 10 AD 00 01 03 00 00 00 01 84 0A"});
  const Outcome stands = run("-r " + together + " --explain 1");
  ASSERT_EQ(stands.status, 0);
  ASSERT_EQ(stands.lines.size(), 13u) << ::testing::PrintToString(stands.lines);
  EXPECT_THAT(stands.lines[0], ::testing::HasSubstr("crc ok [ambiguous-end]"));
  EXPECT_EQ(stands.lines[2], "    request, 6 bytes: kept, +16 bits");
  EXPECT_THAT(stands.lines[4], ::testing::StartsWith("              confirmed, 8 bits of the "
                                                     "search's 8: glitch-then-frame: "));
  EXPECT_EQ(stands.lines[6],
            "            its end's runner-up: the same frame one byte longer, the 0x00 after it "
            "its own");
  EXPECT_EQ(stands.lines[7],
            "              stands: nothing in the bytes or their times tells the two apart (0 of "
            "4 bits): ambiguous-end");
  EXPECT_EQ(stands.lines[12], "    #2 bytes 6-6: noise (glitch), 1 byte");
}

// A copy of the pending request is its slave's echo or the master's retry, and --explain says
// what told them apart: 10 ms after the request, too soon for any retry; in a raw file, with
// no clock, nothing: the echo is taken and the retry stands beside it (ambiguous-echo).
TEST(Cli, ExplainSaysWhatToldAnEchoFromARetry) {
  const std::string timed =
      hexlog("modtap-explain-echo.log",
             {"00.000000", "11 06 00 01 00 03 9A 9B", "00.010000", "11 06 00 01 00 03 9A 9B"});
  const Outcome soon = run("-r " + timed + " --explain 2");
  ASSERT_EQ(soon.status, 0);
  EXPECT_THAT(soon.lines, ::testing::Contains(
                              "  a copy of the pending request, taken for the slave's echo; its "
                              "runner-up: the master's retry"));
  EXPECT_THAT(soon.lines, ::testing::Contains(::testing::StartsWith(
                              "              ruled out, 4 bits: too-soon-for-retry: ")));

  const std::string raw =
      raw_capture("modtap-explain-echo.raw",
                  {{0x11, 0x06, 0x00, 0x01, 0x00, 0x03}, {0x11, 0x06, 0x00, 0x01, 0x00, 0x03}});
  const Outcome untimed = run("-r " + raw + " --explain 2");
  ASSERT_EQ(untimed.status, 0);
  ASSERT_FALSE(untimed.lines.empty());
  EXPECT_THAT(untimed.lines[0], ::testing::HasSubstr("[ambiguous-echo]"));
  EXPECT_THAT(untimed.lines,
              ::testing::Contains("              stands: nothing in the bytes or their times tells "
                                  "the two apart (0 of 4 bits): ambiguous-echo"));
}

// --explain says why the matcher gave a frame its role and which request it paired it with:
// an echo is the awaited answer; an answer after a second master's exchange answers the
// request that exchange cut in on; an answer after the master's time-out, the one that timed
// out.
TEST(Cli, ExplainSaysWhyAFrameHasItsRoleAndItsRequest) {
  const std::string log =
      hexlog("modtap-explain-role.log",
             {"00.000000", "11 06 00 01 00 03 9A 9B", "00.010000", "11 06 00 01 00 03 9A 9B",
              "00.100000", "01 03 00 00 00 01 84 0A", "00.108000", "C9 03 01 00 00 01 95 BE",
              "00.116000", "C9 03 02 00 2A D8 4B", "00.124000", "01 03 02 00 07 F9 86"});
  const Outcome echo = run("-r " + log + " --explain 2");
  ASSERT_EQ(echo.status, 0);
  EXPECT_THAT(echo.lines,
              ::testing::Contains("  the matcher read it as a response: of the pending request's "
                                  "slave and function, where its answer is due: that answer"));
  EXPECT_THAT(echo.lines, ::testing::Contains("  paired with #1, the pending request"));
  const Outcome after = run("-r " + log + " --explain 6");
  EXPECT_THAT(after.lines, ::testing::Contains("  the matcher read it as a response: its "
                                               "structure fits an answer and no request"));
  EXPECT_THAT(after.lines,
              ::testing::Contains("  paired with #3, the request another master's request cut in "
                                  "on, set aside while that exchange ran"));
  const Outcome late = run("-r " + log + " --timeout 0.015 --explain 6");
  EXPECT_THAT(late.lines, ::testing::Contains(::testing::StartsWith(
                              "  paired with #3, the request that timed out last")));
}

// --explain answers "why did modtap cut here?". A master's retry of FC07 (`01 07 41 E2`), a
// silence, then a broadcast: the retry and the broadcast's 0x00 pass a CRC as the five-byte
// answer the bus waits for, but a silence lies inside that span and the four bytes before it
// hold their own CRC: 24 bits against the span's 16, so it is refuted and the request, 16 bits
// over no frame at all, is kept.
TEST(Cli, ExplainNamesTheReadingsWeighedAndTheEvidenceThatDecided) {
  const std::string log =
      hexlog("modtap-explain.log", {"00.000000", "01 07 41 E2", "00.300000", "01 07 41 E2",
                                    "00.400000", "00 06 00 10 00 05 49 DD"});
  const Outcome r = run("-r " + log + " --explain 2");
  ASSERT_EQ(r.status, 0);
  ASSERT_EQ(r.lines.size(), 15u) << ::testing::PrintToString(r.lines);
  EXPECT_THAT(r.lines[0], ::testing::MatchesRegex(" +2 +0\\.300000 req slave 1 .*"));
  EXPECT_THAT(r.lines[1], ::testing::HasSubstr("at byte 4 of"));
  EXPECT_EQ(r.lines[2], "    response, 5 bytes: refuted, -8 bits");
  EXPECT_THAT(r.lines[3], ::testing::StartsWith("       +16  crc-holds: "));
  EXPECT_THAT(r.lines[4], ::testing::StartsWith("       -24  good-frame-before-silence: "));
  EXPECT_THAT(r.lines[5], ::testing::StartsWith("               -16  another-crc: "));
  EXPECT_THAT(r.lines[6], ::testing::StartsWith("                -8  silence-inside: "));
  EXPECT_EQ(r.lines[7], "    request, 4 bytes: kept, +16 bits");
  EXPECT_THAT(r.lines[8], ::testing::StartsWith("       +16  crc-holds: "));
  EXPECT_EQ(r.lines[9], "  kept by 16 bits over the runner-up: no frame here (0 bits)");
  EXPECT_EQ(r.lines[10],
            "  the matcher read it as a request: its structure fits a request and no answer");
  EXPECT_EQ(r.lines[11], "  the segmentation around it:");
  EXPECT_EQ(r.lines[12], "    #1 bytes 0-3: request, 4 bytes, check ok");
  EXPECT_EQ(r.lines[13], "    #2 bytes 4-7: this record");
  EXPECT_EQ(r.lines[14], "    #3 bytes 8-15: request, 8 bytes, check ok");
  const Outcome missing = run("-r " + log + " --explain 9");
  EXPECT_NE(missing.status, 0);
  EXPECT_THAT(missing.lines, ::testing::Contains(
                                 ::testing::HasSubstr("--explain 9: " + log + " has no record 9")));
}

// A frame at a reserved address whose span holds a frame a bus carries: `F8 03 0C`, two bytes
// of junk, slave 2's request, and its answer's first four bytes, which pass a CRC as the 17
// bytes slave 248's answer claims (the junk chosen so). The frame inside outweighs it by 2 bits:
// its CRC and public code (18) and the unexpected sender (4) against the span's CRC (16) and
// the junk the frame inside leaves before it (4). --explain prints that sum, the row's features
// with the junk counted for the span.
TEST(Cli, ExplainWeighsAFrameInsideASpanAgainstTheJunkItLeaves) {
  const std::string log = hexlog(
      "modtap-explain-inside.log",
      {"00.000000", "01 03 00 00 00 01 84 0A", "00.010000", "01 03 02 00 01 79 84", "00.300000",
       "F8 03 0C DA B4 02 03 00 00 00 01 84 39", "00.310000", "02 03 02 00 05 3C 47"});
  ASSERT_EQ(modtap::crc16(std::vector<uint8_t>{0xF8, 0x03, 0x0C, 0xDA, 0xB4, 0x02, 0x03, 0x00, 0x00,
                                               0x00, 0x01, 0x84, 0x39, 0x02, 0x03}),
            0x0002);
  const Outcome r = run("-r " + log + " --explain 3");
  ASSERT_EQ(r.status, 0);
  ASSERT_GE(r.lines.size(), 11u) << ::testing::PrintToString(r.lines);
  EXPECT_THAT(r.lines[0], ::testing::HasSubstr("noise 5 bytes (truncated): F8 03 0C DA B4"));
  EXPECT_EQ(r.lines[3], "    response, 17 bytes: refuted, -2 bits");
  EXPECT_THAT(r.lines[5], ::testing::StartsWith("       -18  swallows-known-frame: "));
  EXPECT_THAT(r.lines[6], ::testing::StartsWith("               -16  another-crc: "));
  EXPECT_THAT(r.lines[7], ::testing::StartsWith("                -2  bus-code: "));
  EXPECT_THAT(r.lines[8], ::testing::StartsWith("                -4  unexpected-sender: "));
  EXPECT_THAT(r.lines[9], ::testing::StartsWith("                +4  leaves-junk: "));
  EXPECT_EQ(r.lines[10],
            "  no frame here (0 bits), by 2 bits over the runner-up: the response of "
            "17 bytes");
}

// For a damaged frame, --explain says why no frame was cut inside it: an exception talked over,
// `32 81 03 14 5b`, whose bytes from the second on, the next request and part of its answer
// pass a CRC as a 25-byte answer of slave 129 (the answer's data chosen so). Nobody asked slave
// 129, and that span starts inside the span the exception claims, with no request of its own
// before it: the row unawaited-answer-inside-awaited-answer refutes it by 4 bits.
TEST(Cli, ExplainSaysWhyNoFrameWasCutInsideADamagedOne) {
  const std::string log = hexlog(
      "modtap-explain-damaged.log",
      {"00.000000", "32 01 00 00 00 10 38 05", "00.030000",
       "32 81 03 14 5B 07 03 00 00 00 0A C5 AB 07 03 14 11 11 11 11 11 11 11 11 34 9E 11 11 11 "
       "11 11 11 11 11 11 11 78 2F",
       "00.300000", "01 03 00 00 00 01 84 0A"});
  const Outcome r = run("-r " + log + " --explain 2");
  ASSERT_EQ(r.status, 0);
  ASSERT_GE(r.lines.size(), 12u) << ::testing::PrintToString(r.lines);
  EXPECT_THAT(r.lines[0], ::testing::HasSubstr("crc BAD"));
  EXPECT_EQ(r.lines[3], "  at byte 9, inside it, a span whose length rules and CRC agree:");
  EXPECT_EQ(r.lines[4], "    response, 25 bytes: refuted, -4 bits");
  EXPECT_THAT(r.lines[6],
              ::testing::StartsWith("       -20  unawaited-answer-inside-awaited-answer: "));
  EXPECT_THAT(r.lines[7], ::testing::StartsWith("               -16  awaited-header: "));
  EXPECT_THAT(r.lines[8], ::testing::StartsWith("                -4  unexpected-sender: "));
  EXPECT_EQ(r.lines[9],
            "  no frame here (0 bits), by 4 bits over the runner-up: the response of "
            "25 bytes");
  EXPECT_EQ(r.lines[10], "  at 1 start inside it, every reading refuted whatever its end:");
  EXPECT_EQ(r.lines[14],
            "  then, no reading holding, the bytes up to the next good frame or silence were one "
            "piece: a header whose length rules say these 5 bytes exactly, whose check fails: "
            "corrupted");
}

// A write's answer cut short between a 0x00 and a 0xFF, the next request right behind it: the
// 0x00 is the answering driver's glitch, for the bytes after it begin as the awaited answer; the
// 0xFF is the next sender's, for it cannot be the quantity's high byte of an answer to a write
// of 2 registers. --explain says, for each, what weighed on either reading.
TEST(Cli, ExplainSaysHowTheBytesAtAPiecesEdgesWereRead) {
  const std::string log =
      hexlog("modtap-explain-edges.log",
             {"00.000000", "01 10 00 05 00 02 04 00 0A 01 02 93 C3", "00.030000",
              "00 01 10 00 05 FF 01 03 00 00 00 01 84 0A", "00.040000", "01 03 02 00 2A 39 9B"});
  const Outcome r = run("-r " + log + " --explain 3");
  ASSERT_EQ(r.status, 0);
  ASSERT_FALSE(r.lines.empty());
  EXPECT_THAT(r.lines[0], ::testing::HasSubstr("crc BAD (cut)"));
  const auto has = [&](const std::string& line) {
    EXPECT_THAT(r.lines, ::testing::Contains(line));
  };
  has("  byte 13 (00), the first of the piece, read two ways:");
  has("    the answering driver's glitch, before its answer: +16 bits");
  has("    the piece's own first byte: +0 bits, no feature speaks for it");
  has("  taken for the answering driver's glitch, before its answer, by 16 bits: the runner-up is "
      "ruled out");
  has("  byte 18 (FF), the last of the piece, read two ways:");
  EXPECT_THAT(r.lines, ::testing::Contains(::testing::StartsWith("        +16  byte-ruled-out: ")));
  has("  taken for the next sender's glitch, after the answer, by 16 bits: the runner-up is ruled "
      "out");
  has("    #2 bytes 13-13: noise (glitch), 1 byte");
  has("    #4 bytes 18-18: noise (glitch), 1 byte");
}

// Two pieces whose checks fail, each a frame's length by its header: `F8 41 ...`, a vendor's
// code at a reserved address, and `F9 03 ...`, a read to a reserved address. Only the header
// speaks, and noise needs a lead of 4 bits: the first has 6 (vendor-code, unexpected-sender), the
// second 2 (unexpected-sender against bus-code), so it stays a damaged frame. --explain says so.
TEST(Cli, ExplainSaysWhyAPieceIsNoiseOrADamagedFrame) {
  const std::string log =
      hexlog("modtap-explain-header.log",
             {"00.000000", "01 03 00 00 00 01 84 0A", "00.010000", "01 03 02 00 01 79 84",
              "00.300000", "F8 41 00 00 00 00", "00.400000", "F9 03 00 00 00 01 00 00", "00.500000",
              "01 03 00 00 00 01 84 0A"});
  const Outcome noise = run("-r " + log + " --explain 3");
  ASSERT_EQ(noise.status, 0);
  ASSERT_FALSE(noise.lines.empty());
  EXPECT_THAT(noise.lines[0], ::testing::HasSubstr("noise 6 bytes (junk): F8 41 00 00 00 00"));
  EXPECT_THAT(noise.lines,
              ::testing::Contains("    a damaged frame: +0 bits, no feature speaks for it"));
  EXPECT_THAT(noise.lines, ::testing::Contains("    noise: +6 bits"));
  EXPECT_THAT(noise.lines, ::testing::Contains("  taken for noise, by 6 bits"));
  const Outcome damaged = run("-r " + log + " --explain 4");
  ASSERT_EQ(damaged.status, 0);
  ASSERT_FALSE(damaged.lines.empty());
  EXPECT_THAT(damaged.lines[0], ::testing::HasSubstr("req slave 249 Read Holding Registers"));
  EXPECT_THAT(damaged.lines[0], ::testing::HasSubstr("crc BAD"));
  EXPECT_THAT(damaged.lines, ::testing::Contains("    a damaged frame: +2 bits"));
  EXPECT_THAT(damaged.lines, ::testing::Contains(::testing::StartsWith("         +2  bus-code: ")));
  EXPECT_THAT(damaged.lines, ::testing::Contains("    noise: +4 bits"));
  EXPECT_THAT(damaged.lines, ::testing::Contains("  taken for a damaged frame: noise needs a lead "
                                                 "of 4 bits (it has 2)"));
}

// Inside a damaged answer, a start with a code a bus seldom carries is refuted before its end
// is sought: `0d 06 00 01 30 44 07 03 0d`, a write's answer talked over, holds three (01 30 and
// 30 44, vendor function codes; 03 0d, FC13, no public one), one of them the start of 30 44 07
// and its good CRC. --explain says the row once, with the count.
TEST(Cli, ExplainCountsTheStartsRefutedWhateverTheirEnd) {
  const std::string log =
      hexlog("modtap-explain-vendor.log",
             {"00.000000", "0D 06 00 01 00 05 18 C5", "00.020000", "0D 06 00 01 30 44 07 03 0D",
              "00.300000", "14 03 00 00 00 01 86 CF"});
  const Outcome r = run("-r " + log + " --explain 2");
  ASSERT_EQ(r.status, 0);
  ASSERT_GE(r.lines.size(), 8u) << ::testing::PrintToString(r.lines);
  EXPECT_THAT(r.lines[0], ::testing::HasSubstr("crc BAD (expected CC F5, collision)"));
  EXPECT_EQ(r.lines[4], "  at 3 starts inside it, every reading refuted whatever its end:");
  EXPECT_THAT(r.lines[5],
              ::testing::StartsWith("       -18  vendor-frame-inside-awaited-answer: "));
  EXPECT_THAT(r.lines[6], ::testing::StartsWith("               -16  awaited-header: "));
  EXPECT_THAT(r.lines[7], ::testing::StartsWith("                -2  vendor-code: "));
}

// Unframed bytes leave as records only once the next good frame is found; --explain holds the
// readings of a bounded number of starts, and says so where a record's are gone rather than
// that its first byte started no frame.
TEST(Cli, ExplainSaysWhereTheReadingsOfLongJunkAreNoLongerHeld) {
  const auto junk = (std::filesystem::temp_directory_path() / "modtap-explain-junk.raw").string();
  {
    std::mt19937 random(1);  // its 40,000 bytes hold no frame
    std::ofstream out(junk, std::ios::binary);
    for (int i = 0; i < 40'000; ++i) out.put(static_cast<char>(random() & 0xFF));
  }
  const Outcome first = run("-r " + junk + " --format raw --mode rtu --explain 1");
  ASSERT_EQ(first.status, 0);
  ASSERT_GE(first.lines.size(), 3u) << ::testing::PrintToString(first.lines);
  EXPECT_THAT(first.lines[0], ::testing::HasSubstr("noise 256 bytes"));
  EXPECT_EQ(first.lines[2],
            "    the readings weighed here are no longer held: unframed bytes ran on past the "
            "8192 starts --explain holds");
  const Outcome later = run("-r " + junk + " --format raw --mode rtu --explain 150");
  ASSERT_EQ(later.status, 0);
  EXPECT_THAT(later.lines, ::testing::Contains(::testing::HasSubstr(": no frame (no-good-end: ")));
}

namespace {

// modtap top without a terminal (here a pipe) prints its screen as plain text, the last one
// at the end of a replay, with the numbers -T stats gives.
TEST(Cli, TopWithoutATerminalPrintsItsScreenAsPlainText) {
  const std::string capture = std::string(MODTAP_SAMPLES) + "/drives-manual-examples.log";
  const Outcome top = run("top " + capture + " --speed 100000");
  ASSERT_EQ(top.status, 0);
  const auto title = std::find_if(top.lines.rbegin(), top.lines.rend(), [](const auto& line) {
    return line.rfind("modtap top  ", 0) == 0;
  });
  ASSERT_NE(title, top.lines.rend());
  EXPECT_NE(title->find("end of capture"), std::string::npos) << *title;
  EXPECT_EQ(title->find("q quits"), std::string::npos) << *title;  // no key is read
  const Outcome stats = run("-r " + capture + " -T stats");
  const auto frames = std::find_if(stats.lines.begin(), stats.lines.end(),
                                   [](const auto& line) { return line.rfind("frames ", 0) == 0; });
  ASSERT_NE(frames, stats.lines.end());
  std::istringstream words(*frames);
  std::string word, count;
  words >> word >> count;
  EXPECT_NE((title - 1)->find(" " + count + " frames"), std::string::npos)
      << *(title - 1) << " / " << *frames;
}

TEST(Cli, TopRefusesAnOutputThatWouldDrawOnItsTerminal) {
  const std::string capture = std::string(MODTAP_SAMPLES) + "/drives-manual-examples.log";
  const Outcome refused = run("top -r " + capture + " -T json");
  EXPECT_EQ(refused.status >> 8, 2);
  ASSERT_FALSE(refused.lines.empty());
  EXPECT_NE(refused.lines[0].find("modtap top draws on the terminal"), std::string::npos)
      << refused.lines[0];
}

}  // namespace

namespace discover {

std::array<uint8_t, 4> words_bytes(uint32_t value, bool low_first) {
  const uint32_t v = low_first ? (value << 16 | value >> 16) : value;
  return {static_cast<uint8_t>(v >> 24), static_cast<uint8_t>(v >> 16),
          static_cast<uint8_t>(v >> 8), static_cast<uint8_t>(v)};
}

// A meter that no model names: its voltage in f32 low word first, its energy in u32 high word
// first, a temperature in s16 tenths around freezing, read every second.
std::string meter_capture(const std::string& name) {
  std::vector<std::pair<int64_t, std::vector<uint8_t>>> frames;
  for (int n = 0; n < 30; ++n) {
    frames.push_back({n * 1000, {0x07, 0x04, 0x00, 0x00, 0x00, 0x05}});
    std::vector<uint8_t> answer{0x07, 0x04, 0x0A};
    const float volts = 229.0f + 0.1f * static_cast<float>(n % 7);
    for (const uint8_t b : words_bytes(std::bit_cast<uint32_t>(volts), true)) answer.push_back(b);
    for (const uint8_t b : words_bytes(0x0000FFF0u + 7u * static_cast<uint32_t>(n), false))
      answer.push_back(b);
    const auto tenths = static_cast<uint16_t>(static_cast<int16_t>(-40 + 3 * n));
    answer.push_back(static_cast<uint8_t>(tenths >> 8));
    answer.push_back(static_cast<uint8_t>(tenths));
    frames.push_back({n * 1000 + 20, answer});
  }
  return timed_pcap(name, frames);
}

}  // namespace discover

// From a capture of a meter no model names to named values: discover drafts its model, which
// modtap's own check takes, and the capture read through it shows the voltage as a float in
// the right word order and the energy as one 32-bit number.
TEST(Cli, DiscoverDraftsAModelThatReadsTheBusByName) {
  const std::string capture = discover::meter_capture("modtap-discover-meter.pcap");
  const Outcome summary = run("discover " + capture);
  ASSERT_EQ(summary.status, 0) << ::testing::PrintToString(summary.lines);
  EXPECT_THAT(summary.lines,
              ::testing::Contains(::testing::MatchesRegex(
                  " *input +0000H-0001H +f32, low word first .*V .*high confidence.*voltage.*")))
      << ::testing::PrintToString(summary.lines);
  EXPECT_THAT(summary.lines,
              ::testing::Contains(::testing::HasSubstr("polling program: 1 request a cycle")));
  const auto dir = std::filesystem::temp_directory_path() / "modtap-discover-drafts";
  std::filesystem::remove_all(dir);
  const Outcome wrote = run("discover " + capture + " --out " + dir.string());
  ASSERT_EQ(wrote.status, 0) << ::testing::PrintToString(wrote.lines);
  ASSERT_TRUE(std::filesystem::exists(dir / "slave-7.yaml"));
  EXPECT_EQ(run("models check " + (dir / "slave-7.yaml").string()).status, 0);
  const Outcome read = run("-r " + capture + " --models-dir " + dir.string() +
                           " --model 7=slave-7 -T json -Y 'role == response'");
  ASSERT_EQ(read.status, 0) << ::testing::PrintToString(read.lines);
  ASSERT_FALSE(read.lines.empty());
  const std::string& first = read.lines.front();
  EXPECT_NE(first.find("\"voltage_ir_0000\""), std::string::npos) << first;
  EXPECT_NE(first.find("229"), std::string::npos) << first;
  EXPECT_NE(first.find(std::to_string(0x0000FFF0)), std::string::npos) << first;
  EXPECT_NE(first.find("\"temperature_ir_0004\",\"raw\":65496,\"value\":-4.0,\"unit\":\"°C\""),
            std::string::npos)
      << first;
}
