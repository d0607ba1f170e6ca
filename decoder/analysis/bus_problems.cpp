#include "decoder/analysis/bus_problems.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include <fmt/format.h>

#include "decoder/models/device_model.hpp"
#include "decoder/models/register_meaning.hpp"
#include "decoder/protocol/bytes.hpp"
#include "decoder/protocol/function_codes.hpp"

namespace modtap {

namespace {

constexpr std::array<ProblemInfo, problem_kind_count> problem_infos{{
    {"no-response",
     "check that a device with this address is on the bus and powered, and that its address, "
     "baud rate and parity are the bus's; or take the address off the master's poll list"},
    {"stopped-responding",
     "check the device's power and its wiring at the terminals, and whether it is in a fault "
     "or was reset to other communication settings"},
    {"intermittent-response",
     "check the device's power supply and its wiring (a loose terminal, a long stub), and that "
     "the master's time-out leaves room for its answer time"},
    {"slow-response",
     "check the device's response-delay parameter and its load; make sure the master's "
     "time-out leaves room for its answer time"},
    {"late-responses",
     "lengthen the master's time-out beyond this device's answer time, or shorten the "
     "device's response delay: its answers come after the master gave up and are lost"},
    {"slow-block",
     "this request is what takes the device long (a block it computes or fetches, a "
     "gateway's remote registers): make sure the master's time-out leaves room for it, or read "
     "it less often or in smaller parts"},
    {"corrupted-responses",
     "check this device's transceiver and its wiring: the A/B wires and shield at its "
     "terminals, its stub, its segment; a device at another baud rate or parity answers in "
     "garbage too"},
    {"bus-noise",
     "check the termination (120 ohm at both ends of the trunk only), the biasing, the "
     "grounding and shield, and the cable's route past power wiring and drives"},
    {"reflections",
     "check the termination: 120 ohm at both ends of the trunk, none elsewhere (a missing or "
     "misplaced terminator reflects each bit, and long frames fail first); then stub lengths "
     "and the cable's type"},
    {"noise-bursts",
     "find what switches at this period (a contactor, a relay, a drive's or heater's cycle) and "
     "keep the cable away from it or its wiring; check the shield's grounding at one end"},
    {"second-master",
     "one master to an RS-485 line: find the other (an HMI, a gateway, a laptop or SCADA left "
     "polling) and take it off, or give it a line of its own"},
    {"rejected-requests",
     "check the master's configuration for this device against its manual: the function, "
     "the register addresses (and their numbering base) and the values it asks for"},
    {"collisions",
     "give every device its own address (two answer to this one), and make sure only one "
     "master drives the bus"},
    {"turnaround-glitches",
     "check the bus biasing (fail-safe resistors) and termination, and the driver-enable "
     "timing of the device that releases or takes the bus"},
    {"settings-look-wrong",
     "give modtap the line's baud rate, parity and stop bits as the master uses them, or let it "
     "find them (--baud auto --parity auto); the other problems wait until the settings read "
     "the bus"},
    {"wrong-baud-device",
     "set this device's baud rate, parity and stop bits to the bus's: its answers come at "
     "another speed (junk longer than the answer: a slower device; shorter: a faster one)"},
    {"device-restarts",
     "check the device's power supply for brown-outs, its fault log and watchdog, and what "
     "switches near it when it drops out"},
}};

// Thresholds: a handful of events is chance, not a problem (docs/output.md, "problems").
constexpr uint64_t few = 3;                   // fewer events than this never make a problem
constexpr uint64_t some = 5;                  // nor fewer than this for a share of requests
constexpr double missed_share = 0.05;         // intermittent-response from here
constexpr double missed_share_error = 0.25;   // and an error from here
constexpr double damaged_share = 0.02;        // corrupted-responses, collisions from here
constexpr double damaged_share_error = 0.10;  // and an error from here
constexpr double by_chance = 1e-3;    // a slave's count this unlikely at the bus's rate is its own
constexpr double concentrated = 3.0;  // times the other slaves' share: one slave's
constexpr double slow_factor = 3.0;   // slow-response: times the others' median...
constexpr int64_t slow_margin_ns = 20'000'000;  // ...and this much more
constexpr double near_timeout = 0.5;            // or its p95 past this share of the time-out
constexpr double rejected_share = 0.8;          // rejected-requests: this share of a request
constexpr double glitch_share = 0.2;            // turnaround-glitches: of the requests
constexpr size_t several = 3;                   // slaves alike: one cause they share
constexpr double wrong_baud_share = 0.8;        // wrong-baud-device: of its answers, as junk
constexpr double wrong_baud_asked = 0.5;        // and of the requests to it
constexpr uint64_t long_frames_needed = 50;     // reflections: long and short frames, each
constexpr size_t bursts_needed = 8;             // noise-bursts: times between bursts, at least
constexpr int64_t burst_merge_ns = 20'000'000;  // junk closer than this is one burst
constexpr double period_slack = 0.1;            // of a period, either side of a multiple
constexpr double regular_share = 0.8;           // of the times between bursts, regular
constexpr double second_master_share = 0.01;    // second-master: of the requests, cut short
constexpr double noise_share = 0.01;            // bus-noise: of all frames
constexpr double noise_share_error = 0.05;

double share(uint64_t part, uint64_t whole) {
  return whole ? static_cast<double>(part) / static_cast<double>(whole) : 0.0;
}

// The answer's length on the wire, where the request tells it (a read's byte count, an echo).
uint16_t expected_answer_size(const Frame& request) {
  const uint16_t body = told_answer_size(request.slave(), request.pdu());
  if (!body) return 0;
  if (request.mode == Mode::rtu) return static_cast<uint16_t>(body + 2);
  return static_cast<uint16_t>(1 + 2 * (body + 1) + 2);  // ':' hex LRC CR LF
}

// Slave, function, start and quantity of a request that reads or writes registers or coils.
std::optional<ProblemEvidence::RequestKey> request_key(const Frame& request) {
  const auto pdu = request.pdu();
  const uint8_t fc = request.function();
  if (pdu.size() < 5 || !(fc <= 0x06 || fc == 0x0F || fc == 0x10 || fc == 0x17)) return {};
  const bool single = fc == 0x05 || fc == 0x06;
  return ProblemEvidence::RequestKey{request.slave(), fc, be16(pdu, 1),
                                     single ? uint16_t{1} : be16(pdu, 3)};
}

}  // namespace

const ProblemInfo& problem_info(ProblemKind kind) {
  return problem_infos[static_cast<size_t>(kind)];
}

bool ProblemEvidence::Events::add(int64_t t_ns, uint64_t index) {
  if (!first_ns) first_ns = t_ns;
  ++count;
  if (first.size() == kept_records) return false;
  first.push_back(index);
  return true;
}

void ProblemEvidence::note(Events& events, int64_t t_ns, uint64_t index) {
  if (events.add(t_ns, index)) cited_ = index;
}

void ProblemEvidence::on_frame(const Frame& frame) {
  forget_citations();
  after_request_ = false;
  bytes_ += frame.raw.size();
  if (frame.check_ok) good_frame_bytes_ += frame.raw.size();
  if (frame.adu.empty()) return;
  count_length(frame);
  if (!frame.check_ok)
    note_junk(frame.t_ns, frame.role == Role::response ? frame.device() : 0, frame.index);
  time_answer(frame);
  if (frame.role == Role::request && frame.check_ok) return on_request(frame);
  const bool awaited =
      frame.role == Role::response && frame.request && !(frame.findings & finding_late_response);
  if (!frame.check_ok && !awaited) return note(bad_requests_, frame.t_ns, frame.index);
  if (frame.role != Role::response) return;
  if (!awaited) {  // an answer after its request timed out: late, if the history says so
    if (frame.findings & finding_late_response) on_late_answer(frame);
    return;
  }
  // The answer to a request before the last: another request cut in while it was due, sooner
  // than a master waits (the matcher sets such a request aside): a second master's.
  if (frame.check_ok && *frame.request < last_request_)
    note(interruptions_, frame.t_ns, frame.index);
  Slave& slave = slaves_[frame.device()];
  // A copy that may be the master's retry as well as the echo is no answer to count on.
  if (frame.findings & finding_ambiguous_echo) return;
  if (frame.check_ok) return on_answer(frame, slave);
  if (frame.damage == Damage::collision) return note(slave.overlapping, frame.t_ns, frame.index);
  // Neither its address nor its function the request's: junk in the answer's place.
  if (frame.findings & finding_garbage_after_request)
    return on_damaged_answer(frame.index, frame.t_ns, frame.raw.size(), slave);
  note(slave.damaged, frame.t_ns, frame.index);
  heard(slave, frame.t_ns);
}

// An answer right after its request, where the clock timed it: early where it would begin
// before its request ended (the matcher leaves such a latency unmeasured).
void ProblemEvidence::time_answer(const Frame& frame) {
  if (frame.role == Role::response && frame.request && request_end_ns_) {
    const bool early = !frame.latency_ns && frame.t_ns < *request_end_ns_;
    timed_answers_ += frame.latency_ns || early;
    early_answers_ += early;
  }
  request_end_ns_.reset();
}

// Short and long frames, the bus's and each slave's (the one asked, or answering).
void ProblemEvidence::count_length(const Frame& frame) {
  const size_t size = frame.raw.size();
  if (size > short_frame && size < long_frame) return;
  Lengths& bus = size <= short_frame ? short_frames_ : long_frames_;
  bus.add(size, frame.check_ok);
  const bool known = frame.check_ok || (frame.role == Role::response && frame.request);
  if (!known || frame.device() == 0) return;
  slave_lengths_[frame.device()][size <= short_frame ? 0 : 1].add(size, frame.check_ok);
}

void ProblemEvidence::on_request(const Frame& frame) {
  ++requests_seen_;
  last_request_ = frame.index;
  after_request_ = true;
  request_end_ns_ = frame.end_ns;
  awaited_ = nullptr;
  awaited_slave_.reset();
  if (frame.slave() == 0) return;  // a broadcast: no answer comes
  Slave& slave = slaves_[frame.slave()];
  ++slave.requests;
  if (!slave.first_request_ns) slave.first_request_ns = frame.t_ns;
  if (frame.meaning && frame.meaning->model) slave.model = frame.meaning->model;
  slave.expected_answer_size = expected_answer_size(frame);
  awaited_slave_ = frame.slave();
  const auto key = request_key(frame);
  if (!key) return;
  auto it = requests_.find(*key);
  if (it == requests_.end()) {
    if (requests_.size() >= kept_requests) return;
    it = requests_.emplace(*key, Asked{}).first;
  }
  ++it->second.requests;
  awaited_ = &it->second;  // a map's entries stay where they are
}

void ProblemEvidence::on_answer(const Frame& frame, Slave& slave) {
  ++slave.answers;
  heard(slave, frame.t_ns);
  if (frame.meaning && frame.meaning->model) slave.model = frame.meaning->model;
  if (awaited_ && awaited_slave_ == frame.device()) {
    Asked& asked = *awaited_;
    if (frame.is_exception()) {
      note(asked.by_exception[frame.adu[2]], frame.t_ns, frame.index);
    } else if (frame.latency_ns) {
      asked.timed.add(frame.t_ns, frame.index);  // not cited: there is one for every request
      asked.latency_sum_ns += *frame.latency_ns;
    }
  }
  awaited_ = nullptr;
}

void ProblemEvidence::on_late_answer(const Frame& frame) {
  Slave& slave = slaves_[frame.slave()];
  note(slave.late, frame.t_ns, frame.index);
  heard(slave, frame.t_ns);  // it is there, only slow
  if (!frame.latency_ns) return;
  slave.late_min_ns = std::min(slave.late_min_ns.value_or(INT64_MAX), *frame.latency_ns);
  slave.late_max_ns = std::max(slave.late_max_ns.value_or(INT64_MIN), *frame.latency_ns);
}

// An answer past reading: a character or two longer than the awaited answer, it is two answers
// begun a little apart (another device of the same address); otherwise it is damaged. Begun
// within a bit, they read as one frame of the answer's length, with a bad check: damaged.
void ProblemEvidence::on_damaged_answer(uint64_t index, int64_t t_ns, size_t size, Slave& slave) {
  const uint16_t expected = slave.expected_answer_size;
  if (expected && size > expected && size <= expected + 2u) {
    note(slave.overlapping, t_ns, index);
  } else {
    note(slave.damaged, t_ns, index);
    slave.garbled.add(t_ns, index);
    if (expected) {
      slave.garbled_bytes += size;
      slave.garbled_bytes_due += expected;
    }
  }
  heard(slave, t_ns);
}

// The slave spoke: a silence of a few time-outs in a row, seconds long, is over (a restart).
void ProblemEvidence::heard(Slave& slave, int64_t t_ns) {
  const SilenceRun run = slave.silence.heard();
  if (run.timeouts == 0) return;
  const bool restart = run.timeouts >= restart_timeouts && t_ns - run.since_ns >= restart_ns;
  if (!restart || !slave.silences.add(run.since_ns, run.first_request))
    withdrawn_ = run.first_request;
  if (restart) {
    const int64_t lasted = t_ns - run.since_ns;
    slave.silence_timeouts += run.timeouts;
    slave.shortest_silence_ns = std::min(slave.shortest_silence_ns, lasted);
    slave.longest_silence_ns = std::max(slave.longest_silence_ns, lasted);
  }
}

void ProblemEvidence::on_noise(const Noise& noise) {
  forget_citations();
  bytes_ += noise.raw.size();
  if (noise.reason != NoiseReason::glitch)
    note_junk(noise.t_ns, noise.damaged_answer ? noise.request_slave : 0, noise.index);
  const bool after_request = std::exchange(after_request_, false);
  if (noise.reason == NoiseReason::glitch) {
    // Right after a request, the slave's driver turning on to answer; else the master's.
    if (after_request && awaited_slave_) {
      note(slaves_[*awaited_slave_].glitches, noise.t_ns, noise.index);
    } else {
      note(master_glitches_, noise.t_ns, noise.index);
    }
    return;
  }
  if (noise.damaged_answer)
    on_damaged_answer(noise.index, noise.t_ns, noise.raw.size(), slaves_[noise.request_slave]);
}

void ProblemEvidence::on_timeout(const Timeout& timeout) {
  forget_citations();
  after_request_ = false;
  awaited_ = nullptr;
  if (!timeout.timed_out() || timeout.slave == 0) return;
  Slave& slave = slaves_[timeout.slave];
  note(slave.timeouts, timeout.t_ns, timeout.request);
  slave.silence.unanswered(timeout);
  if (slave.silence.timeouts == 1) may_cite_ = timeout.request;
}

namespace {

using Slave = ProblemEvidence::Slave;

// A value's median over every slave but one, for each slave: the values sorted once and each
// slave's own left out by its place, so a bus of 247 slaves costs no more than a sort. Fixed
// room, no allocation: MQTT's health summary asks for the problems every interval.
class MedianOfOthers {
 public:
  void add(uint8_t slave, double value) { sorted_[size_++] = {value, slave}; }
  void sort() { std::sort(sorted_.begin(), sorted_.begin() + static_cast<ptrdiff_t>(size_)); }
  // The upper median of the others' values; none when no other slave has one.
  std::optional<double> without(uint8_t slave) const {
    const auto end = sorted_.begin() + static_cast<ptrdiff_t>(size_);
    const auto own = std::find_if(sorted_.begin(), end,
                                  [&](const auto& entry) { return entry.second == slave; });
    const size_t others = size_ - (own != end);
    if (others == 0) return std::nullopt;
    const size_t at = others / 2;
    const auto skipped = static_cast<size_t>(own - sorted_.begin());
    return sorted_[at < skipped ? at : at + 1].first;
  }

