// Conclusions a technician can act on: each faulty device named, with what it does wrong, since
// when, the counts behind it and what to check. The statistics give numbers; this reads them,
// and the evidence only the stream of records shows (which slave an answer was awaited from,
// what came in its place, a glitch at whose turnaround), into problems of the kinds below.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <tuple>
#include <utility>
#include <vector>

#include "decoder/analysis/bus_statistics.hpp"
#include "decoder/analysis/silence_run.hpp"
#include "decoder/models/device_model.hpp"
#include "decoder/protocol/findings.hpp"
#include "decoder/protocol/format_probe.hpp"
#include "decoder/protocol/record_sink.hpp"

namespace modtap {

enum class ProblemKind : uint8_t {
  no_response,            // a polled slave never answers
  stopped_responding,     // answered, then never again from a time on
  intermittent_response,  // misses a share of requests, answers the rest
  slow_response,          // far slower than the bus's other slaves, or near the time-out
  late_responses,         // answers after the master has given up
  slow_block,             // one request's answers far slower than the slave's others
  corrupted_responses,    // bad checks concentrated on one slave's answers
  bus_noise,              // bad checks spread over requests and several slaves
  reflections,            // bad checks growing with frame length, on every sender
  noise_bursts,           // junk at a regular period, destroying what it falls on
  second_master,          // requests while another request's answer is due: two masters
  rejected_requests,      // the same request answered with the same exception, again and again
  collisions,             // two devices answering at once as one address
  turnaround_glitches,    // a stray byte each time a driver takes the bus
  settings_look_wrong,    // the line's settings given to modtap do not read the bus
  wrong_baud_device,      // one device answers at another baud rate or parity: always junk
  device_restarts,        // silent for seconds, a few times, answering cleanly in between
};
inline constexpr size_t problem_kind_count = 17;

// The one place a kind is named and advised on: JSON, text, the report and metrics spell it so.
struct ProblemInfo {
  std::string_view name;
  std::string_view advice;  // what to check, in a technician's words
};
const ProblemInfo& problem_info(ProblemKind kind);

struct Problem {
  ProblemKind kind = ProblemKind::no_response;
  std::optional<uint8_t> slave;  // none: the whole bus
  Severity severity = Severity::warning;
  int64_t since_ns = 0;
  std::vector<std::pair<std::string, double>> evidence;  // the counts and times behind it
  std::string text;                                      // one plain sentence naming the device
  std::string advice;                                    // what to check
  std::vector<uint64_t> first_records;                   // where it shows, for the report's links
};

// What the records show beyond the statistics' counts, per slave. A sink beside the statistics.
class ProblemEvidence final : public RecordSink {
 public:
  static constexpr size_t kept_records = 5;
  static constexpr size_t kept_requests = 4096;  // distinct requests watched for rejection

  void on_frame(const Frame& frame) override;
  void on_noise(const Noise& noise) override;
  void on_timeout(const Timeout& timeout) override;

  // Frames of a length class (short or long) and how many of them failed their check.
  struct Lengths {
    uint64_t frames = 0, bad = 0, bytes = 0;
    void add(size_t size, bool check_ok) {
      ++frames;
      bad += !check_ok;
      bytes += size;
    }
    Lengths& operator-=(const Lengths& other) {
      frames -= other.frames;
      bad -= other.bad;
      bytes -= other.bytes;
      return *this;
    }
  };
  static constexpr size_t short_frame = 12;  // bytes at most: a request's, a short answer's
  static constexpr size_t long_frame = 24;   // bytes at least

  // Records of one kind of trouble: how many, when the first came, and the first few.
  struct Events {
    uint64_t count = 0;
    std::optional<int64_t> first_ns;
    std::vector<uint64_t> first;
    bool add(int64_t t_ns, uint64_t index);  // true: the record is one of the first
  };
  struct Slave {
    const DeviceModel* model = nullptr;  // the one its frames were read with
    uint64_t requests = 0, answers = 0;
    std::optional<int64_t> first_request_ns;
    Events timeouts, damaged, overlapping, late, glitches;
    // Its answers that came as junk past reading (noise in the answer's time), and their bytes
    // against those the answers due would have had, where the request told.
    Events garbled;
    uint64_t garbled_bytes = 0, garbled_bytes_due = 0;
    // How long after their requests its late answers came, where the clock timed them.
    std::optional<int64_t> late_min_ns, late_max_ns;
    // The time-outs since its last answer: a slave that stopped answering.
    SilenceRun silence;
    // Its silences that ended, each a few time-outs and seconds long (a restart), and the
    // time-outs they hold.
    Events silences;
    uint64_t silence_timeouts = 0;
    int64_t shortest_silence_ns = INT64_MAX, longest_silence_ns = 0;
    uint16_t expected_answer_size = 0;  // of the request it was last asked, 0 if unknown
  };
  // A request as the master repeats it: slave, function, start address and quantity.
  using RequestKey = std::tuple<uint8_t, uint8_t, uint16_t, uint16_t>;
  // What came of one request as the master repeats it: its exceptions, and how long its
  // answers took.
  struct Asked {
    uint64_t requests = 0;
    std::map<uint8_t, Events> by_exception;
    Events timed;  // its answers the clock timed, the first of them cited
    int64_t latency_sum_ns = 0;
    double mean_latency_ns() const {
      return timed.count ? static_cast<double>(latency_sum_ns) / timed.count : 0;
    }
  };

