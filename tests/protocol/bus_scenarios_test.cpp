// Thousands of simulated transactions through every adapter delivery model: the analyzer
// must find exactly the frames that were sent, with their roles and pairs, and keep every byte.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cinttypes>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <fstream>
#include <map>
#include <set>
#include <stdexcept>

#include <filesystem>
#include <iostream>
#include <iterator>

#include <unistd.h>

#include "captures/hexlog_writer.hpp"
#include "captures/open_capture.hpp"
#include "captures/pcap_chunk_writer.hpp"
#include "captures/pcapng_writer.hpp"
#include "decoder/protocol/analyzer.hpp"
#include "output/pcapng_sink.hpp"
#include "tests/support/collector.hpp"
#include "tools/busgen/bus_simulator.hpp"

namespace modtap {
namespace {

using busgen::BusCapture;
using busgen::BusOptions;
using busgen::Delivery;
using testing::Collector;

// How the traffic reaches the analyzer: handed over directly, or written to a file that
// modtap's own reader then reads back.
enum class Via { direct, pcap, hexlog };

struct Scenario {
  const char* name;
  Delivery delivery;
  BusOptions bus;
  // Junk and broken frames with no timing to cut them off can hide a neighbour; where the
  // source has no per-byte clock the few such frames are counted, not excused silently.
  size_t max_missing = 0;
  Via via = Via::direct;
  busgen::ClockError clock{};
  // modtap is told the master's time-out (--timeout), as a user who knows it sets it; else it
  // waits its own second.
  bool told_timeout = false;
};

void PrintTo(const Scenario& s, std::ostream* os) {
  *os << s.name;
}

constexpr int64_t file_epoch_ns = 1'700'000'000'000'000'000;

// A scenario's temporary file: named by the scenario, and by the process, so that two test runs
// on one machine (a developer's beside CI's, or shards) never read each other's.
std::string temp_path(const std::string& stem, const char* extension) {
  return (std::filesystem::temp_directory_path() /
          (stem + "-" + std::to_string(getpid()) + extension))
      .string();
}

// Writes the delivered chunks as the scenario's file format and returns the path.
std::string write_file(const BusCapture& capture, const Scenario& s) {
  const auto path =
      temp_path(std::string("modtap-scenario-") + s.name, s.via == Via::pcap ? ".pcap" : ".log");
  const auto chunks = busgen::deliver(capture, s.delivery, s.bus.seed, s.clock);
  auto chunk_at = [&](const busgen::DeliveredChunk& c) {
    return Chunk{0, file_epoch_ns + c.t_ns, {capture.bytes.data() + c.offset, c.size}};
  };
  if (s.via == Via::pcap) {
    captures::PcapChunkWriter writer(path, 147);
    for (const auto& c : chunks) writer.write(chunk_at(c));
  } else {
    captures::HexlogWriter writer(path);
    for (const auto& c : chunks) writer.write(chunk_at(c));
  }
  return path;
}

// Passes every record to a collector and, when given, to one more sink.
class Tee final : public RecordSink {
 public:
  Tee(RecordSink& first, RecordSink* second) : first_(first), second_(second) {}
  void on_frame(const Frame& f) override {
    first_.on_frame(f);
    if (second_) second_->on_frame(f);
  }
  void on_noise(const Noise& n) override {
    first_.on_noise(n);
    if (second_) second_->on_noise(n);
  }
  void on_timeout(const Timeout& t) override {
    first_.on_timeout(t);
    if (second_) second_->on_timeout(t);
  }

 private:
  RecordSink& first_;
  RecordSink* second_;
};

Collector run(const BusCapture& capture, const Scenario& s, RecordSink* also = nullptr,
              FramingObserver* observer = nullptr) {
  AnalyzerOptions options;
  options.mode = ModeChoice::automatic;
  options.format = s.bus.format;
  options.framing_observer = observer;
  if (s.told_timeout) options.timeout_ns = s.bus.retry_after_ns;
  options.timeout_told = s.told_timeout;
  Collector collected;
  Tee out(collected, also);
  if (s.via == Via::direct) {
    options.clock = busgen::clock_of(s.delivery);
    Analyzer analyzer(options, {{"bus", ChannelRole::bus}}, out);
    for (const auto& c : busgen::deliver(capture, s.delivery, s.bus.seed, s.clock))
      analyzer.push({0, c.t_ns, {capture.bytes.data() + c.offset, c.size}});
    analyzer.finish();
    return collected;
  }
  const std::string path = write_file(capture, s);
  captures::OpenOptions open;
  open.serial = s.bus.format;
  auto source = captures::open_capture(path, open);
  options.clock = source->clock();
  Analyzer analyzer(options, source->channels(), out);
  Chunk chunk;
  while (source->next(chunk)) analyzer.push(chunk);
  analyzer.finish();
  // MODTAP_KEEP_CAPTURES keeps the file, to read a failing seed with `modtap --explain`.
  if (!std::getenv("MODTAP_KEEP_CAPTURES")) std::filesystem::remove(path);
  return collected;
}

std::string context(const BusCapture& capture, const Collector& out, uint64_t offset) {
  std::string text;
  for (const auto& r : out.stream()) {
    if (r.offset + r.raw.size() + 40 < offset || r.offset > offset + 60) continue;
    text += "\n  ";
    text += r.type == testing::Record::Type::frame ? (r.check_ok ? "frame" : "BAD") : "noise";
    text += " @";
    text += std::to_string(r.offset);
    text += ":";
    for (uint8_t b : r.raw) text.append(" ").append(std::to_string(b));
  }
  text += "\n  sent:";
  for (const auto& f : capture.frames) {
    if (f.offset + f.size + 40 < offset || f.offset > offset + 60) continue;
    text += "\n  @" + std::to_string(f.offset) + ": " + std::to_string(f.size) + " bytes, " +
            std::string(to_string(f.role)) + ", damage " + std::string(to_string(f.damage)) +
            ", findings " + std::to_string(f.findings) + ", ends at " +
            std::to_string(capture.end_ns[f.offset + f.size - 1] / 1000) + " us";
  }
  return text;
}

class BusScenario : public ::testing::TestWithParam<Scenario> {};

// Bytes that are no frame: junk bursts, requests broken off, answers at another baud rate.
bool sends_no_junk(const BusOptions& bus) {
  return bus.noise_rate == 0 && bus.truncation_rate == 0 && bus.garbled_rate == 0 &&
         bus.noise_burst_period_ns == 0;
}

// The pcapng modtap writes reads back to the same records: frames, noise, roles, pairs,
// findings, and time to the nanosecond (docs/pcapng.md, "Reading it back").
TEST_P(BusScenario, WrittenAsPcapngReadsBackToTheSameRecords) {
  const Scenario& s = GetParam();
  const BusCapture capture = busgen::simulate(s.bus);
  const auto path = temp_path(std::string("modtap-round-") + s.name, ".pcapng");
  Collector first;
  {
    const std::vector<ChannelInfo> channels{{"bus", ChannelRole::bus}};
    captures::PcapngWriter writer(path);
    output::PcapngOptions options;
    // As main does: the clock of the source (pcap and hex log files time each packet).
    options.clock = s.via == Via::direct ? busgen::clock_of(s.delivery) : ClockQuality::per_chunk;
    options.char_ns = s.bus.format.char_time_ns();  // a record lasting its bytes says no duration
    output::PcapngSink sink(writer, channels, options);
    first = run(capture, s, &sink);
    writer.close();
  }
  captures::OpenOptions open;
  open.serial = s.bus.format;
  auto source = captures::open_capture(path, open);
  AnalyzerOptions options;
  options.mode = ModeChoice::automatic;
  options.format = s.bus.format;
  options.clock = source->clock();
  if (s.told_timeout) options.timeout_ns = s.bus.retry_after_ns;
  options.timeout_told = s.told_timeout;
  Collector again;
  Analyzer analyzer(options, source->channels(), again);
  Chunk chunk;
  while (source->next(chunk)) analyzer.push(chunk);
  analyzer.finish();
  // MODTAP_KEEP_CAPTURES keeps the file, to read a failing seed with `modtap --explain`.
  if (!std::getenv("MODTAP_KEEP_CAPTURES")) std::filesystem::remove(path);

  ASSERT_EQ(again.records.size(), first.records.size());
  for (size_t i = 0; i < first.records.size(); ++i) {
    const auto &a = first.records[i], &b = again.records[i];
    ASSERT_EQ(b.type, a.type) << i;
    EXPECT_EQ(b.offset, a.offset) << i;
    EXPECT_EQ(b.raw, a.raw) << i;
    EXPECT_EQ(b.role, a.role) << i;
    EXPECT_EQ(b.check_ok, a.check_ok) << i;
    EXPECT_EQ(b.damage, a.damage) << i;
    // A packet has one time: a pause inside a frame is in its comment for Wireshark, but
    // reading the file again cannot time it.
    EXPECT_EQ(b.findings, a.findings & ~finding_gap_in_frame) << i;
    EXPECT_EQ(b.request, a.request) << i;
    EXPECT_EQ(b.latency_ns, a.latency_ns) << i;
    EXPECT_EQ(b.t_ns, a.t_ns) << i;
    EXPECT_EQ(b.reason, a.reason) << i;
    EXPECT_EQ(b.timeout_reason, a.timeout_reason) << i;
    if (::testing::Test::HasFailure()) break;
  }
}

// How the records of one run differ from what the simulator sent: each count, and the first
// few of each kind with the records and the frames sent around them.
struct Differences {
  size_t bytes_lost = 0;    // bytes the records do not give back as they came
  size_t bad_verdicts = 0;  // a frame whose check verdict is not its CRC's
  size_t missing = 0, wrong_role = 0, wrong_pair = 0, wrong_damage = 0, wrong_findings = 0,
         false_frames = 0, invented = 0, clashes_misread = 0, timeouts_differ = 0;
  std::vector<std::string> examples;