 private:
  std::array<std::pair<double, uint8_t>, 256> sorted_;  // one an address at most
  size_t size_ = 0;
};

// Reads the statistics and the evidence into problems, one rule a kind.
class Diagnosis {
 public:
  Diagnosis(const BusStatistics& statistics, const ProblemEvidence& evidence,
            const ProblemOptions& options)
      : statistics_(statistics), evidence_(evidence), options_(options) {
    statistics_.for_each_slave([&](uint8_t address, const SlaveStatistics& s) {
      if (s.latency_ns.count() >= some)
        latency_medians_.add(address, static_cast<double>(s.latency_ns.percentile(50)));
    });
    latency_medians_.sort();
    for (const auto& [address, s] : evidence_.slaves()) {
      bus_damaged_ += s.damaged.count;
      bus_overlapping_ += s.overlapping.count;
      bus_requests_ += s.requests;
      if (s.requests < some) continue;
      damaged_rates_.add(address, damaged_rate(s));
      missed_rates_.add(address, share(s.timeouts.count, s.requests));
    }
    damaged_rates_.sort();
    missed_rates_.sort();
  }

  std::vector<Problem> run() {
    // Read with settings that are not the line's, every other conclusion is the settings'.
    if (settings_look_wrong()) return std::move(problems_);
    for (const auto& [address, slave] : evidence_.slaves()) {
      if (no_response(address, slave)) continue;  // nothing else to say of a silent address
      const bool restarts = device_restarts(address, slave);
      stopped_or_intermittent(address, slave, restarts);
      if (!slow_block(address, slave)) slow_response(address, slave);
      late_responses(address, slave);
      damaged_answers(address, slave);
    }
    turnaround_glitches();
    bus_noise();
    second_master();
    master_glitches();
    rejected_requests();
    std::stable_sort(problems_.begin(), problems_.end(),
                     [](const Problem& a, const Problem& b) { return a.severity > b.severity; });
    return std::move(problems_);
  }