  const std::map<uint8_t, Slave>& slaves() const { return slaves_; }
  const std::map<RequestKey, Asked>& requests() const { return requests_; }
  const Events& bad_requests() const { return bad_requests_; }  // bad checks no answer explains
  const Events& master_glitches() const { return master_glitches_; }
  uint64_t requests_seen() const { return requests_seen_; }
  // Answers to a request another request cut in on while its answer was due, sooner than any
  // master's time-out (the Matcher sets such a request aside): the second master's requests.
  // A master with a short time-out that moves on from a silent slave gets no answer after.
  const Events& interruptions() const { return interruptions_; }
  // What of the stream made sense: every byte in a record, those of frames whose check holds.
  uint64_t bytes() const { return bytes_; }
  // When junk came (noise but a turnaround's glitch, a frame whose check fails) and the slave
  // it is counted against (0: none), the first kept_junk of them: a period shows in them.
  static constexpr size_t kept_junk = 4096;
  struct Junk {
    int64_t t_ns;
    uint8_t slave;
    uint64_t index;  // its record's
  };
  const std::vector<Junk>& junk() const { return junk_; }
  // Every frame by length, whoever sent it.
  const Lengths& short_frames() const { return short_frames_; }
  const Lengths& long_frames() const { return long_frames_; }
  // A slave's frames (requests to it, its answers) by length: short, long.
  const std::array<Lengths, 2>& lengths_of(uint8_t slave) const { return slave_lengths_[slave]; }
  uint64_t good_frame_bytes() const { return good_frame_bytes_; }
  // Answers timed after their request, and of those the ones that would begin before their
  // request ended: a line faster than the baud modtap was given.
  uint64_t timed_answers() const { return timed_answers_; }
  uint64_t early_answers() const { return early_answers_; }
  // The record just given is one of the first of some trouble, which a problem may cite under
  // this index (a time-out's under its request's): a report keeps its line.
  std::optional<uint64_t> cited() const { return cited_; }
  // The record just given is a time-out that may begin a silence a problem will cite (a
  // restart's, or a stop): a report keeps its line until withdrawn() names the index, the
  // slave heard again before its silence counted.
  std::optional<uint64_t> may_cite() const { return may_cite_; }
  std::optional<uint64_t> withdrawn() const { return withdrawn_; }

 private:
  void on_request(const Frame& frame);
  void on_answer(const Frame& frame, Slave& slave);
  void on_damaged_answer(uint64_t index, int64_t t_ns, size_t size, Slave& slave);
  void on_late_answer(const Frame& frame);
  void heard(Slave& slave, int64_t t_ns);
  void forget_citations() {
    cited_.reset();
    may_cite_.reset();
    withdrawn_.reset();
  }
  static constexpr uint64_t restart_timeouts = silent_after_timeouts;
  static constexpr int64_t restart_ns = 1'000'000'000;  // a restart takes seconds
  void note(Events& events, int64_t t_ns, uint64_t index);

  std::map<uint8_t, Slave> slaves_;
  std::map<RequestKey, Asked> requests_;
  Events bad_requests_, master_glitches_;
  uint64_t requests_seen_ = 0;
  uint64_t bytes_ = 0, good_frame_bytes_ = 0;
  Lengths short_frames_, long_frames_;
  std::array<std::array<Lengths, 2>, 256>
      slave_lengths_{};  // by address: a frame's costs no lookup
  std::vector<Junk> junk_;
  Events interruptions_;
  uint64_t last_request_ = 0;  // the index of the last good request
  // The first junk's records are cited, a few: a period's first bursts are among them.
  static constexpr size_t cited_junk = 32;
  void note_junk(int64_t t_ns, uint8_t slave, uint64_t index) {
    if (junk_.size() >= kept_junk) return;
    if (junk_.size() < cited_junk) cited_ = index;
    junk_.push_back({t_ns, slave, index});
  }
  void count_length(const Frame& frame);
  void time_answer(const Frame& frame);
  uint64_t timed_answers_ = 0, early_answers_ = 0;
  std::optional<int64_t> request_end_ns_;  // of the last request, while its answer may come
  Asked* awaited_ = nullptr;               // the request whose answer is awaited, if watched
  std::optional<uint8_t> awaited_slave_;
  bool after_request_ = false;  // the last record was a request: a glitch now is the slave's
  std::optional<uint64_t> cited_, may_cite_, withdrawn_;
};

// Settings that read a capture convincingly where the given ones did not (--baud auto's
// scoring on its start): the shares of its bytes in frames with a good check, under each.
struct BetterSettings {
  SerialFormat format;
  double good_share = 0;
  double given_share = 0;
};

// "at 19200 8E1, 100% do: read it with --baud 19200 --parity even", for settings read with
// `given` (the stop bits named only where they differ).
std::string read_it_with(const BetterSettings& better, const SerialFormat& given);

struct ProblemOptions {
  int64_t timeout_ns = 1'000'000'000;  // the time-out the analyzer waits for an answer
  bool timeout_told = false;           // timeout_ns is the master's (--timeout), not a default
  // Whether the reads came faster than the line's baud could carry their bytes (none: not
  // watched, as for sources with no clock per read).
  const ChunkPace* pace = nullptr;
  std::optional<BetterSettings> better{};  // none: not sought (a port, a pipe) or none found
};

// The problems the statistics and the evidence show, errors first, then by slave.
std::vector<Problem> find_problems(const BusStatistics& statistics, const ProblemEvidence& evidence,
                                   const ProblemOptions& options = {});

}  // namespace modtap