  // Counts one more in `count`, and keeps what `example` says of the first few: saying it
  // walks the records around it, too dear for every one.
  template <typename Example>
  void note(size_t& count, Example example) {
    if (++count <= 3) examples.push_back(example());
  }
  // "missing 1, wrong role 2", or empty where the records are the truth.
  std::string summary() const {
    std::string text;
    const std::pair<const char*, size_t> counts[] = {{"bytes lost", bytes_lost},
                                                     {"bad verdicts", bad_verdicts},
                                                     {"missing", missing},
                                                     {"wrong role", wrong_role},
                                                     {"wrong pair", wrong_pair},
                                                     {"wrong damage", wrong_damage},
                                                     {"wrong findings", wrong_findings},
                                                     {"false frames", false_frames},
                                                     {"invented", invented},
                                                     {"clashes misread", clashes_misread},
                                                     {"time-outs differ", timeouts_differ}};
    for (const auto& [name, count] : counts)
      if (count)
        text += (text.empty() ? "" : ", ") + std::string(name) + " " + std::to_string(count);
    return text;
  }
};

// The records' frames, by offset.
struct RecordIndex {
  std::map<uint64_t, const testing::Record*> frames, noise;
  explicit RecordIndex(const Collector& out) {
    for (const auto& r : out.records) {
      if (r.type == testing::Record::Type::frame) frames[r.offset] = &r;
      if (r.type == testing::Record::Type::noise) noise[r.offset] = &r;
    }
  }