 private:
  Problem& add(ProblemKind kind, std::optional<uint8_t> slave, Severity severity, int64_t since_ns,
               std::vector<uint64_t> first) {
    Problem& p = problems_.emplace_back();
    p.kind = kind;
    p.slave = slave;
    p.severity = severity;
    p.since_ns = since_ns;
    p.advice = problem_info(kind).advice;
    p.first_records = std::move(first);
    return p;
  }

  // The settings modtap was given do not read the bus: most bytes form no good frame, the reads
  // bring more bytes than the baud can carry, or answers would begin before their requests
  // ended. Each is what a wrong baud rate or parity does; a bad line garbles some frames, not
  // most (the statistics of a noisy bus stay well below), and cannot hurry the bytes.
  bool settings_look_wrong() {
    const uint64_t bytes = evidence_.bytes();
    const double good = share(evidence_.good_frame_bytes(), bytes);
    const ChunkPace* pace = options_.pace;
    const uint64_t timed = evidence_.timed_answers(), early = evidence_.early_answers();
    const std::string settings = describe(statistics_.format());
    std::string why;
    if (pace && pace->too_fast()) {
      why = fmt::format("the bytes arrive faster than {} carries them ({} of {} reads)", settings,
                        pace->fast_reads, pace->reads);
    } else if (mostly_early(timed, early)) {
      why = fmt::format("{} of {} answers would begin before their request ended at {}", early,
                        timed, settings);
    } else if (mostly_junk(bytes, evidence_.good_frame_bytes())) {
      why = fmt::format("only {:.0f}% of {} bytes form frames with a good check at {}", 100 * good,
                        bytes, settings);
    } else if (const auto& better = options_.better) {
      why = fmt::format("{:.0f}% of the capture's first bytes form frames with a good check at {}",
                        100 * better->given_share, settings);
    } else {
      return false;
    }
    Problem& p = add(ProblemKind::settings_look_wrong, std::nullopt, Severity::error,
                     statistics_.first_t_ns.value_or(0), {});
    p.evidence = {
        {"bytes", bytes}, {"good_share", good}, {"early_answers", early}, {"timed_answers", timed}};
    if (pace) {
      p.evidence.emplace_back("fast_reads", pace->fast_reads);
      p.evidence.emplace_back("reads", pace->reads);
    }
    p.text = fmt::format("The line's settings look wrong: {}{}", why, remedy(p));
    return true;
  }

  // What to read the capture with: the settings found to read it, or the search for them.
  std::string remedy(Problem& p) const {
    const auto& better = options_.better;
    if (!better) return ". Are they the line's? Try --baud auto";
    const SerialFormat& f = better->format;
    p.evidence.emplace_back("better_baud", f.baud);
    p.evidence.emplace_back("better_good_share", better->good_share);
    return "; " + read_it_with(*better, statistics_.format());
  }

  // "Slave 3 (gd20)": the model named where one was set or found, not the generic one.
  static std::string who(uint8_t address, const Slave& slave) {
    if (!slave.model || maps_no_register(*slave.model)) return fmt::format("Slave {}", address);
    return fmt::format("Slave {} ({})", address, slave.model->name);
  }

  static double percent(uint64_t part, uint64_t whole) { return 100 * share(part, whole); }

  // Whatever came from a slave in answer: good, damaged, two at once, or late.
  static uint64_t answered(const Slave& s) {
    return s.answers + s.damaged.count + s.overlapping.count + s.late.count;
  }

  // A slave that answers none of its requests, or fewer than a few and one in a hundred at
  // most (a record read as its answer that was none): silent, not intermittent. Junk now and
  // then where its answer would be is the line's noise, not the device: a device whose answers
  // are junk sends them to most requests (wrong-baud-device, corrupted-responses).
  bool no_response(uint8_t address, const Slave& s) {
    const uint64_t came = s.answers + s.late.count;
    const uint64_t junk = s.damaged.count + s.overlapping.count;
    if (s.requests < few || s.timeouts.count < few || came >= few || 100 * came > s.requests ||
        2 * junk >= s.requests)
      return false;
    Problem& p = add(ProblemKind::no_response, address, Severity::error,
                     s.first_request_ns.value_or(0), s.timeouts.first);
    p.evidence = {{"requests", s.requests},
                  {"timeouts", s.timeouts.count},
                  {"answered", came},
                  {"junk", junk}};
    p.text = came ? fmt::format("{} almost never answers: {} of {} requests timed out, {} answered",
                                who(address, s), s.timeouts.count, s.requests, came)
             : s.timeouts.count == s.requests
                 ? fmt::format("{} never answers: {} requests, all timed out", who(address, s),
                               s.requests)
                 : fmt::format("{} never answers: {} requests, {} timed out", who(address, s),
                               s.requests, s.timeouts.count);
    if (junk)
      p.text += fmt::format("; {} brought only junk where its answer would be (line noise)", junk);
    return true;
  }

  // A slave silent from a time to the end stopped; one that misses a share throughout drops.
  void stopped_or_intermittent(uint8_t address, const Slave& s, bool restarts) {
    // A restarting device silent at the end, no longer than twice its longest silence, is
    // restarting again, not gone.
    const int64_t silent_at_end = statistics_.last_t_ns.value_or(0) - s.silence.since_ns;
    const bool stopped = s.answers >= few && s.silence.timeouts >= some &&
                         (!restarts || silent_at_end > 2 * s.longest_silence_ns);
    if (stopped) {
      Problem& p = add(ProblemKind::stopped_responding, address, Severity::error,
                       s.silence.since_ns, {s.silence.first_request});
      p.evidence = {{"answered_before", s.answers}, {"timeouts_since", s.silence.timeouts}};
      p.text =
          fmt::format("{} stopped answering at {}: its last {} requests timed out", who(address, s),
                      moment_text(statistics_, s.silence.since_ns), s.silence.timeouts);
    }
    // Time-outs its late answers explain are late-responses; those after it stopped, stopped.
    // Restarts, their silences'.
    const uint64_t explained =
        std::min(s.timeouts.count, s.late.count + (stopped || restarts ? s.silence.timeouts : 0) +
                                       (restarts ? s.silence_timeouts : 0));
    const uint64_t missed = s.timeouts.count - explained;
    const uint64_t asked = s.requests - (stopped ? s.silence.timeouts : 0);
    const double missed_rate = share(missed, asked);
    if (missed < some || missed_rate < missed_share ||
        missed_rate < concentrated * others_missed_rate(address))
      return;
    Problem& p = add(ProblemKind::intermittent_response, address,
                     missed_rate >= missed_share_error ? Severity::error : Severity::warning,
                     *s.timeouts.first_ns, s.timeouts.first);
    p.evidence = {{"requests", asked}, {"timeouts", missed}, {"share", missed_rate}};
    p.text = fmt::format("{} fails to answer {:.0f}% of requests ({} of {}) since {}",
                         who(address, s), 100 * missed_rate, missed, asked,
                         moment_text(statistics_, *s.timeouts.first_ns));
  }