  // A frame that says its last byte may be a glitch is found at the other reading too: one
  // byte short with that byte as a glitch after it, or one byte long ending in 0x00/0xFF.
  bool other_reading(const testing::Record& r, const busgen::TruthFrame& truth) const {
    if (!(r.findings & finding_ambiguous_end)) return false;
    const uint64_t size = r.raw.size();
    if (size + 1 == truth.size) {  // the byte it lacks leads the noise after it
      const auto glitch = noise.find(truth.offset + size);
      return glitch != noise.end() && (r.check_ok || glitch->second->raw.size() == 1);
    }
    return size == truth.size + 1 && (r.raw.back() == 0x00 || r.raw.back() == 0xFF);
  }
  // A response cut one byte short whose missing byte the next driver's glitch repeats puts the
  // whole response on the wire, byte for byte (1 cut in 512): found as the good frame it reads.
  static bool made_whole(const testing::Record& r, const busgen::TruthFrame& truth) {
    return truth.damage == Damage::cut && r.check_ok && r.raw.size() == truth.size + 1 &&
           r.damage == Damage::none;
  }
  const testing::Record* found(const busgen::TruthFrame& truth) const {
    auto it = frames.find(truth.offset);
    if (it == frames.end()) return nullptr;
    const testing::Record& r = *it->second;
    if (made_whole(r, truth)) return &r;
    if (r.raw.size() != truth.size && !other_reading(r, truth)) return nullptr;
    if (r.check_ok == (truth.damage != Damage::none)) return nullptr;
    return &r;
  }
};

// The sent frames: each found, with its role, pair, damage and findings.
void compare_frames(const BusCapture& capture, const Collector& out, const RecordIndex& records,
                    std::vector<uint64_t>& index_of, Differences& d) {
  for (size_t i = 0; i < capture.frames.size(); ++i) {
    const auto& truth = capture.frames[i];
    auto where = [&] {
      return "frame " + std::to_string(i) + " at offset " + std::to_string(truth.offset) +
             " size " + std::to_string(truth.size);
    };
    auto around = [&] { return context(capture, out, truth.offset); };
    const testing::Record* got = records.found(truth);
    if (!got) {
      d.note(d.missing, [&] { return where() + " not found" + around(); });
      continue;
    }
    index_of[i] = got->index;
    // Where nothing can tell a retry from an echo, a frame that says so stands at either role.
    const bool said_ambiguous = got->findings & finding_ambiguous_echo;
    if (got->role != truth.role && !said_ambiguous)
      d.note(d.wrong_role, [&] { return where() + " has the wrong role" + around(); });
    // A response made whole carries a whole answer's damage and findings; a frame found at its
    // other reading, that reading's damage (cut one byte short, run on one byte long).
    const bool whole = RecordIndex::made_whole(*got, truth);
    if (!whole && got->raw.size() == truth.size && got->damage != truth.damage)
      d.note(d.wrong_damage, [&] { return where() + " has the wrong damage" + around(); });
    if (truth.request && got->request != index_of[*truth.request] && !said_ambiguous)
      d.note(d.wrong_pair, [&] { return where() + " paired wrongly" + around(); });
    // A retry merged into one read with its original cannot be timed; counted like a miss.
    const uint32_t knowable = said_ambiguous ? truth.findings & ~finding_retry : truth.findings;
    if (!whole && (got->findings & knowable) != knowable)
      d.note(d.wrong_findings, [&] {
        return where() + " lacks findings " + std::to_string(truth.findings) + around();
      });
  }
}

// Two devices answering over each other put one damaged answer on the wire, from the first
// start bit to the last stop bit: one record, the answer's (a damaged frame paired with its
// request, or where its header is garbled too, noise that says it is that slave's answer), and
// nothing else starts inside it.
void compare_clashes(const BusCapture& capture, const Collector& out, const RecordIndex& records,
                     const std::vector<uint64_t>& index_of, Differences& d) {
  std::map<uint64_t, const testing::Record*> record_at = records.noise;
  record_at.insert(records.frames.begin(), records.frames.end());
  std::set<uint64_t> sent_at;
  for (const auto& f : capture.frames) sent_at.insert(f.offset);
  for (const busgen::Clash& clash : capture.clashes) {
    if (sent_at.count(clash.offset)) continue;  // begun within one bit: a frame of the truth
    const auto it = record_at.find(clash.offset);
    const testing::Record* r = it == record_at.end() ? nullptr : it->second;
    const auto& request = capture.frames[clash.request];
    const bool one_answer =
        r && r->raw.size() == clash.size &&
        (r->type == testing::Record::Type::noise
             ? r->damaged_answer && r->device == request.slave
             : !r->check_ok && r->role == Role::response && r->request == index_of[clash.request]);
    const auto next = record_at.upper_bound(clash.offset);
    const bool nothing_inside = next == record_at.end() || next->first >= clash.offset + clash.size;
    if (!one_answer || !nothing_inside)
      d.note(d.clashes_misread, [&] {
        return std::string("the answers clashing at offset " + std::to_string(clash.offset) + " (" +
                           std::to_string(clash.size) + " bytes) are not one answer of slave " +
                           std::to_string(request.slave) + context(capture, out, clash.offset));
      });
  }
}

// Good frames where none was sent, and bad ones where neither a frame nor a clash was.
void compare_extra_frames(const BusCapture& capture, const Collector& out,
                          const RecordIndex& records, const Scenario& s, Differences& d) {
  std::map<uint64_t, const busgen::TruthFrame*> truth_at;
  for (const auto& f : capture.frames) truth_at[f.offset] = &f;
  std::set<uint64_t> clash_at, garbled_at;
  for (const busgen::Clash& clash : capture.clashes) clash_at.insert(clash.offset);
  garbled_at.insert(capture.garbled.begin(), capture.garbled.end());
  for (const auto& [offset, r] : records.frames) {
    const auto truth = truth_at.find(offset);
    const bool sent_good = truth != truth_at.end() && truth->second->damage == Damage::none;
    const bool whole = truth != truth_at.end() && RecordIndex::made_whole(*r, *truth->second);
    if (r->check_ok && !sent_good && !whole)
      d.note(d.false_frames, [&] {
        return std::string("false frame at offset " + std::to_string(offset) +
                           context(capture, out, offset));
      });
    // What runs on past a collided answer is the other talker's, never a request to a slave
    // of its own. Junk itself may read as a damaged frame of its header: only where no junk
    // was sent is a bad frame counted (a garbled answer's junk is known by its start).
    if (!r->check_ok && truth == truth_at.end() && !clash_at.count(offset) &&
        !garbled_at.count(offset) && sends_no_junk(s.bus))
      d.note(d.invented, [&] {
        return std::string("bad frame where none was sent, at offset " + std::to_string(offset) +
                           context(capture, out, offset));
      });
  }
}

Differences compare_with_truth(const BusCapture& capture, const Collector& out, const Scenario& s) {
  Differences d;
  if (out.bytes_of(0) != capture.bytes)
    d.note(d.bytes_lost, [&] { return std::string("byte conservation"); });
  // A frame's verdict is its check, whatever was around it: a CRC that holds is never bad.
  for (const auto& r : out.records) {
    if (r.type != testing::Record::Type::frame || s.bus.mode != Mode::rtu ||
        r.damage == Damage::cut)
      continue;
    if (r.check_ok != (r.expected_check == (r.raw[r.raw.size() - 2] | r.raw.back() << 8)))
      d.note(d.bad_verdicts,
             [&] { return std::string("the check verdict of frame " + std::to_string(r.index)); });
  }
  const RecordIndex records(out);
  std::vector<uint64_t> index_of(capture.frames.size(), 0);
  compare_frames(capture, out, records, index_of, d);
  compare_clashes(capture, out, records, index_of, d);
  compare_extra_frames(capture, out, records, s, d);
  if (d.missing) return d;  // a lost request also changes which time-outs are seen
  std::set<uint64_t> timed_out, expected, differ;
  for (const auto& t : out.timeouts()) timed_out.insert(*t.request);
  for (size_t i : capture.timed_out) expected.insert(index_of[i]);
  std::set_symmetric_difference(timed_out.begin(), timed_out.end(), expected.begin(),
                                expected.end(), std::inserter(differ, differ.begin()));
  for (const uint64_t request : differ)
    d.note(d.timeouts_differ, [&] {
      const auto& stream = out.stream();
      const auto r = std::find_if(stream.begin(), stream.end(),
                                  [&](const testing::Record& x) { return x.index == request; });
      return std::string("request record " + std::to_string(request) +
                         (timed_out.count(request) ? " timed out, in truth not"
                                                   : " did not time out, in truth did")) +
             (r == stream.end() ? "" : context(capture, out, r->offset));
    });
  return d;
}

TEST_P(BusScenario, FindsExactlyTheFramesSentWithRolesAndPairs) {
  const Scenario& s = GetParam();
  const BusCapture capture = busgen::simulate(s.bus);
  const Differences d = compare_with_truth(capture, run(capture, s), s);
  EXPECT_EQ(d.bytes_lost, 0u);
  EXPECT_EQ(d.bad_verdicts, 0u);
  EXPECT_EQ(d.clashes_misread, 0u);
  // Where the clock cannot see a turnaround, a response cut one byte short and the next
  // frame's glitch complete a good CRC 1 time in 256: counted with the misses.
  for (const size_t count : {d.missing, d.wrong_role, d.wrong_damage, d.false_frames, d.invented})
    EXPECT_LE(count, s.max_missing);
  EXPECT_LE(d.wrong_pair, d.missing + s.max_missing);
  EXPECT_LE(d.wrong_findings, s.max_missing);
  EXPECT_EQ(d.timeouts_differ, 0u);
  if (::testing::Test::HasFailure())
    for (const std::string& example : d.examples) ADD_FAILURE() << example;
}

BusOptions clean(uint64_t seed, size_t n = 3000) {
  BusOptions o;
  o.seed = seed;
  o.transactions = n;
  return o;
}

BusOptions rough(uint64_t seed) {
  BusOptions o = clean(seed, 2000);
  o.glitch_rate = 0.05;
  o.noise_rate = 0.03;
  o.truncation_rate = 0.03;
  return o;
}

BusOptions ascii(uint64_t seed) {
  BusOptions o = clean(seed, 1000);
  o.mode = Mode::ascii;
  o.format = {9600, 7, Parity::even, 1};
  return o;
}

BusOptions fast(uint64_t seed) {
  BusOptions o = clean(seed);
  o.format = {115200, 8, Parity::none, 1};
  o.fast_turnaround_rate = 0.8;
  return o;
}

BusOptions vendor_codes(uint64_t seed) {
  BusOptions o = clean(seed, 1000);
  o.unknown_function_rate = 0.05;
  return o;
}

// What real masters and buses do: requests over the limits, retries after silent slaves (every
// echo code among them), responses cut short or talked over, and a glitch at most turnarounds.
BusOptions real_masters(uint64_t seed) {
  BusOptions o = clean(seed, 3000);
  o.out_of_spec_rate = 0.05;
  o.no_response_rate = 0.08;
  o.retry_rate = 0.7;
  o.cut_rate = 0.03;
  o.collision_rate = 0.03;
  o.glitch_rate = 0.5;
  o.request_glitch_rate = 0.5;
  return o;
}

BusOptions glitch_every_turnaround(uint64_t seed) {
  BusOptions o = clean(seed, 3000);
  o.glitch_rate = o.request_glitch_rate = 1.0;
  return o;
}

// Senders that pause inside frames, and slaves that answer in junk (at another baud rate):
// where each byte has its time, every pause is seen and no frame is lost to the junk.
BusOptions faulty_senders(uint64_t seed) {
  BusOptions o = clean(seed, 3000);
  o.pause_rate = 0.05;
  o.garbled_rate = 0.05;
  o.glitch_rate = o.request_glitch_rate = 0.2;
  return o;
}

// FC15 Write File Record answers as long as their requests (up to 250 bytes), at 115200 baud:
// through a 16 ms adapter an echo spans reads, and its duration is as long as a turnaround.
BusOptions long_echoes(uint64_t seed) {
  BusOptions o = real_masters(seed);
  o.transactions = 1000;
  o.format = {115200, 8, Parity::none, 1};
  o.long_file_records = true;
  return o;
}

// One address in ten with the fault `set` gives it, on a bus of 3,000 transactions.
template <typename Fault>
BusOptions one_in_ten(uint64_t seed, Fault set) {
  BusOptions o = clean(seed, 3000);
  for (unsigned address = 10; address <= 240; address += 10)
    set(o.slave_faults[static_cast<uint8_t>(address)]);
  return o;
}

// Slaves that answer only after the master's time-out, one address in ten, at every function
// code: an echo (FC05, 06, 08, 16) as the request again, after the master has moved on.
BusOptions late_answers(uint64_t seed) {
  return one_in_ten(seed, [](auto& f) { f.answers_after_timeout = true; });
}

// The same, with a master that sends unanswered requests again: a late echo and a retry are
// both the request again.
BusOptions late_answers_and_retries(uint64_t seed) {
  BusOptions o = late_answers(seed);
  o.retry_rate = 0.7;
  return o;
}

constexpr busgen::ClockError usb_jitter{8'000'000, 1};
constexpr busgen::ClockError coarse_timer{0, 10'000'000};
constexpr busgen::ClockError sample_clock{0, 2'000};  // a logic analyzer at 500 kHz

// Where the clock cannot see a turnaround, a glitch and a frame's last byte can read alike
// (docs/framing.md, "What the bytes cannot tell"): those frames are counted, not excused.
INSTANTIATE_TEST_SUITE_P(
    RealMasters, BusScenario,
    ::testing::Values(
        Scenario{"per_byte", Delivery::per_byte, real_masters(21)},
        Scenario{"per_byte_coarse", Delivery::per_byte, real_masters(22), 0, Via::direct,
                 sample_clock},
        Scenario{"bursts", Delivery::bursts, real_masters(23), 0},
        Scenario{"bursts_coarse", Delivery::bursts, real_masters(24), 0, Via::direct, coarse_timer},
        Scenario{"per_frame_jitter", Delivery::per_frame, real_masters(25), 0, Via::direct,
                 usb_jitter},
        Scenario{"pcap_per_frame_jitter", Delivery::per_frame, real_masters(26), 0, Via::pcap,
                 usb_jitter},
        Scenario{"faulty_senders_per_byte", Delivery::per_byte, faulty_senders(31)},
        Scenario{"untimed", Delivery::untimed, real_masters(32), 2},
        Scenario{"whole_frames_pcap", Delivery::whole_frames, real_masters(33), 0, Via::pcap},
        Scenario{"hexlog_bursts", Delivery::bursts, real_masters(34), 0, Via::hexlog},
        Scenario{"glitches_per_byte", Delivery::per_byte, glitch_every_turnaround(27)},
        Scenario{"glitches_bursts", Delivery::bursts, glitch_every_turnaround(28)},
        Scenario{"glitches_per_frame", Delivery::per_frame, glitch_every_turnaround(29)},
        Scenario{"glitches_untimed", Delivery::untimed, glitch_every_turnaround(30)},
        Scenario{"long_echoes_bursts", Delivery::bursts, long_echoes(35)},
        Scenario{"long_echoes_usb_packets", Delivery::usb_packets, long_echoes(37)},
        Scenario{"long_echoes_per_frame", Delivery::per_frame, long_echoes(36), 0, Via::direct,
                 usb_jitter}),
    [](const auto& info) { return std::string(info.param.name); });

// Slaves that are not there, polled by a master that sends again what goes unanswered.
BusOptions absent_with_retries(uint64_t seed) {
  BusOptions o = one_in_ten(seed, [](auto& f) { f.absent = true; });
  o.retry_rate = 0.7;
  return o;
}
// Two devices at one address, answering over each other.
BusOptions duplicates(uint64_t seed) {
  return one_in_ten(seed, [](auto& f) { f.duplicate_address = true; });
}
// A driver that puts a 0x00 or 0xFF on the line before every answer.
BusOptions glitching_slaves(uint64_t seed) {
  return one_in_ten(seed, [](auto& f) { f.turnaround_glitch = true; });
}
// A weak driver: bits flipped in 3 answers in 10, and the master sends again.
BusOptions bit_errors(uint64_t seed) {
  BusOptions o = one_in_ten(seed, [](auto& f) { f.corruption_rate = 0.3; });
  o.retry_rate = 0.7;
  return o;
}
// A device set to half the line's baud rate: every answer junk twice its length.
BusOptions half_baud_devices(uint64_t seed) {
  return one_in_ten(seed, [](auto& f) { f.half_baud = true; });
}
// A second master reading its own slave every 0.7 s, its request right after the first
// master's: both answers come, each paired with its own request, and nothing times out.
BusOptions second_master(uint64_t seed) {
  BusOptions o = clean(seed, 3000);
  o.second_master_period_ns = 700'000'000;
  return o;
}
// Devices that restart, one address in ten: silent 5 s of every 7 s, clean answers between.
BusOptions restarting(uint64_t seed) {
  return one_in_ten(seed, [](auto& f) { f.restarts_every_ns = 7'000'000'000; });
}
// A scan list of six slaves, one of which answers a block it is read every cycle after 60 ms.
BusOptions slow_block(uint64_t seed) {
  BusOptions o = clean(seed, 3000);
  o.polled_slaves = 6;
  o.slave_faults[3].slow_block = busgen::RegisterBlock{0x0100, 8};
  return o;
}
// A trunk not terminated: long frames fail their check, short ones pass.
BusOptions reflecting(uint64_t seed) {
  BusOptions o = clean(seed, 3000);
  o.reflection_rate = 0.3;
  return o;
}
// A contactor switching every 0.7 s: a burst of junk between frames, or over one.
BusOptions noise_bursts(uint64_t seed) {
  BusOptions o = clean(seed, 3000);
  o.noise_burst_period_ns = 700'000'000;
  return o;
}
// Bursts of junk between transactions.
BusOptions noisy(uint64_t seed) {
  BusOptions o = clean(seed, 3000);
  o.noise_rate = 0.03;
  return o;
}

// Faulty buses, each fault at one address in ten, read at every timed delivery, the master's
// time-out told (--timeout) or not: a collision is one damaged answer, a retry never an
// answer, a late answer paired with the request it answers and never read as a request, and
// that request still timed out. Seeds 41-43, or 3 from MODTAP_FAULT_SEEDS=FIRST; with
// MODTAP_FAULT_KINDS=late,... the kinds named, at every delivery (late answers are read at a
// clock per byte for now). Without a clock nothing tells a garbled answer from junk after the
// master gave up (Matcher::in_answer_time), so untimed reads are not among them. Where a kind
// is read exactly: at every delivery, at a clock per byte told the time-out, or nowhere yet (its
// runs' differences are in the baseline of wrong readings, below).
enum class Exact : uint8_t { every_delivery, per_byte_told, in_baseline };
struct FaultKind {
  const char* name;
  BusOptions (*make)(uint64_t seed);
  Exact exact;
};
constexpr FaultKind fault_kinds[] = {
    {"absent", absent_with_retries, Exact::every_delivery},
    {"duplicate", duplicates, Exact::every_delivery},
    {"glitch", glitching_slaves, Exact::every_delivery},
    {"biterr", bit_errors, Exact::every_delivery},
    {"noise", noisy, Exact::every_delivery},
    {"halfbaud", half_baud_devices, Exact::every_delivery},
    {"second_master", second_master, Exact::every_delivery},
    {"restarts", restarting, Exact::every_delivery},
    {"slow_block", slow_block, Exact::every_delivery},
    {"reflections", reflecting, Exact::per_byte_told},
    {"noise_bursts", noise_bursts, Exact::in_baseline},
    {"late", late_answers, Exact::per_byte_told},
    {"late_retries", late_answers_and_retries, Exact::per_byte_told}};

struct TimedDelivery {
  const char* name;
  Delivery delivery;
  busgen::ClockError clock;
};
constexpr TimedDelivery timed_deliveries[] = {{"per_byte", Delivery::per_byte, {}},
                                              {"bursts", Delivery::bursts, {}},
                                              {"usb", Delivery::usb_packets, {}},
                                              {"per_frame", Delivery::per_frame, usb_jitter}};

std::vector<Scenario> faulty_buses() {
  static std::deque<std::string> names;  // the scenarios point at their names
  std::vector<Scenario> out;
  const char* first = std::getenv("MODTAP_FAULT_SEEDS");
  const char* asked = std::getenv("MODTAP_FAULT_KINDS");
  const uint64_t from = first ? std::strtoull(first, nullptr, 10) : 41;
  for (const FaultKind& kind : fault_kinds) {
    const bool named = asked && std::strstr(asked, kind.name);
    if ((asked && !named) || (!named && kind.exact == Exact::in_baseline)) continue;
    const bool everywhere = named || kind.exact == Exact::every_delivery;
    for (const TimedDelivery& delivery : timed_deliveries) {
      if (!everywhere && delivery.delivery != Delivery::per_byte) continue;
      for (const bool told : {true, false}) {
        if (!everywhere && !told) continue;
        for (uint64_t seed = from; seed < from + 3; ++seed) {
          names.push_back(std::string(kind.name) + "_" + delivery.name + (told ? "_told_" : "_") +
                          std::to_string(seed));
          out.push_back(Scenario{names.back().c_str(), delivery.delivery, kind.make(seed), 0,
                                 Via::direct, delivery.clock, told});
        }
      }
    }
  }
  return out;
}
INSTANTIATE_TEST_SUITE_P(FaultyBuses, BusScenario, ::testing::ValuesIn(faulty_buses()),
                         [](const auto& info) { return std::string(info.param.name); });

// The seeds to run: MODTAP_SEEDS=FIRST-LAST (a sweep of fresh seeds by hand, to find what no
// rule covers yet: docs/testing.md), else 100-1125 (100-119 under the sanitizers) and the seeds
// of later sweeps that a rule was made for.
#ifndef MODTAP_LAST_SEED
#define MODTAP_LAST_SEED 1125
#endif
// The seeds FIRST-LAST the variable `name` asks for, appended to `seeds`; false where it is unset.
bool seeds_asked(const char* name, std::vector<uint64_t>& seeds) {
  const char* range = std::getenv(name);
  if (!range) return false;
  uint64_t first = 0, last = 0;
  if (std::sscanf(range, "%" SCNu64 "-%" SCNu64, &first, &last) != 2 || last < first)
    throw std::invalid_argument(std::string(name) + ": FIRST-LAST, as 1126-1325");
  for (uint64_t seed = first; seed <= last; ++seed) seeds.push_back(seed);
  return true;
}

std::vector<uint64_t> seeds_to_run() {
  std::vector<uint64_t> seeds;
  if (seeds_asked("MODTAP_SEEDS", seeds)) return seeds;
  // docs/framing.md: the sweeps of 1126-2125 and of 5126-6125 (swallows-request); 5788, a
  // retry whose longer reading's CRC holds by chance, its cut answer right after it
  // (retry-read-as-answer: the answer's header after the copy is no junk)
  seeds = {1215, 1233, 1297, 1390, 1690, 5343, 5788, 5899};
  for (uint64_t seed = 100; seed <= MODTAP_LAST_SEED; ++seed) seeds.push_back(seed);
  return seeds;
}

// 1,026 more seeds of the real-master scenario (20 under the sanitizers) and the eight of
// sweeps, each with its own turnarounds to mistake: at 16 ms bursts and per-frame reads with
// jitter, no frame missed and none false (docs/framing.md).
std::vector<Scenario> real_master_seeds() {
  static std::deque<std::string> names;  // the scenarios point at their names
  std::vector<Scenario> out;
  for (const uint64_t seed : seeds_to_run()) {
    names.push_back("bursts_" + std::to_string(seed));
    out.push_back(Scenario{names.back().c_str(), Delivery::bursts, real_masters(seed), 0});
    names.push_back("per_frame_jitter_" + std::to_string(seed));
    out.push_back(Scenario{names.back().c_str(), Delivery::per_frame, real_masters(seed), 0,
                           Via::direct, usb_jitter});
  }
  return out;
}

INSTANTIATE_TEST_SUITE_P(RealMasterSeeds, BusScenario, ::testing::ValuesIn(real_master_seeds()),
                         [](const auto& info) { return std::string(info.param.name); });

// The rough scenario's seeds (5% glitches, 3% junk bursts, 3% truncated requests) at every
// delivery, with no allowance: 100-125 (100-104 under the sanitizers) and 172, or
// MODTAP_ROUGH_SEEDS (docs/framing.md, "Limits"). In 172 a request cut before its last CRC byte,
// which repeats its slave's address, and the whole request read back from pcapng as that
// request and junk, until a packet's first byte waited for its rest and `swallows-exchange` for
// the answer's header (docs/pcapng.md, "Reading it back").
#ifndef MODTAP_LAST_ROUGH_SEED
#define MODTAP_LAST_ROUGH_SEED 125
#endif
std::vector<Scenario> rough_seeds() {
  static std::deque<std::string> names;  // the scenarios point at their names
  std::vector<uint64_t> seeds;
  if (!seeds_asked("MODTAP_ROUGH_SEEDS", seeds)) {
    seeds = {172};
    for (uint64_t seed = 100; seed <= MODTAP_LAST_ROUGH_SEED; ++seed) seeds.push_back(seed);
  }
  std::vector<Scenario> out;  // named apart from RealMasterSeeds': a name is a file's too
  for (const uint64_t seed : seeds) {
    for (const auto& [name, delivery] : {std::pair{"rough_per_byte_", Delivery::per_byte},
                                         std::pair{"rough_bursts_", Delivery::bursts},
                                         std::pair{"rough_per_frame_", Delivery::per_frame},
                                         std::pair{"rough_untimed_", Delivery::untimed}}) {
      names.push_back(name + std::to_string(seed));
      out.push_back(Scenario{names.back().c_str(), delivery, rough(seed)});
    }
  }
  return out;
}

INSTANTIATE_TEST_SUITE_P(RoughSeeds, BusScenario, ::testing::ValuesIn(rough_seeds()),
                         [](const auto& info) { return std::string(info.param.name); });

INSTANTIATE_TEST_SUITE_P(
    Generator, BusScenario,
    ::testing::Values(Scenario{"per_byte", Delivery::per_byte, clean(1)},
                      Scenario{"bursts", Delivery::bursts, clean(2)},
                      Scenario{"per_frame", Delivery::per_frame, clean(3)},
                      Scenario{"untimed", Delivery::untimed, clean(4)},
                      Scenario{"fast_per_byte", Delivery::per_byte, fast(5)},
                      Scenario{"fast_bursts", Delivery::bursts, fast(6)},
                      Scenario{"fast_usb_packets", Delivery::usb_packets, fast(7)},
                      Scenario{"rough_per_byte", Delivery::per_byte, rough(7)},
                      Scenario{"rough_bursts", Delivery::bursts, rough(8)},
                      Scenario{"rough_per_frame", Delivery::per_frame, rough(9)},
                      Scenario{"rough_untimed", Delivery::untimed, rough(10)},
                      Scenario{"ascii_per_byte", Delivery::per_byte, ascii(11)},
                      Scenario{"ascii_bursts", Delivery::bursts, ascii(12)},
                      Scenario{"ascii_untimed", Delivery::untimed, ascii(13)},
                      Scenario{"vendor_codes_per_byte", Delivery::per_byte, vendor_codes(14)},
                      Scenario{"pcap_per_frame", Delivery::per_frame, clean(15), 0, Via::pcap},
                      Scenario{"pcap_bursts_rough", Delivery::bursts, rough(16), 0, Via::pcap},
                      Scenario{"hexlog_bursts", Delivery::bursts, clean(17), 0, Via::hexlog},
                      Scenario{"hexlog_ascii", Delivery::bursts, ascii(18), 0, Via::hexlog}),
    [](const auto& info) { return std::string(info.param.name); });

// The baseline of wrong readings (tests/protocol/wrong_readings.txt): every run of the sweeps
// whose records differ from what the simulator sent, one line a run, "SWEEP SEED DELIVERY: what
// differs". Each slice (a sweep at one delivery) runs its cheap seeds and fails where a run
// differs otherwise than the file says, better or worse; MODTAP_BASELINE=full runs every seed,
// MODTAP_BASELINE=update (or full-update) rewrites the lines of the runs it read, and
// MODTAP_BASELINE_SHOW="real-masters 379 per_byte" prints what differs in that run.
struct BaselineSlice {
  const char* sweep;
  const char* delivery_name;
  Delivery delivery;
  busgen::ClockError clock;
  bool told_timeout;
  BusOptions (*make)(uint64_t seed);
  uint64_t first, cheap_last, last;  // seeds: the test's, and the full sweep's
};

void PrintTo(const BaselineSlice& b, std::ostream* os) {
  *os << b.sweep << " " << b.delivery_name;
}

#ifndef MODTAP_BASELINE_TENTHS
#define MODTAP_BASELINE_TENTHS 10
#endif
// The cheap seeds of a slice: all of [first, last], or under the sanitizers a tenth.
constexpr uint64_t cheap_last(uint64_t first, uint64_t last) {
  return first + (last - first + 1) * MODTAP_BASELINE_TENTHS / 10 - 1;
}

std::vector<BaselineSlice> baseline_slices() {
  std::vector<BaselineSlice> out;
  for (const TimedDelivery& d : timed_deliveries)
    out.push_back({"real-masters", d.name, d.delivery, d.clock, false, real_masters, 100,
                   cheap_last(100, 299), 7125});
  for (const auto& [name, delivery] :
       {std::pair{"per_byte", Delivery::per_byte}, std::pair{"bursts", Delivery::bursts},
        std::pair{"per_frame", Delivery::per_frame}, std::pair{"untimed", Delivery::untimed}})
    out.push_back({"rough", name, delivery, {}, false, rough, 100, cheap_last(100, 1125), 1125});
  static std::deque<std::string> names;  // the slices point at their names
  for (const FaultKind& kind : fault_kinds)
    for (const TimedDelivery& d : timed_deliveries)
      for (const bool told : {true, false}) {
        names.push_back(std::string("faulty-") + kind.name + (told ? "-told" : ""));
        out.push_back({names.back().c_str(), d.name, d.delivery, d.clock, told, kind.make, 41,
                       cheap_last(41, 60), 60});
      }
  return out;
}

std::string baseline_path() {
  return std::string(MODTAP_TEST_DATA) + "/protocol/wrong_readings.txt";
}

// The file's lines, by run ("SWEEP SEED DELIVERY"); its comments apart.
std::map<std::string, std::string> read_baseline(std::vector<std::string>* comments = nullptr) {
  std::map<std::string, std::string> lines;
  std::ifstream in(baseline_path());
  for (std::string line; std::getline(in, line);) {
    const size_t colon = line.find(": ");
    if (line.empty() || line[0] == '#' || colon == std::string::npos) {
      if (comments) comments->push_back(line);
      continue;
    }
    lines[line.substr(0, colon)] = line.substr(colon + 2);
  }
  return lines;
}

std::string run_key(const BaselineSlice& b, uint64_t seed) {
  return std::string(b.sweep) + " " + std::to_string(seed) + " " + b.delivery_name;
}

// Sweep, seed, delivery, in that order; seeds by number.
bool key_before(const std::string& a, const std::string& b) {
  auto parts = [](const std::string& key) {
    const size_t first = key.find(' '), second = key.find(' ', first + 1);
    return std::tuple(key.substr(0, first), std::stoull(key.substr(first + 1, second - first - 1)),
                      key.substr(second + 1));
  };
  return parts(a) < parts(b);
}

void write_baseline(const std::map<std::string, std::string>& lines,
                    const std::vector<std::string>& comments) {
  std::vector<std::string> keys;
  for (const auto& [key, what] : lines) keys.push_back(key);
  std::sort(keys.begin(), keys.end(), key_before);
  std::ofstream out(baseline_path());
  for (const std::string& comment : comments) out << comment << "\n";
  for (const std::string& key : keys) out << key << ": " << lines.at(key) << "\n";
  ASSERT_TRUE(out.flush()) << baseline_path();
}

class WrongReadings : public ::testing::TestWithParam<BaselineSlice> {};

TEST_P(WrongReadings, AreThoseTheBaselineShows) {
  const BaselineSlice& b = GetParam();
  const char* asked = std::getenv("MODTAP_BASELINE");
  const std::string mode = asked ? asked : "";
  const bool full = mode.starts_with("full");
  const char* shown = std::getenv("MODTAP_BASELINE_SHOW");
  const std::string show = shown ? shown : "";
  std::vector<std::string> comments;
  std::map<std::string, std::string> baseline = read_baseline(&comments);
  std::vector<std::string> changed;
  for (uint64_t seed = b.first; seed <= (full ? b.last : b.cheap_last); ++seed) {
    const Scenario s{"baseline", b.delivery, b.make(seed), 0, Via::direct, b.clock, b.told_timeout};
    const BusCapture capture = busgen::simulate(s.bus);
    const Differences differences = compare_with_truth(capture, run(capture, s), s);
    const std::string what = differences.summary();
    const std::string key = run_key(b, seed);
    if (show == key)  // MODTAP_BASELINE_SHOW="SWEEP SEED DELIVERY": what differs, and where
      for (const std::string& example : differences.examples) std::cout << example << "\n";
    const auto known = baseline.find(key);
    const std::string was = known == baseline.end() ? "" : known->second;
    if (what == was) continue;
    changed.push_back(key + ": " + (was.empty() ? "exact" : was) + " -> " +
                      (what.empty() ? "exact" : what));
    if (what.empty())
      baseline.erase(key);
    else
      baseline[key] = what;
  }
  if (mode.ends_with("update")) {
    // Slices run one at a time in one process; as shards, each rewrites the file it read.
    write_baseline(baseline, comments);
    return;
  }
  std::string list;
  for (const std::string& line : changed) list += "\n  " + line;
  EXPECT_TRUE(changed.empty()) << "runs that differ otherwise than " << baseline_path()
                               << " says (where better, MODTAP_BASELINE=update rewrites it):"
                               << list;
}

INSTANTIATE_TEST_SUITE_P(Sweeps, WrongReadings, ::testing::ValuesIn(baseline_slices()),
                         [](const auto& info) {
                           std::string name =
                               std::string(info.param.sweep) + "_" + info.param.delivery_name;
                           std::replace(name.begin(), name.end(), '-', '_');
                           return name;
                         });

}  // namespace
}  // namespace modtap

namespace modtap {
namespace {

// The readings the framer weighs, kept per start as --explain keeps them; and, as each record
// comes out, what had been weighed at its first byte.
class Weighed final : public FramingObserver, public RecordSink {
 public:
  void on_start(uint16_t, uint64_t offset) override {
    std::erase_if(steps_, [&](const FramingStep& step) { return step.offset >= offset; });
  }
  void on_reading(const FramingStep& step) override {
    steps_.push_back(step);
    const bool decided = step.outcome != ReadingOutcome::kept &&
                         step.outcome != ReadingOutcome::no_frame &&
                         step.why != Evidence::more_bytes_needed;
    if (decided) ++deciding[step.why];
  }
  void on_frame(const Frame& frame) override {
    forget_before(frame.channel, frame.offset);
    const FramingStep* kept = kept_at(frame.offset, frame.adu.size());
    if (frame.check_ok && !kept) good_frames_not_kept.push_back(frame.offset);
    if (!frame.check_ok && kept) bad_frames_kept.push_back(frame.offset);
    if (!frame.check_ok || !kept) return;
    const Margin& margin = kept->end_margin;
    if (margin.stands() != bool(frame.findings & finding_ambiguous_end))
      margin_not_said.push_back(frame.offset);
    if (margin.stands()) ++end_runner_ups_standing;
    if (margin.told) ++ruling_out[*margin.told];
  }
  void on_noise(const Noise& noise) override {
    forget_before(noise.channel, noise.offset);
    if (kept_at(noise.offset, 0)) noise_kept.push_back(noise.offset);
  }
  void on_timeout(const Timeout&) override {}

  std::vector<uint64_t> good_frames_not_kept, bad_frames_kept, noise_kept;
  std::map<Evidence, size_t> deciding;  // rows that refuted a span or held it back
  // Good frames whose ambiguous-end is not what their end's margin says.
  std::vector<uint64_t> margin_not_said;
  size_t end_runner_ups_standing = 0;
  std::map<Feature, size_t> ruling_out;  // what ruled an end's runner-up out

 private:
  // A channel's records come out in order: what was weighed before one is never asked again,
  // and keeping it would make each lookup walk the whole capture.
  void forget_before(uint16_t channel, uint64_t offset) {
    std::erase_if(steps_, [&](const FramingStep& step) {
      return step.channel == channel && step.offset < offset;
    });
  }
  const FramingStep* kept_at(uint64_t offset, size_t size) const {
    const auto step = std::find_if(steps_.begin(), steps_.end(), [&](const FramingStep& s) {
      return s.offset == offset && s.outcome == ReadingOutcome::kept &&
             (size == 0 || s.length == size);
    });
    return step == steps_.end() ? nullptr : &*step;
  }
  std::vector<FramingStep> steps_;
};

// A collision garbles the answer's last bytes and the other device's bytes follow; where
// either is a good frame by chance (1 in 65,536), no receiver could tell it from one, so the
// simulator keeps the check failing. Seeds 1424, 4245 and 6253 drew a garbled answer whose CRC
// held, 6711 and 7010 junk that held its own.
TEST(BusSimulator, ACollisionLeavesNoGoodFrame) {
  for (const uint64_t seed : {1424u, 4245u, 6253u, 6711u, 7010u}) {
    const BusOptions options = real_masters(seed);
    const busgen::BusCapture capture = busgen::simulate(options);
    size_t collisions = 0;
    for (const busgen::TruthFrame& frame : capture.frames) {
      if (frame.damage != Damage::collision) continue;
      ++collisions;
      const uint8_t* bytes = capture.bytes.data();
      EXPECT_FALSE(rtu_crc_holds({bytes + frame.offset, frame.size}))
          << seed << " @" << frame.offset;
      // The other device's bytes: those right behind the answer's, with no pause.
      const uint64_t junk = frame.offset + frame.size;
      uint64_t next = junk;
      while (next < capture.bytes.size() &&
             capture.end_ns[next] - capture.end_ns[next - 1] <= options.format.char_time_ns())
        ++next;
      if (next - junk >= 4) {
        EXPECT_FALSE(rtu_crc_holds({bytes + junk, static_cast<size_t>(next - junk)}))
            << seed << " @" << junk;
      }
    }
    EXPECT_GT(collisions, 0u) << seed;
  }
}

// Junk and requests broken off hold no span whose CRC holds: no receiver could call one anything
// but a frame. The simulator keeps them free of one (a request broken off sooner, a junk byte
// changed): seeds 164 and 609 broke off an FC08 query whose CRC ends in 0x00 before that byte,
// 200, 382, 933 and 1033 drew junk that held a frame, 526 a broken-off request.
TEST(BusSimulator, JunkAndBrokenOffRequestsHoldNoGoodFrame) {
  for (const uint64_t seed : {164u, 200u, 382u, 526u, 609u, 933u, 1033u}) {
    const busgen::BusCapture capture = busgen::simulate(rough(seed));
    uint64_t sent_to = 0;
    size_t pieces = 0;
    const int64_t char_ns = rough(seed).format.char_time_ns();
    // Where the piece sent back to back from `first` ends, before `limit` at the latest.
    auto piece_end = [&](uint64_t first, uint64_t limit) {
      uint64_t end = first + 1;
      while (end < limit && capture.end_ns[end] - capture.end_ns[end - 1] <= char_ns) ++end;
      return end;
    };
    for (const busgen::TruthFrame& frame : capture.frames) {
      for (uint64_t piece = sent_to; piece < frame.offset;) {
        const uint64_t piece_to = piece_end(piece, frame.offset);
        pieces += piece_to - piece >= 4;
        for (uint64_t first = piece; first + 4 <= piece_to; ++first)
          for (uint64_t end = first + 4; end <= piece_to; ++end)
            EXPECT_FALSE(rtu_crc_holds({capture.bytes.data() + first, size_t(end - first)}))
                << seed << " @" << first << "-" << end;
        piece = piece_to;
      }
      sent_to = frame.offset + frame.size;
    }
    EXPECT_GT(pieces, 10u) << seed;
  }
}

// An FTDI sends its USB packet once 62 bytes have come, not only when its 16 ms timer runs out:
// at 115200 baud, long echoes fill packets every 5.4 ms, each stamped when its last byte came.
TEST(BusSimulator, UsbPacketsCarryAtMost62BytesAndGoOutWhenFull) {
  const BusOptions options = long_echoes(37);
  const busgen::BusCapture capture = busgen::simulate(options);
  size_t full = 0;
  for (const auto& c : busgen::deliver(capture, Delivery::usb_packets, options.seed)) {
    ASSERT_LE(c.size, 62u);
    if (c.size < 62) continue;
    ++full;
    EXPECT_EQ(c.t_ns, capture.end_ns[c.offset + c.size - 1]);  // not at the timer's tick
  }
  EXPECT_GT(full, 100u);
}

// What --explain shows is what decided: a good frame starts where a reading of its length was
// kept, and noise or a damaged frame where none was. Every row of the evidence table decides
// somewhere in the real masters' seeds (a row none needed would be dead weight): these seeds
// hold, at 16 ms bursts, the first case of each of the 1,026 seeds' sweep (docs/framing.md),
// 1073 for swallows-exchange (answer-cut-before-request refutes its first case before it), 710
// for swallows-known-frame (unawaited-answer-inside-awaited-answer refutes its earlier cases, a
// 0xFF read as station 255 before the awaited answer), and fresh seeds 2139 and 3038 for the two
// rows none of those needs (unawaited- and predicted-inside-awaited-answer).
TEST(FramingEvidence, WhatWasWeighedAtEachStartIsWhatCameOut) {
  Weighed weighed;
  for (const uint64_t seed :
       {100u, 103u, 122u, 133u, 197u, 290u, 316u, 346u, 379u, 547u, 710u, 1073u, 2139u, 3038u}) {
    for (const Delivery delivery : {Delivery::per_byte, Delivery::bursts}) {
      const Scenario s{"evidence", delivery, real_masters(seed)};
      run(busgen::simulate(s.bus), s, &weighed, &weighed);
    }
  }
  EXPECT_THAT(weighed.good_frames_not_kept, ::testing::IsEmpty());
  EXPECT_THAT(weighed.bad_frames_kept, ::testing::IsEmpty());
  EXPECT_THAT(weighed.noise_kept, ::testing::IsEmpty());
  // A good frame is ambiguous-end exactly where its end's runner-up stands; here some do, and
  // some are ruled out.
  EXPECT_THAT(weighed.margin_not_said, ::testing::IsEmpty());
  EXPECT_GT(weighed.end_runner_ups_standing, 0u);
  EXPECT_FALSE(weighed.ruling_out.empty());
  for (size_t row = 0; row < evidence_table.size(); ++row) {
    const auto evidence = static_cast<Evidence>(row);
    if (evidence == Evidence::length_and_crc || evidence == Evidence::no_good_end ||
        evidence == Evidence::more_bytes_needed)
      continue;
    EXPECT_GT(weighed.deciding[evidence], 0u) << evidence_info(evidence).name;
  }
}

}  // namespace
}  // namespace modtap