  // Silent for seconds a few times, answering again after each, and hardly ever missing a
  // request in between: a device that restarts, not one that drops requests.
  bool device_restarts(uint8_t address, const Slave& s) {
    if (s.silences.count < 2) return false;
    const uint64_t between =
        s.timeouts.count -
        std::min(s.timeouts.count, s.silence_timeouts + s.late.count + s.silence.timeouts);
    if (share(between, s.requests) >= missed_share) return false;
    Problem& p = add(ProblemKind::device_restarts, address, Severity::error, *s.silences.first_ns,
                     s.silences.first);
    const double shortest_s = s.shortest_silence_ns / 1e9, longest_s = s.longest_silence_ns / 1e9;
    p.evidence = {{"silences", s.silences.count},
                  {"timeouts_in_silences", s.silence_timeouts},
                  {"shortest_s", shortest_s},
                  {"longest_s", longest_s}};
    p.text = fmt::format(
        "{} went silent {} times, {:.1f} to {:.1f} s each, and answered again after each, as a "
        "device restarting does; first at {}",
        who(address, s), s.silences.count, shortest_s, longest_s,
        moment_text(statistics_, *s.silences.first_ns));
    // A silence the capture ended in is one more, whose length nobody knows.
    if (s.silence.silent()) {
      p.evidence.push_back({"silent_at_end", 1});
      p.text += fmt::format("; silent again from {} to the end",
                            moment_text(statistics_, s.silence.since_ns));
    }
    return true;
  }

  // The median of the other slaves' shares of time-outs: a master whose time-out is too short
  // for all of them is no one slave's fault.
  double others_missed_rate(uint8_t address) const {
    return missed_rates_.without(address).value_or(0);
  }

  // The median of the other slaves' median latencies: what this bus's slaves take.
  std::optional<uint64_t> others_latency(uint8_t address) const {
    const auto others = latency_medians_.without(address);
    if (!others) return std::nullopt;
    return static_cast<uint64_t>(*others);
  }

  const SlaveStatistics* statistics_of(uint8_t address) const {
    const auto it = statistics_.addresses().find(address);
    return it == statistics_.addresses().end() ? nullptr : it->second.get();
  }

  // A slave whose answers come late is slow for that reason: the late problem says how slow.
  // One request the slave answers far slower than its others, as slow-response compares
  // slaves: the request is slow, not the device (latency by what is asked).
  bool slow_block(uint8_t address, const Slave& s) {
    using Key = ProblemEvidence::RequestKey;
    const auto& requests = evidence_.requests();
    const auto first = requests.lower_bound(Key{address, 0, 0, 0});
    const auto last = requests.lower_bound(Key{static_cast<uint8_t>(address + 1), 0, 0, 0});
    const auto end = address == 255 ? requests.end() : last;
    uint64_t timed = 0;
    int64_t sum_ns = 0;
    for (auto it = first; it != end; ++it) {
      timed += it->second.timed.count;
      sum_ns += it->second.latency_sum_ns;
    }
    for (auto it = first; it != end; ++it) {
      const ProblemEvidence::Asked& asked = it->second;
      const uint64_t others = timed - asked.timed.count;
      if (asked.timed.count < some || others < some) continue;
      const double mean = asked.mean_latency_ns();
      const double others_mean = static_cast<double>(sum_ns - asked.latency_sum_ns) / others;
      if (mean < slow_factor * others_mean || mean - others_mean < slow_margin_ns) continue;
      const auto [slave, fc, start, quantity] = it->first;
      Problem& p = add(ProblemKind::slow_block, address, Severity::warning,
                       asked.timed.first_ns.value_or(0), asked.timed.first);
      p.evidence = {{"function", fc},
                    {"address", start},
                    {"quantity", quantity},
                    {"latency_ms", mean / 1e6},
                    {"others_latency_ms", others_mean / 1e6}};
      p.text = fmt::format(
          "{} answers its {} of {:04X}H ({} registers) in {:.0f} ms, where its "
          "other requests take {:.0f} ms",
          who(address, s), verb(fc), start, quantity, mean / 1e6, others_mean / 1e6);
      return true;
    }
    return false;
  }

  void slow_response(uint8_t address, const Slave& s) {
    const SlaveStatistics* stats = statistics_of(address);
    if (!stats || stats->latency_ns.count() < some || s.late.count >= few) return;
    const auto median = static_cast<int64_t>(stats->latency_ns.percentile(50));
    const auto p95 = static_cast<int64_t>(stats->latency_ns.percentile(95));
    const auto others = others_latency(address);
    const bool slower = others && median >= slow_factor * static_cast<double>(*others) &&
                        median - static_cast<int64_t>(*others) >= slow_margin_ns;
    const bool near = p95 >= near_timeout * static_cast<double>(options_.timeout_ns);
    if (!slower && !near) return;
    Problem& p = add(ProblemKind::slow_response, address, Severity::warning,
                     s.first_request_ns.value_or(0), {});
    p.evidence = {{"latency_p50_ms", median / 1e6}, {"latency_p95_ms", p95 / 1e6}};
    if (others) p.evidence.emplace_back("others_p50_ms", static_cast<double>(*others) / 1e6);
    p.text = slower ? fmt::format("{} answers in {:.0f} ms where the others take {:.0f} ms",
                                  who(address, s), median / 1e6, *others / 1e6)
                    : fmt::format(
                          "{} answers in {:.0f} ms (95% within {:.0f} ms), close to the "
                          "{:.0f} ms time-out",
                          who(address, s), median / 1e6, p95 / 1e6, options_.timeout_ns / 1e6);
  }

  // How late, against the master's time-out where it was told: the number to set it by.
  void late_responses(uint8_t address, const Slave& s) {
    if (s.late.count < few) return;
    Problem& p =
        add(ProblemKind::late_responses, address, Severity::error, *s.late.first_ns, s.late.first);
    p.evidence = {{"late_answers", s.late.count}, {"requests", s.requests}};
    // A share of its requests, as the time-outs' are: with those it never answered, the
    // statistics' time-out rate.
    p.text = fmt::format(
        "{} answers after the master has given up: {} of its {} requests ({:.0f}%) were "
        "answered too late",
        who(address, s), s.late.count, s.requests, percent(s.late.count, s.requests));
    if (!s.late_min_ns) return;
    const double low_ms = *s.late_min_ns / 1e6, high_ms = *s.late_max_ns / 1e6;
    p.evidence.emplace_back("late_min_ms", low_ms);
    p.evidence.emplace_back("late_max_ms", high_ms);
    p.text += low_ms < high_ms - 0.5
                  ? fmt::format(", {:.0f} to {:.0f} ms after their requests", low_ms, high_ms)
                  : fmt::format(", {:.0f} ms after their requests", low_ms);
    if (!options_.timeout_told) return;
    p.evidence.emplace_back("timeout_ms", options_.timeout_ns / 1e6);
    p.text += fmt::format(" where the master waits {:.0f} ms", options_.timeout_ns / 1e6);
  }

  // The rest of the bus's share of its requests that `others_events` befell.
  double others_rate(uint64_t others_events, const Slave& s) const {
    return share(others_events, bus_requests_ - s.requests);
  }

  // Whether `count` of a slave's `requests` are more than chance gives at the rest of the bus's
  // rate: a line's noise or a second master's collisions fall on every device alike, and one of
  // forty gets a few more by chance alone (the Poisson tail of its expected count); a faulty
  // device's stand out.
  static bool beyond_chance(uint64_t count, uint64_t requests, double others_rate) {
    const double expected = others_rate * static_cast<double>(requests);
    double term = std::exp(-expected), below = 0;
    for (uint64_t k = 0; k < count; ++k) {
      below += term;
      term *= expected / static_cast<double>(k + 1);
    }
    return 1 - below < by_chance;
  }

  // Each slave's share of damaged answers, for telling one bad device from a bad line.
  double damaged_rate(const Slave& s) const { return share(s.damaged.count, s.requests); }
  double others_damaged_rate(uint8_t address) const {
    return damaged_rates_.without(address).value_or(0);
  }

  // Two devices answering at once also make frames with bad checks (begun within a bit of each
  // other): where they collide, those are part of it, not a damaged device of their own.
  void damaged_answers(uint8_t address, const Slave& s) {
    if (wrong_baud_device(address, s)) return;
    const double overlap_rate = share(s.overlapping.count, s.requests);
    if (s.overlapping.count >= few && overlap_rate >= damaged_share &&
        beyond_chance(s.overlapping.count, s.requests,
                      others_rate(bus_overlapping_ - s.overlapping.count, s))) {
      Problem& p = add(ProblemKind::collisions, address, Severity::error, *s.overlapping.first_ns,
                       s.overlapping.first);
      p.evidence = {{"overlapping_answers", s.overlapping.count}, {"requests", s.requests}};
      p.text = fmt::format(
          "Two devices answer as slave {}: {} of {} requests ({:.0f}%) were answered by two at "
          "once",
          address, s.overlapping.count, s.requests, 100 * overlap_rate);
      damage_explained_[address] = true;  // its bad checks are the collisions'
      return;
    }
    const double rate = damaged_rate(s);
    if (s.damaged.count < some || rate < damaged_share) return;
    const double others = others_damaged_rate(address);
    if (rate < concentrated * others ||
        !beyond_chance(s.damaged.count, s.requests, others_rate(bus_damaged_ - s.damaged.count, s)))
      return;
    Problem& p = add(ProblemKind::corrupted_responses, address,
                     rate >= damaged_share_error ? Severity::error : Severity::warning,
                     *s.damaged.first_ns, s.damaged.first);
    damage_explained_[address] = true;  // one device's answers, not the line
    p.evidence = {
        {"damaged_answers", s.damaged.count}, {"requests", s.requests}, {"others_share", others}};
    p.text = fmt::format(
        "{}'s answers arrive damaged: {:.0f}% ({} of {}) fail their check, the other slaves' "
        "{:.1f}%",
        who(address, s), 100 * rate, s.damaged.count, s.requests, 100 * others);
  }

  // A device at another baud rate or parity answers every time, and every time in junk no
  // frame reads, of a length its speed sets: not a weak driver, whose answers mostly come
  // through. Its bad checks are this problem's.
  bool wrong_baud_device(uint8_t address, const Slave& s) {
    if (s.garbled.count < some || s.garbled.count < wrong_baud_share * answered(s) ||
        s.garbled.count < wrong_baud_asked * s.requests)
      return false;
    Problem& p = add(ProblemKind::wrong_baud_device, address, Severity::error, *s.garbled.first_ns,
                     s.garbled.first);
    p.evidence = {{"garbled_answers", s.garbled.count}, {"answers", answered(s)}};
    p.text = fmt::format(
        "{} answers in junk every time, as a device at another baud rate or parity does: {} of "
        "its {} answers",
        who(address, s), s.garbled.count, answered(s));
    if (s.garbled_bytes_due) {
      const double ratio = share(s.garbled_bytes, s.garbled_bytes_due);
      p.evidence.emplace_back("length_ratio", ratio);
      p.text += fmt::format(", {:.1f} times as long as the answers due", ratio);
    }
    damage_explained_[address] = true;
    return true;
  }

  // A stray byte between a request and its answer, at a share of a slave's requests.
  static bool glitching(const Slave& s) {
    return s.glitches.count >= some && share(s.glitches.count, s.requests) >= glitch_share;
  }

  // One slave's driver, or one cause at the master's side for all: the stray byte after the
  // requests of several slaves alike (half of those asked), or of a slave that never drives the
  // bus at all, is the master's driver releasing it late, or the bus's biasing.
  void turnaround_glitches() {
    std::vector<uint8_t> glitchy;
    size_t asked = 0;
    bool silent_one = false;
    for (const auto& [address, s] : evidence_.slaves()) {
      asked += s.requests >= some;
      if (!glitching(s)) continue;
      glitchy.push_back(address);
      silent_one |= answered(s) == 0;
    }
    if (silent_one || (glitchy.size() >= several && 2 * glitchy.size() >= asked))
      return glitches_after_requests(glitchy, asked);
    for (const uint8_t address : glitchy) slave_glitches(address, evidence_.slaves().at(address));
  }

  void slave_glitches(uint8_t address, const Slave& s) {
    Problem& p = add(ProblemKind::turnaround_glitches, address, Severity::warning,
                     *s.glitches.first_ns, s.glitches.first);
    p.evidence = {{"glitches", s.glitches.count}, {"requests", s.requests}};
    p.text = fmt::format(
        "A stray byte on the line each time {} starts to answer: after {:.0f}% of its requests "
        "({} of {})",
        who(address, s), percent(s.glitches.count, s.requests), s.glitches.count, s.requests);
  }

  void glitches_after_requests(const std::vector<uint8_t>& glitchy, size_t asked) {
    uint64_t count = 0, requests = 0;
    int64_t since = INT64_MAX;
    std::vector<uint64_t> first;
    for (const uint8_t address : glitchy) {
      const Slave& s = evidence_.slaves().at(address);
      count += s.glitches.count;
      requests += s.requests;
      since = std::min(since, *s.glitches.first_ns);
      first.insert(first.end(), s.glitches.first.begin(), s.glitches.first.end());
    }
    std::sort(first.begin(), first.end());
    first.resize(std::min(first.size(), ProblemEvidence::kept_records));
    Problem& p = add(ProblemKind::turnaround_glitches, std::nullopt, Severity::warning, since,
                     std::move(first));
    p.evidence = {{"glitches", count}, {"requests", requests}, {"slaves", glitchy.size()}};
    const std::string whose = glitchy.size() == asked
                                  ? std::string("every slave")
                                  : fmt::format("{} of {} slaves", glitchy.size(), asked);
    p.text = fmt::format(
        "A stray byte on the line after the master's requests to {} alike, one cause at the "
        "master's side or the bus's biasing: after {:.0f}% of their requests ({} of {})",
        whose, percent(count, requests), count, requests);
  }

  void master_glitches() {
    const auto& g = evidence_.master_glitches();
    const uint64_t turnarounds = evidence_.requests_seen();
    if (g.count < some || share(g.count, turnarounds) < glitch_share) return;
    Problem& p = add(ProblemKind::turnaround_glitches, std::nullopt, Severity::warning, *g.first_ns,
                     g.first);
    p.evidence = {{"glitches", g.count}, {"requests", turnarounds}};
    p.text = fmt::format(
        "A stray byte on the line each time the master starts a request: "
        "{:.0f}% of its requests ({} of {})",
        percent(g.count, turnarounds), g.count, turnarounds);
  }

  // Bad checks that grow with frame length faster than the bits a frame carries, on the
  // frames of every device whose damage is not its own: reflections, the line's termination.
  // Bits flipped at random hit a frame as often as it has bits; a reflection builds up over
  // a frame, and long frames fail out of proportion.
  bool reflections() {
    ProblemEvidence::Lengths short_frames = evidence_.short_frames(),
                             long_frames = evidence_.long_frames();
    for (const auto& [address, s] : evidence_.slaves()) {
      if (!damage_explained_[address]) continue;
      short_frames -= evidence_.lengths_of(address)[0];
      long_frames -= evidence_.lengths_of(address)[1];
    }
    if (long_frames.frames < long_frames_needed || long_frames.bad < some ||
        short_frames.frames < long_frames_needed)
      return false;
    const double long_share = share(long_frames.bad, long_frames.frames);
    // One bad short frame more than were seen: a bound where none failed, not a zero.
    const double short_share = share(short_frames.bad + 1, short_frames.frames + 1);
    const double lengths = share(long_frames.bytes, long_frames.frames) /
                           share(short_frames.bytes, short_frames.frames);
    if (long_share < damaged_share || long_share < 2 * lengths * short_share) return false;
    Problem& p = add(ProblemKind::reflections, std::nullopt,
                     long_share >= damaged_share_error ? Severity::error : Severity::warning,
                     statistics_.first_t_ns.value_or(0), evidence_.bad_requests().first);
    p.evidence = {{"long_frames", long_frames.frames},
                  {"long_bad", long_frames.bad},
                  {"short_frames", short_frames.frames},
                  {"short_bad", short_frames.bad}};
    p.text = fmt::format(
        "Bad checks grow with frame length, faster than the bits frames carry, as reflections "
        "on a line not terminated make them: {:.1f}% of frames of {} bytes or more ({} of {}), "
        "{:.1f}% of frames of {} bytes or fewer ({} of {})",
        100 * long_share, ProblemEvidence::long_frame, long_frames.bad, long_frames.frames,
        percent(short_frames.bad, short_frames.frames), ProblemEvidence::short_frame,
        short_frames.bad, short_frames.frames);
    return true;
  }

  // Junk at a regular period (a contactor, a drive switching): the times between bursts are
  // nearly all whole multiples of one period (a burst that falls where nothing shows it, or
  // is read as part of a frame, leaves a multiple). Junk that a device's own problem explains
  // is left out: a device answering junk at every poll is periodic too.
  bool noise_bursts() {
    std::vector<int64_t> gaps;
    std::vector<uint64_t> first;  // the first bursts' first records
    std::optional<int64_t> last;
    for (const auto& [t_ns, slave, index] : evidence_.junk()) {
      if (damage_explained_[slave] && slave) continue;
      if (last && t_ns - *last < burst_merge_ns) continue;  // one burst's pieces
      if (last) gaps.push_back(t_ns - *last);
      if (first.size() < ProblemEvidence::kept_records) first.push_back(index);
      last = t_ns;
    }
    if (gaps.size() < bursts_needed) return false;
    std::vector<int64_t> sorted = gaps;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    const double period = static_cast<double>(sorted[sorted.size() / 2]);
    const auto regular = std::count_if(gaps.begin(), gaps.end(), [&](int64_t gap) {
      const double periods = static_cast<double>(gap) / period;
      return std::abs(periods - std::round(periods)) <= period_slack;
    });
    if (static_cast<double>(regular) < regular_share * static_cast<double>(gaps.size()))
      return false;
    Problem& p = add(ProblemKind::noise_bursts, std::nullopt, Severity::warning,
                     evidence_.junk().front().t_ns, std::move(first));
    p.evidence = {{"period_ms", period / 1e6}, {"bursts", gaps.size() + 1}};
    p.text = fmt::format(
        "Junk on the line every {:.0f} ms, as regular as a contactor or a drive switching "
        "nearby makes it: {} bursts, frames failing their check where one fell on them",
        period / 1e6, gaps.size() + 1);
    return true;
  }

  // Requests that come while another request's answer is due, sooner than any master's own
  // time-out lets it send again: a second master polling on its own program. The requests it
  // cut short, and the answers after them, are its doing, not their slaves'.
  void second_master() {
    const ProblemEvidence::Events& cut = evidence_.interruptions();
    if (cut.count < some || share(cut.count, evidence_.requests_seen()) < second_master_share)
      return;
    Problem& p =
        add(ProblemKind::second_master, std::nullopt, Severity::error, *cut.first_ns, cut.first);
    p.evidence = {{"requests_cut_short", cut.count}, {"requests", evidence_.requests_seen()}};
    p.text = fmt::format(
        "Two masters on the line: {} requests ({:.0f}%) came while another request's answer was "
        "due, sooner than a master waits, as a second master polling on its own does",
        cut.count, percent(cut.count, evidence_.requests_seen()));
  }

  // Bad checks on requests, or on the answers of several slaves alike: the line, not a device.
  void bus_noise() {
    if (reflections() || noise_bursts()) return;  // the line's damage, told by its cause
    const auto& bad = evidence_.bad_requests();
    uint64_t damaged = bad.count;
    size_t slaves_hit = 0;
    std::optional<int64_t> since = bad.first_ns;
    for (const auto& [address, s] : evidence_.slaves()) {
      if (damage_explained_[address]) continue;  // a problem of that device's own
      damaged += s.damaged.count;
      slaves_hit += s.damaged.count >= few;
      if (s.damaged.first_ns) since = std::min(since.value_or(INT64_MAX), *s.damaged.first_ns);
    }
    const double rate = share(damaged, statistics_.frames);
    if (damaged < 2 * some || rate < noise_share || (bad.count < few && slaves_hit < 2)) return;
    Problem& p = add(ProblemKind::bus_noise, std::nullopt,
                     rate >= noise_share_error ? Severity::error : Severity::warning,
                     since.value_or(0), bad.first);
    p.evidence = {{"damaged_frames", damaged},
                  {"frames", statistics_.frames},
                  {"damaged_requests", bad.count},
                  {"slaves_with_damaged_answers", slaves_hit}};
    p.text = fmt::format(
        "Bad checks all over the bus: {:.1f}% of frames ({} of {}), on {} "
        "requests and on the answers of {} {}",
        100 * rate, damaged, statistics_.frames, bad.count, slaves_hit,
        slaves_hit == 1 ? "slave" : "slaves");
  }

  void rejected_requests() {
    for (const auto& [key, asked] : evidence_.requests())
      for (const auto& [code, events] : asked.by_exception)
        if (events.count >= some && share(events.count, asked.requests) >= rejected_share)
          rejected(key, asked.requests, code, events);
  }

  void rejected(const ProblemEvidence::RequestKey& key, uint64_t requests, uint8_t code,
                const ProblemEvidence::Events& events) {
    const auto [address, fc, start, quantity] = key;
    const auto it = evidence_.slaves().find(address);
    const Slave none;
    const Slave& slave = it == evidence_.slaves().end() ? none : it->second;
    Problem& p = add(ProblemKind::rejected_requests, address, Severity::warning, *events.first_ns,
                     events.first);
    p.evidence = {{"function", fc},    {"address", start},         {"quantity", quantity},
                  {"exception", code}, {"answered", events.count}, {"requests", requests}};
    // The model's meaning of the code, where it gives one, is its name and says why.
    const std::string_view meaning = slave.model ? exception_meaning(*slave.model, code) : "";
    const std::string_view name = meaning.empty() ? exception_name(code) : meaning;
    std::vector<std::string> what;
    if (const std::string reg = register_name(slave, fc, start); !reg.empty()) what.push_back(reg);
    if (quantity > 1) what.push_back(fmt::format("{} registers", quantity));
    const std::string detail = what.empty() ? "" : fmt::format(" ({})", fmt::join(what, ", "));
    p.text = fmt::format("{} answers {} {} of {:04X}H{} with exception {:02X}H{}{}{}: {} of {}",
                         who(address, slave), events.count == requests ? "every" : "nearly every",
                         verb(fc), start, detail, code, name.empty() ? "" : " (", name,
                         name.empty() ? "" : ")", events.count, requests);
    const std::string_view why =
        meaning.empty() ? exception_advice(code)
                        : "the device gives its own reason (above): its manual says what to change";
    p.advice = fmt::format("{}; {}", why, problem_info(p.kind).advice);
  }

  static std::string_view verb(uint8_t fc) {
    if (fc <= 0x04) return "read";
    return fc == 0x17 ? "read/write" : "write";
  }

  // "P04.00": the model's name for the first register asked for, where it has one.
  static std::string register_name(const Slave& slave, uint8_t fc, uint16_t start) {
    if (!slave.model) return "";
    constexpr std::array tables{Table::coil,  Table::discrete, Table::holding,
                                Table::input, Table::coil,     Table::holding};
    const Table table = fc <= 0x06 ? tables[fc - 1] : fc == 0x0F ? Table::coil : Table::holding;
    // The lookup holds a parameter the group rule made: it lives as long as the lookup.
    const RegisterLookup lookup = find_register(*slave.model, table, start);
    const RegisterDef* def = lookup.def();
    return def ? def->name : "";
  }

  // What an exception code says the master did wrong, in the standard's terms.
  static std::string_view exception_advice(uint8_t code) {
    switch (code) {
      case 0x01:
        return "the device does not support this function";
      case 0x02:
        return "the master asks for registers this device does not have";
      case 0x03:
        return "the device refuses the quantity or value asked for";
      case 0x04:
        return "the device failed to carry it out: read its fault code";
      case 0x06:
        return "the device is busy with a long command: the master asks again too soon";
      default:
        return "the device refuses it with its own code: see its manual's exception table";
    }
  }

  MedianOfOthers latency_medians_, damaged_rates_, missed_rates_;
  uint64_t bus_damaged_ = 0, bus_overlapping_ = 0, bus_requests_ = 0;  // every slave's, summed
  std::array<bool, 256> damage_explained_{};  // slaves whose bad checks a problem of theirs tells
  const BusStatistics& statistics_;
  const ProblemEvidence& evidence_;
  const ProblemOptions& options_;
  std::vector<Problem> problems_;
};

}  // namespace

std::vector<Problem> find_problems(const BusStatistics& statistics, const ProblemEvidence& evidence,
                                   const ProblemOptions& options) {
  return Diagnosis(statistics, evidence, options).run();
}

std::string read_it_with(const BetterSettings& better, const SerialFormat& given) {
  const SerialFormat& f = better.format;
  return fmt::format(
      "at {}, {:.0f}% do: read it with --baud {} --parity {}{}", describe(f),
      100 * better.good_share, f.baud, to_string(f.parity),
      f.stop_bits == given.stop_bits ? "" : fmt::format(" --stop-bits {}", f.stop_bits));
}

}  // namespace modtap
