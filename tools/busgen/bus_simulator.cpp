#include "tools/busgen/bus_simulator.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>

#include "decoder/protocol/checksum.hpp"
#include "decoder/protocol/function_codes.hpp"

namespace modtap::busgen {
using Bytes = std::vector<uint8_t>;

void encode_frame(Mode mode, const Bytes& body, Bytes& out) {
  if (mode == Mode::rtu) {
    out.insert(out.end(), body.begin(), body.end());
    const uint16_t crc = crc16(body);
    out.push_back(static_cast<uint8_t>(crc & 0xFF));
    out.push_back(static_cast<uint8_t>(crc >> 8));
    return;
  }
  static constexpr char hex[] = "0123456789ABCDEF";
  auto put = [&](uint8_t b) {
    out.push_back(static_cast<uint8_t>(hex[b >> 4]));
    out.push_back(static_cast<uint8_t>(hex[b & 15]));
  };
  out.push_back(':');
  for (uint8_t b : body) put(b);
  put(lrc(body));
  out.push_back('\r');
  out.push_back('\n');
}

namespace {

constexpr int64_t restart_silence_ns = 5'000'000'000;  // how long a restarting slave is silent
constexpr int64_t slow_block_ns = 60'000'000;          // a slow block's answer time, at least

class Simulator {
 public:
  explicit Simulator(const BusOptions& o)
      : o_(o), rng_(o.seed), char_ns_(o.format.char_time_ns()), t35_(o.format.t35_ns()) {
    // A slave whose faults are all off is a healthy slave, to the last random number.
    for (const auto& [slave, faults] : o_.slave_faults)
      if (slave >= 1 && slave <= 247 && faults != SlaveFaults{}) faults_[slave] = &faults;
  }

  BusCapture run() {
    for (size_t i = 0; i < o_.transactions; ++i) transaction();
    return std::move(capture_);
  }

 private:
  unsigned pick(unsigned lo, unsigned hi) {
    return std::uniform_int_distribution<unsigned>(lo, hi)(rng_);
  }
  bool chance(double p) { return p > 0 && std::uniform_real_distribution<double>(0, 1)(rng_) < p; }
  static void u16(Bytes& b, unsigned v) {
    b.push_back(static_cast<uint8_t>(v >> 8));
    b.push_back(static_cast<uint8_t>(v & 0xFF));
  }
  // Where bytes that are no frame hold a span of 4 or more whose RTU CRC holds, the end of the
  // first such span: no receiver could call it anything but a frame (1 span in 65,536 by
  // chance, a few a run in a long sweep), so junk and broken-off requests are kept free of one.
  std::optional<size_t> good_span_end(const Bytes& b) const {
    if (o_.mode != Mode::rtu) return std::nullopt;
    for (size_t first = 0; first + 4 <= b.size(); ++first) {
      uint16_t crc = 0xFFFF;  // over a span and its own CRC, the register comes back to 0
      for (size_t end = first + 1; end <= b.size(); ++end) {
        crc = crc16_step(crc, b[end - 1]);
        if (crc == 0 && end - first >= 4) return end;
      }
    }
    return std::nullopt;
  }

  void random_bytes(Bytes& b, size_t n) {
    for (size_t i = 0; i < n; ++i) b.push_back(static_cast<uint8_t>(pick(0, 255)));
  }

  // Bytes go on the wire back to back, starting `gap_ns` after the previous byte ended.
  uint64_t send(const Bytes& wire, int64_t gap_ns) {
    const uint64_t offset = capture_.bytes.size();
    int64_t t = (capture_.end_ns.empty() ? 0 : capture_.end_ns.back()) + gap_ns;
    for (uint8_t b : wire) {
      t += char_ns_;
      capture_.bytes.push_back(b);
      capture_.end_ns.push_back(t);
    }
    return offset;
  }

  // `corruption_rate` is the sender's own, on top of the line's.
  size_t send_frame(const Bytes& body, Role role, int64_t gap_ns, std::optional<size_t> request,
                    double corruption_rate = 0.0) {
    Bytes adu = adu_of(body);
    uint32_t findings = 0;
    auto damage = Damage::none;
    gap_ns = bursts_before(gap_ns);
    const bool burst = burst_hits(gap_ns, static_cast<int64_t>(wire_of(adu).size()) * char_ns_);
    if ((burst || chance(corruption_rate) || chance(o_.corruption_rate) ||
         chance(reflection_odds(adu.size()))) &&
        corrupt(adu, role)) {
      findings = finding_bad_check;
      damage = Damage::corrupted;
    }
    const Bytes wire = wire_of(adu);
    uint64_t offset;
    if (o_.mode == Mode::rtu && chance(o_.pause_rate)) {
      offset = send_with_pause(wire, gap_ns);
      findings |= finding_gap_in_frame;
    } else {
      offset = send(wire, gap_ns);
    }
    capture_.frames.push_back(
        {offset, static_cast<uint32_t>(wire.size()), role, request, findings, damage, body[0]});
    return capture_.frames.size() - 1;
  }

  int64_t now_ns() const { return capture_.end_ns.empty() ? 0 : capture_.end_ns.back(); }

  // The second master's read of its slave, where its time has come: request and answer, each
  // after a quiet line.
  // Whether it polled.
  bool second_master_polls() {
    if (!o_.second_master_period_ns) return false;
    if (!next_second_poll_ns_) next_second_poll_ns_ = o_.second_master_period_ns;
    if (now_ns() < next_second_poll_ns_) return false;
    next_second_poll_ns_ = now_ns() + o_.second_master_period_ns;
    constexpr uint8_t its_slave = 201;
    Bytes request{its_slave, 0x03}, response{its_slave, 0x03, 2};
    u16(request, 0x0100);
    u16(request, 1);
    u16(response, pick(0, 1000));
    const size_t req = send_frame(request, Role::request, t35_ + pick(0, 2'000'000), std::nullopt);
    send_frame(response, Role::response, t35_ + pick(0, 3'000'000), req);
    return true;
  }

  // The noise bursts due before a frame that starts `gap_ns` from now, each junk in the gap
  // where it falls there with a silence after it; the gap left to the frame.
  int64_t bursts_before(int64_t gap_ns) {
    if (!o_.noise_burst_period_ns) return gap_ns;
    if (!next_burst_ns_) next_burst_ns_ = o_.noise_burst_period_ns;
    const int64_t frame_ns = now_ns() + gap_ns;
    while (next_burst_ns_ < frame_ns) {
      const int64_t now = now_ns();
      Bytes junk;
      random_bytes(junk, pick(2, 6));
      while (const auto good = good_span_end(junk)) junk[*good - 1] ^= 1;
      const int64_t junk_ns = static_cast<int64_t>(junk.size()) * char_ns_;
      // One on bytes sent already went with them; one too close to the frame is on the frame.
      if (next_burst_ns_ + junk_ns + t35_ > frame_ns) return gap_ns;
      if (next_burst_ns_ >= now + t35_) send(junk, next_burst_ns_ - now);
      next_burst_ns_ += o_.noise_burst_period_ns + pick(0, 1'000'000);
    }
    return frame_ns - now_ns();
  }

  // Whether the next noise burst falls on a frame `gap_ns` from now lasting `frame_ns` (or just
  // before it): the frame is damaged, and the burst spent.
  bool burst_hits(int64_t gap_ns, int64_t frame_ns) {
    if (!o_.noise_burst_period_ns || next_burst_ns_ >= now_ns() + gap_ns + frame_ns) return false;
    next_burst_ns_ += o_.noise_burst_period_ns + pick(0, 1'000'000);
    return true;
  }

  double reflection_odds(size_t length) const {
    if (length <= 8) return 0;
    return o_.reflection_rate * std::min(1.0, static_cast<double>(length - 8) / 24);
  }

  size_t check_size() const { return o_.mode == Mode::rtu ? 2 : 1; }

  // Slave, PDU and check, in binary.
  Bytes adu_of(const Bytes& body) const {
    Bytes adu = body;
    if (o_.mode == Mode::ascii) {
      adu.push_back(lrc(body));
      return adu;
    }
    const uint16_t crc = crc16(body);
    adu.push_back(static_cast<uint8_t>(crc & 0xFF));
    adu.push_back(static_cast<uint8_t>(crc >> 8));
    return adu;
  }

  Bytes wire_of(const Bytes& adu) const {
    if (o_.mode == Mode::rtu) return adu;
    static constexpr char hex[] = "0123456789ABCDEF";
    Bytes wire{':'};
    for (uint8_t b : adu) {
      wire.push_back(static_cast<uint8_t>(hex[b >> 4]));
      wire.push_back(static_cast<uint8_t>(hex[b & 15]));
    }
    wire.push_back('\r');
    wire.push_back('\n');
    return wire;
  }

  bool check_ok(const Bytes& adu) const {
    const std::span<const uint8_t> body(adu.data(), adu.size() - check_size());
    if (o_.mode == Mode::ascii) return lrc(body) == adu.back();
    return crc16(body) == (adu[adu.size() - 2] | adu.back() << 8);
  }

  // A bit flipped in 1 to 3 bytes on the way. Never in a byte the frame's length is told by (the
  // function code, a byte count), and the address stays one (1-247): the frame arrives whole,
  // its check bad, still its slave's. False, and nothing changed, where an RTU frame's length
  // is no header's to tell (only a search for its CRC finds its end).
  bool corrupt(Bytes& adu, Role role) {
    const size_t body_size = adu.size() - check_size();
    auto length_of = [&] { return body_length(role, {adu.data(), body_size}); };
    using Kind = BodyLength::Kind;
    const auto length = length_of();
    if (length.kind == Kind::invalid || (o_.mode == Mode::rtu && length.kind != Kind::known))
      return false;
    auto keeps_structure = [&](size_t at) {
      if (at == 0) return adu[0] >= 1 && adu[0] <= 247;
      if (at == 1) return false;
      if (at >= body_size) return true;
      const auto now = length_of();
      return now.kind == length.kind && now.bytes == length.bytes;
    };
    // Flipped so that a good span appears inside (1 in 65,536 a start), the frame is flipped
    // afresh: no receiver could read those bytes as anything but that frame (good_span_end).
    const Bytes sent = adu;
    for (int attempt = 0; attempt < 64; ++attempt) {
      adu = sent;
      for (unsigned hits = pick(1, 3); hits > 0; --hits) {
        for (;;) {
          const size_t at = pick(0, static_cast<unsigned>(adu.size() - 1));
          const auto bit = static_cast<uint8_t>(1u << pick(0, 7));
          adu[at] ^= bit;
          if (keeps_structure(at)) break;
          adu[at] ^= bit;
        }
      }
      if (check_ok(adu)) adu.back() ^= 1;  // the hits cancelled out, or kept the check
      if (!good_span_end(adu)) break;
    }
    return true;
  }

  // The sender stalls once between two of the frame's bytes, longer than t1.5 but short of the
  // t3.5 that would end the frame.
  uint64_t send_with_pause(const Bytes& wire, int64_t gap_ns) {
    const auto split = static_cast<ptrdiff_t>(pick(1, static_cast<unsigned>(wire.size() - 1)));
    const int64_t t15 = o_.format.t15_ns();
    const int64_t pause = t15 + (t35_ - t15) * pick(2, 8) / 10;
    const uint64_t offset = send(Bytes(wire.begin(), wire.begin() + split), gap_ns);
    send(Bytes(wire.begin() + split, wire.end()), pause);
    return offset;
  }

  // A master that got no answer sends nothing before its time-out is over (back to back, the
  // bus has no silences at all).
  int64_t idle_gap() {
    const int64_t timing_out = std::exchange(timing_out_ns_, 0);
    if (o_.back_to_back) return 0;
    return std::max(o_.poll_gap_ns, t35_) + pick(0, 2'000'000) + timing_out;
  }

  // The next slave of the scan list (a broadcast goes between two polls, taking no one's turn),
  // or any slave. A slave with a missing block is read twice a cycle: its first registers, then
  // the block (`block_read_`).
  uint8_t next_slave() {
    if (o_.polled_slaves == 0) return static_cast<uint8_t>(pick(1, 247));
    if (block_due_) {
      block_read_ = true;
      return std::exchange(block_due_, 0);
    }
    const auto slave = static_cast<uint8_t>(polls_++ % o_.polled_slaves + 1);
    if (faults_[slave] && (faults_[slave]->missing_block || faults_[slave]->slow_block))
      block_due_ = slave;
    return slave;
  }

  void transaction() {
    const bool broadcast = chance(o_.broadcast_rate);
    block_read_ = false;
    const uint8_t slave = broadcast ? 0 : next_slave();
    const SlaveFaults* faults = faults_[slave];
    Bytes request{slave}, response{slave};
    uint32_t request_findings = 0;
    if (block_read_ && faults->missing_block) {
      read_missing_block(*faults->missing_block, request, response);
    } else if (block_read_) {
      read_block(*faults->slow_block, request, response);
    } else if (!broadcast && chance(o_.out_of_spec_rate)) {
      request_findings = out_of_spec(request, response);
    } else if (o_.polled_slaves) {
      scan_step(slave, request, response);
    } else {
      build(slave, request, response, broadcast);
    }

    if (chance(o_.noise_rate)) {
      Bytes junk;
      random_bytes(junk, pick(1, 40));
      while (const auto good = good_span_end(junk)) junk[*good - 1] ^= 1;
      send(junk, idle_gap());
    }
    if (chance(o_.truncation_rate)) {
      Bytes wire;
      encode_frame(o_.mode, request, wire);
      wire.resize(pick(1, static_cast<unsigned>(wire.size() - 1)));
      // Broken off where its bytes pass a CRC of their own (an FC08 query whose CRC ends in
      // 0x00, cut before it), it holds a good frame to any receiver: broken off sooner.
      while (const auto good = good_span_end(wire)) wire.resize(*good - 1);
      send(wire, idle_gap());
    }
    size_t req = send_request(request, request_findings, idle_gap());
    if (broadcast) return;
    // The answer comes after the other master's exchange, paired with its request then.
    bool after_other_master = second_master_polls();
    // A corrupted request no slave takes; a retry is one only after a copy the analyzer saw.
    bool unanswered_copy = false;
    for (unsigned retries = 0;; ++retries) {
      const bool corrupted = capture_.frames[req].damage != Damage::none;
      if (!corrupted && !silent(faults) && !chance(o_.no_response_rate)) break;
      if (!corrupted) capture_.timed_out.push_back(req);
      unanswered_copy |= !corrupted;
      // Retries only once the bus has shown how fast slaves answer: before that, a copy of an
      // echo request is ambiguous by design (docs/framing.md, "Retries and echoes"). A master
      // gives a faulty slave up after its usual three retries (it may never answer).
      if (answered_ < 20 || (faults && retries == 3) || !chance(o_.retry_rate)) {
        timing_out_ns_ = o_.retry_after_ns;
        return;
      }
      req =
          send_request(request, request_findings | (unanswered_copy ? uint32_t{finding_retry} : 0u),
                       o_.retry_after_ns + pick(0, 50'000'000));
      after_other_master = false;
    }
    int64_t turnaround =
        chance(o_.fast_turnaround_rate) ? char_ns_ * pick(15, 30) / 10 : t35_ + pick(0, 3'000'000);
    if (o_.min_turnaround_ns) turnaround = o_.min_turnaround_ns + pick(0, 3'000'000);
    if (o_.back_to_back) turnaround = 0;
    if (faults) turnaround = slave_turnaround(*faults, turnaround);
    // An answer after the master's time-out: the master has given up on it, and sends its next
    // request its usual idle time after the answer ends (it does not talk over a frame).
    const bool late = faults && turnaround >= o_.retry_after_ns;
    const bool half_baud = faults && faults->half_baud;
    if (half_baud || chance(o_.garbled_rate)) {
      // Junk in the answer's time is the answer, garbled; after the time-out, too late.
      if (late) capture_.timed_out.push_back(req);
      timing_out_ns_ = late ? 0 : o_.retry_after_ns;  // what came was no answer it could read
      return half_baud ? send_at_half_baud(slave, response, turnaround)
                       : send_garbled(slave, turnaround);
    }
    if (late) capture_.timed_out.push_back(req);
    if ((faults && faults->turnaround_glitch) || chance(o_.glitch_rate))
      turnaround = glitch(turnaround);
    if (!late) ++answered_;
    const size_t first = capture_.frames.size();
    answer(response, turnaround, req, faults, late);
    for (size_t i = first; i < capture_.frames.size(); ++i) {
      TruthFrame& frame = capture_.frames[i];
      frame.late = late;
      if (after_other_master && frame.role == Role::response && frame.request == req)
        frame.findings |= finding_after_other_master;
    }
  }

  void answer(const Bytes& response, int64_t turnaround, size_t req, const SlaveFaults* faults,
              bool late) {
    if (faults && faults->duplicate_address) return send_clash(response, turnaround, req, late);
    if (damageable(response) && chance(o_.cut_rate)) return send_cut(response, turnaround, req);
    if (damageable(response) && chance(o_.collision_rate))
      return send_collided(response, turnaround, req);
    send_frame(response, Role::response, turnaround, req, faults ? faults->corruption_rate : 0.0);
  }

  // Whether a faulty slave lets this request go unanswered: it is not there, or no longer, or
  // it missed it.
  bool silent(const SlaveFaults* faults) {
    if (!faults) return false;
    if (faults->absent) return true;
    const int64_t now = capture_.end_ns.back();
    if (faults->stops_after_ns && now >= *faults->stops_after_ns) return true;
    if (const auto every = faults->restarts_every_ns;
        every && now >= *every && now % *every < restart_silence_ns)
      return true;
    return chance(faults->drop_rate);
  }

  int64_t slave_turnaround(const SlaveFaults& faults, int64_t turnaround) {
    if (block_read_ && faults.slow_block) return slow_block_ns + pick(0, 3'000'000);
    if (faults.answers_after_timeout) return o_.retry_after_ns + t35_ + pick(0, 3'000'000);
    if (faults.turnaround_ns) return *faults.turnaround_ns + pick(0, 3'000'000);
    return turnaround;
  }

  // The master's spec findings and retry hold only for a request the slaves could read.
  size_t send_request(const Bytes& request, uint32_t findings, int64_t gap_ns) {
    if (chance(o_.request_glitch_rate)) gap_ns = glitch(gap_ns);
    const size_t req = send_frame(request, Role::request, gap_ns, std::nullopt);
    if (capture_.frames[req].damage == Damage::none) capture_.frames[req].findings |= findings;
    return req;
  }

  // A driver turning on puts one 0x00 or 0xFF on the bus; the frame follows 0 to 2 characters
  // later. Returns that gap.
  int64_t glitch(int64_t gap_ns) {
    send(Bytes{chance(0.5) ? uint8_t{0x00} : uint8_t{0xFF}}, gap_ns);
    return char_ns_ * pick(0, 20) / 10;
  }

  // Damage is told from the response's own structure, so only responses whose header gives
  // their length are damaged here (RTU; ASCII frames end at their CR LF).
  bool damageable(const Bytes& response) const {
    if (o_.mode != Mode::rtu) return false;
    const auto length = body_length(Role::response, response);
    return length.kind == BodyLength::Kind::known;
  }

  void send_cut(const Bytes& response, int64_t gap_ns, size_t req) {
    Bytes wire;
    encode_frame(o_.mode, response, wire);
    wire.resize(pick(3, static_cast<unsigned>(wire.size() - 1)));
    send_damaged(wire, gap_ns, req, Damage::cut, response[0]);
  }

  // Another device starts while the response's last bytes are on the wire: they arrive garbled
  // and the other device's bytes follow at once.
  void send_collided(const Bytes& response, int64_t gap_ns, size_t req) {
    Bytes wire;
    encode_frame(o_.mode, response, wire);
    const size_t garbled = pick(1, 3);
    for (size_t i = wire.size() - garbled; i < wire.size(); ++i)
      wire[i] ^= static_cast<uint8_t>(pick(1, 255));
    // Garbled into a good frame, or junk that is one by chance, no receiver could tell them
    // from frames: the check is kept failing, as a corruption's is.
    if (check_ok(wire)) wire.back() ^= 1;
    send_damaged(wire, gap_ns, req, Damage::collision, response[0]);
    Bytes other;
    random_bytes(other, pick(1, 6));
    if (other.size() >= 4 && check_ok(other)) other.back() ^= 1;
    send(other, 0);
  }

  // An answer at another baud rate or character format reads as junk: never the slave's address
  // first (that would read as its damaged answer), never a lone glitch.
  void send_garbled(uint8_t slave, int64_t gap_ns) {
    Bytes junk;
    random_bytes(junk, pick(3, 12));
    if (junk[0] == slave) junk[0] ^= 0x80;
    capture_.garbled.push_back(send(junk, gap_ns));
  }

  // An answer sent at half the line's baud rate: every character it sends reads as about two
  // of the line's, none of them its own (the receiver finds its start bits in the middle of the
  // sender's), and no span of them a frame.
  void send_at_half_baud(uint8_t slave, const Bytes& response, int64_t gap_ns) {
    Bytes junk;
    random_bytes(junk, 2 * static_cast<unsigned>(adu_of(response).size()));
    if (junk[0] == slave) junk[0] ^= 0x80;
    while (const auto good = good_span_end(junk)) junk[*good - 1] ^= 1;
    capture_.garbled.push_back(send(junk, gap_ns));
  }

  void send_damaged(const Bytes& wire, int64_t gap_ns, size_t req, Damage damage, uint8_t slave) {
    const uint64_t offset = send(wire, gap_ns);
    capture_.frames.push_back({offset, static_cast<uint32_t>(wire.size()), Role::response, req,
                               finding_bad_check, damage, slave});
  }

  // Two devices with the slave's address answer together, the second 0 to 1.9 characters after
  // the first, in steps of about a bit. Begun within the same bit, the bytes they agree on come
  // through and the rest is garbage: a frame whole but for its check, unless they said the same.
  // Begun apart, the receiver never finds the characters' starts again: junk from the first
  // byte both drove, as long as both answers together. Nothing after a whole first byte (the
  // address) is this answer's function code, so the junk never reads as the slave's damaged
  // answer; in ASCII it holds no ':' to start a frame.
  void send_clash(const Bytes& response, int64_t gap_ns, size_t req, bool late) {
    const Bytes mine = adu_of(response), theirs = adu_of(twin_answer(response));
    const unsigned delay = pick(0, 19);  // in tenths of a character
    if (delay == 0) {
      Bytes adu(mine.size());
      do {
        for (size_t i = 0; i < adu.size(); ++i)
          adu[i] = mine[i] == theirs[i] ? mine[i] : static_cast<uint8_t>(pick(0, 255));
      } while (adu != mine && check_ok(adu));
      const bool whole = adu == mine;
      const Bytes wire = wire_of(adu);
      const uint64_t offset = send(wire, gap_ns);
      const auto size = static_cast<uint32_t>(wire.size());
      capture_.frames.push_back({offset, size, Role::response, req,
                                 whole ? 0u : uint32_t{finding_bad_check},
                                 whole ? Damage::none : Damage::corrupted, response[0]});
      capture_.clashes.push_back({req, offset, size});
      return;
    }
    const Bytes first = wire_of(mine);
    const size_t whole = o_.mode == Mode::rtu ? delay / 10 : 0;
    Bytes junk(first.begin(), first.begin() + static_cast<ptrdiff_t>(whole));
    random_bytes(junk, first.size() + (delay + 9) / 10 - whole);
    const uint8_t fc = response[1] & 0x7F;
    for (size_t i = whole; i < junk.size(); ++i) {
      while ((o_.mode == Mode::ascii && junk[i] == ':') || (i == 0 && junk[0] == response[0]) ||
             (i == 1 && (junk[1] & 0x7F) == fc))
        junk[i] = static_cast<uint8_t>(pick(0, 255));
    }
    const uint64_t offset = send(junk, gap_ns);
    capture_.garbled.push_back(offset);
    capture_.clashes.push_back({req, offset, static_cast<uint32_t>(junk.size())});
    // In the answer's time the junk is the answer, garbled: no time-out, but the master waits
    // its time-out out, as it cannot tell where the junk ends.
    if (late) return;  // the master gave up already
    timing_out_ns_ = o_.retry_after_ns;
  }

  // The other device's answer: the same header, and its own values where it reads them.
  Bytes twin_answer(const Bytes& response) {
    Bytes twin = response;
    if (twin.size() > 3 && twin[1] >= 0x01 && twin[1] <= 0x04)
      for (size_t i = 3; i < twin.size(); ++i) twin[i] = static_cast<uint8_t>(pick(0, 255));
    return twin;
  }

  // A request over the standard's limits, as masters do send them, and the slave's exception
  // 03. Returns what the analyzer must say of the request.
  uint32_t out_of_spec(Bytes& req, Bytes& rsp) {
    const unsigned kind = pick(0, 3);
    const uint8_t fc = static_cast<uint8_t>(kind == 0   ? pick(3, 4)
                                            : kind == 1 ? pick(1, 2)
                                            : kind == 2 ? 0x10
                                                        : 0x0F);
    req.push_back(fc);
    u16(req, pick(0, 1000));
    uint32_t findings = finding_quantity_out_of_spec;
    if (kind == 0) u16(req, chance(0.2) ? 0 : pick(126, 300));
    if (kind == 1) u16(req, chance(0.2) ? 0 : pick(2001, 4000));
    if (kind >= 2) {  // a byte count one more than the quantity needs
      const unsigned qty = pick(1, 20);
      const unsigned count = (kind == 2 ? qty * 2 : (qty + 7) / 8) + 1;
      u16(req, qty);
      req.push_back(static_cast<uint8_t>(count));
      random_bytes(req, count);
      findings = finding_byte_count_mismatch;
    }
    exception(rsp, fc, 0x03);
    return findings;
  }

  void exception(Bytes& rsp, uint8_t fc, uint8_t code) {
    rsp.push_back(static_cast<uint8_t>(fc | 0x80));
    rsp.push_back(code);
  }

  bool reads_missing(uint8_t slave, unsigned start, unsigned count) const {
    const SlaveFaults* faults = faults_[slave];
    if (!faults || !faults->missing_block) return false;
    const RegisterBlock& block = *faults->missing_block;
    return start < block.start + block.count && block.start < start + count;
  }

  void read_block(const RegisterBlock& block, Bytes& req, Bytes& rsp) {
    req.push_back(0x03);
    u16(req, block.start);
    u16(req, block.count);
    rsp.push_back(0x03);
    rsp.push_back(static_cast<uint8_t>(2 * block.count));
    for (unsigned i = 0; i < block.count; ++i) u16(rsp, pick(0, 0xFFFF));
  }

  void read_missing_block(const RegisterBlock& block, Bytes& req, Bytes& rsp) {
    req.push_back(0x03);
    u16(req, block.start);
    u16(req, block.count);
    exception(rsp, 0x03, 0x02);
  }

  // A scan list's step: a read of the slave's first registers, whose values drift as a drive's
  // frequency and current do (so a register followed over time draws a line), or between polls
  // a setpoint broadcast to all.
  void scan_step(uint8_t slave, Bytes& req, Bytes& rsp) {
    if (slave == 0) {
      req.push_back(0x06);
      u16(req, 0x0010);
      u16(req, pick(0, 1000));
      return;
    }
    auto& values = drifting_[slave];
    req.push_back(0x03);
    u16(req, 0x0000);
    u16(req, values.size());
    if (reads_missing(slave, 0x0000, values.size())) return exception(rsp, 0x03, 0x02);
    if (chance(o_.exception_rate)) return exception(rsp, 0x03, chance(0.5) ? 0x02 : 0x04);
    rsp.push_back(0x03);
    rsp.push_back(static_cast<uint8_t>(values.size() * 2));
    for (uint16_t& value : values) {
      value = static_cast<uint16_t>(
          std::clamp<int>(value + static_cast<int>(pick(0, 20)) - 10, 0, 1000));
      u16(rsp, value);
    }
  }

  void build(uint8_t slave, Bytes& req, Bytes& rsp, bool broadcast) {
    const auto unicast = public_function_codes();
    static constexpr uint8_t writes[] = {0x05, 0x06, 0x0F, 0x10};
    uint8_t fc = broadcast ? writes[pick(0, 3)]
                           : unicast[pick(0, static_cast<unsigned>(unicast.size() - 1))].code;
    if (!broadcast && chance(o_.unknown_function_rate)) fc = static_cast<uint8_t>(pick(0x41, 0x48));
    req.push_back(fc);
    const bool fails = chance(o_.exception_rate);
    if (!fails) rsp.push_back(fc);
    fill(fc, req, rsp);
    if (fails) {
      rsp.resize(1);
      static constexpr uint8_t codes[] = {0x01, 0x02, 0x03, 0x04, 0x06};
      exception(rsp, fc, codes[pick(0, 4)]);
    } else if (fc == 0x03 && reads_missing(slave, req[2] << 8 | req[3], req[4] << 8 | req[5])) {
      rsp.resize(1);
      exception(rsp, fc, 0x02);
    }
  }

  // A request of each function code and the answer it gets, with random fields, by code.
  using Filler = void (Simulator::*)(uint8_t fc, Bytes& req, Bytes& rsp);
  void fill(uint8_t fc, Bytes& req, Bytes& rsp) {
    static constexpr std::pair<uint8_t, Filler> fillers[] = {
        {0x01, &Simulator::read_bits},      {0x02, &Simulator::read_bits},
        {0x03, &Simulator::read_registers}, {0x04, &Simulator::read_registers},
        {0x05, &Simulator::write_coil},     {0x06, &Simulator::write_register},
        {0x16, &Simulator::write_register}, {0x07, &Simulator::read_status},
        {0x08, &Simulator::diagnostics},    {0x0B, &Simulator::event_counter},
        {0x0C, &Simulator::event_log},      {0x0F, &Simulator::write_multiple},
        {0x10, &Simulator::write_multiple}, {0x11, &Simulator::server_id},
        {0x14, &Simulator::read_file},      {0x15, &Simulator::write_file},
        {0x17, &Simulator::read_write},     {0x18, &Simulator::read_fifo},
        {0x2B, &Simulator::identification},
    };
    for (const auto& [code, filler] : fillers)
      if (code == fc) return (this->*filler)(fc, req, rsp);
    vendor_function(fc, req, rsp);
  }

  void read_bits(uint8_t, Bytes& req, Bytes& rsp) {
    const unsigned qty = pick(1, 80);
    u16(req, pick(0, 0xFFFF - qty));
    u16(req, qty);
    rsp.push_back(static_cast<uint8_t>((qty + 7) / 8));
    random_bytes(rsp, (qty + 7) / 8);
  }

  void read_registers(uint8_t, Bytes& req, Bytes& rsp) {
    const unsigned qty = pick(1, 40);
    u16(req, pick(0, 0xFFFF - qty));
    u16(req, qty);
    rsp.push_back(static_cast<uint8_t>(qty * 2));
    random_bytes(rsp, qty * 2);
  }

  void write_coil(uint8_t, Bytes& req, Bytes& rsp) {
    u16(req, pick(0, 0xFFFF));
    u16(req, chance(0.5) ? 0xFF00 : 0x0000);
    rsp.assign(req.begin(), req.end());
  }

  // FC06, and FC16 Mask Write Register: both answered by their echo.
  void write_register(uint8_t fc, Bytes& req, Bytes& rsp) {
    u16(req, pick(0, 0xFFFF));
    random_bytes(req, fc == 0x06 ? 2 : 4);
    rsp.assign(req.begin(), req.end());
  }

  void read_status(uint8_t, Bytes&, Bytes& rsp) {
    rsp.push_back(static_cast<uint8_t>(pick(0, 255)));
  }

  // Return Query Data (0000) echoes its data; the counters answer with a value of their own.
  void diagnostics(uint8_t, Bytes& req, Bytes& rsp) {
    static constexpr uint16_t subs[] = {0x0000, 0x000A, 0x000B, 0x000C, 0x000D, 0x000E, 0x0012};
    const uint16_t sub = subs[pick(0, 6)];
    u16(req, sub);
    random_bytes(req, sub == 0 ? pick(1, 4) * 2 : 2);
    if (sub != 0) std::fill(req.end() - 2, req.end(), 0);  // a counter's request carries 0000
    rsp.assign(req.begin(), req.end());
    if (sub != 0) {
      rsp.resize(rsp.size() - 2);
      random_bytes(rsp, 2);
    }
  }

  void event_counter(uint8_t, Bytes&, Bytes& rsp) { random_bytes(rsp, 4); }

  void event_log(uint8_t, Bytes&, Bytes& rsp) {
    const unsigned events = pick(0, 20);
    rsp.push_back(static_cast<uint8_t>(6 + events));
    random_bytes(rsp, 6 + events);
  }

  // FC0F coils and FC10 registers: the answer repeats the address and quantity.
  void write_multiple(uint8_t fc, Bytes& req, Bytes& rsp) {
    const unsigned qty = fc == 0x0F ? pick(1, 80) : pick(1, 30);
    const unsigned count = fc == 0x0F ? (qty + 7) / 8 : qty * 2;
    u16(req, pick(0, 0xFFFF - qty));
    u16(req, qty);
    req.push_back(static_cast<uint8_t>(count));
    random_bytes(req, count);
    rsp.insert(rsp.end(), req.begin() + 2, req.begin() + 6);
  }

  void server_id(uint8_t, Bytes&, Bytes& rsp) {
    const unsigned count = pick(2, 20);
    rsp.push_back(static_cast<uint8_t>(count));
    random_bytes(rsp, count);
  }

  void read_file(uint8_t, Bytes& req, Bytes& rsp) {
    const unsigned subs = pick(1, 3);
    req.push_back(static_cast<uint8_t>(subs * 7));
    Bytes data;
    for (unsigned i = 0; i < subs; ++i) {
      const unsigned length = pick(1, 5);
      req.push_back(6);
      u16(req, pick(1, 10));
      u16(req, pick(0, 9999));
      u16(req, length);
      data.push_back(static_cast<uint8_t>(1 + length * 2));
      data.push_back(6);
      random_bytes(data, length * 2);
    }
    rsp.push_back(static_cast<uint8_t>(data.size()));
    rsp.insert(rsp.end(), data.begin(), data.end());
  }

  void write_file(uint8_t, Bytes& req, Bytes& rsp) {
    const unsigned subs = pick(1, 3);
    // 245 bytes of data at most (Modbus Application Protocol 6.15): 7 of header a record.
    const unsigned longest = o_.long_file_records ? (245 / subs - 7) / 2 : 5;
    Bytes data;
    for (unsigned i = 0; i < subs; ++i) {
      const unsigned length = pick(1, longest);
      data.push_back(6);
      u16(data, pick(1, 10));
      u16(data, pick(0, 9999));
      u16(data, length);
      random_bytes(data, length * 2);
    }
    req.push_back(static_cast<uint8_t>(data.size()));
    req.insert(req.end(), data.begin(), data.end());
    rsp.assign(req.begin(), req.end());
  }

  void read_write(uint8_t, Bytes& req, Bytes& rsp) {
    const unsigned read_qty = pick(1, 20), write_qty = pick(1, 10);
    u16(req, pick(0, 1000));
    u16(req, read_qty);
    u16(req, pick(0, 1000));
    u16(req, write_qty);
    req.push_back(static_cast<uint8_t>(write_qty * 2));
    random_bytes(req, write_qty * 2);
    rsp.push_back(static_cast<uint8_t>(read_qty * 2));
    random_bytes(rsp, read_qty * 2);
  }

  void read_fifo(uint8_t, Bytes& req, Bytes& rsp) {
    const unsigned count = pick(0, 31);
    u16(req, pick(0, 0xFFFF));
    u16(rsp, 2 + count * 2);
    u16(rsp, count);
    random_bytes(rsp, count * 2);
  }

  void identification(uint8_t, Bytes& req, Bytes& rsp) {
    const uint8_t code = static_cast<uint8_t>(pick(1, 4));
    req.insert(req.end(), {0x0E, code, 0x00});
    static constexpr const char* values[] = {"modtap", "BUSGEN-1", "V1.02"};
    rsp.insert(rsp.end(), {0x0E, code, 0x81, 0x00, 0x00, 0x03});
    for (uint8_t id = 0; id < 3; ++id) {
      const std::string value = values[id];
      rsp.push_back(id);
      rsp.push_back(static_cast<uint8_t>(value.size()));
      rsp.insert(rsp.end(), value.begin(), value.end());
    }
  }

  // A vendor's code: some data both ways.
  void vendor_function(uint8_t, Bytes& req, Bytes& rsp) {
    random_bytes(req, pick(0, 6));
    random_bytes(rsp, pick(0, 6));
  }

  BusOptions o_;
  std::mt19937_64 rng_;
  int64_t char_ns_;
  int64_t t35_;
  BusCapture capture_;
  uint64_t polls_ = 0;
  std::array<std::array<uint16_t, 4>, 248> drifting_ = initial_values();

  static std::array<std::array<uint16_t, 4>, 248> initial_values() {
    std::array<std::array<uint16_t, 4>, 248> values;
    for (auto& slave : values) slave = {500, 250, 100, 750};
    return values;
  }
  size_t answered_ = 0;
  int64_t timing_out_ns_ = 0;        // the master's time-out, still to run before its next request
  int64_t next_burst_ns_ = 0;        // when the next noise burst comes (noise_burst_period_ns)
  int64_t next_second_poll_ns_ = 0;  // when the second master reads next
  std::array<const SlaveFaults*, 248> faults_{};  // by address; none for a healthy slave
  uint8_t block_due_ = 0;    // the slave whose missing block the scan list reads next
  bool block_read_ = false;  // this transaction reads it
};

}  // namespace

BusCapture simulate(const BusOptions& options) {
  return Simulator(options).run();
}

namespace {

std::optional<double> number(std::string_view text) {
  double value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || text.empty()) return {};
  return value;
}

std::optional<int64_t> time_ns(std::string_view text) {
  static constexpr std::pair<std::string_view, double> units[] = {
      {"ns", 1}, {"us", 1e3}, {"ms", 1e6}, {"s", 1e9}};
  for (const auto& [unit, ns] : units) {
    if (!text.ends_with(unit)) continue;
    const auto value = number(text.substr(0, text.size() - unit.size()));
    if (!value || *value < 0 || *value * ns > 1e18) return {};
    return static_cast<int64_t>(*value * ns + 0.5);
  }
  return {};
}

std::optional<unsigned> whole_number(std::string_view text, int base) {
  unsigned value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value, base);
  if (error != std::errc() || end != text.data() + text.size() || text.empty()) return {};
  return value;
}

// 0400H, 0x400 or 1024.
std::optional<unsigned> register_address(std::string_view text) {
  if (text.ends_with('H') || text.ends_with('h'))
    return whole_number(text.substr(0, text.size() - 1), 16);
  if (text.starts_with("0x") || text.starts_with("0X")) return whole_number(text.substr(2), 16);
  return whole_number(text, 10);
}

constexpr std::string_view fault_names =
    "absent, stops=TIME, drop=RATE, slow=TIME, late, bit-errors=RATE, missing-block=START+COUNT, "
    "slow-block=START+COUNT, duplicate, glitch, half-baud, restarts=TIME";

void add_fault(SlaveFaults& faults, std::string_view name, std::optional<std::string_view> value) {
  const std::string what(name);
  auto no_value = [&] {
    if (value) throw std::invalid_argument(what + " takes no value");
  };
  auto text = [&] {
    if (!value) throw std::invalid_argument(what + " needs a value: " + what + "=...");
    return *value;
  };
  auto time = [&] {
    const auto ns = time_ns(text());
    if (!ns)
      throw std::invalid_argument(what + " wants a time with its unit, as 131ms, 60s, 500us");
    return *ns;
  };
  auto rate = [&] {
    const auto r = number(text());
    if (!r || *r < 0 || *r > 1) throw std::invalid_argument(what + " wants a rate from 0 to 1");
    return *r;
  };
  auto block = [&] {
    const std::string_view spec = text();
    const size_t plus = spec.find('+');
    const auto start = register_address(spec.substr(0, plus));
    const auto count =
        plus == std::string_view::npos ? std::nullopt : whole_number(spec.substr(plus + 1), 10);
    if (!start || !count || *count < 1 || *count > 125 || *start + *count > 0x10000)
      throw std::invalid_argument(what +
                                  " wants START+COUNT, as 0400H+4 (COUNT 1-125, a FC03 read's)");
    return RegisterBlock{static_cast<uint16_t>(*start), static_cast<uint16_t>(*count)};
  };
  if (name == "absent") {
    no_value();
    faults.absent = true;
  } else if (name == "late") {
    no_value();
    faults.answers_after_timeout = true;
  } else if (name == "duplicate") {
    no_value();
    faults.duplicate_address = true;
  } else if (name == "glitch") {
    no_value();
    faults.turnaround_glitch = true;
  } else if (name == "half-baud") {
    no_value();
    faults.half_baud = true;
  } else if (name == "stops") {
    faults.stops_after_ns = time();
  } else if (name == "restarts") {
    faults.restarts_every_ns = time();
  } else if (name == "slow") {
    faults.turnaround_ns = time();
  } else if (name == "drop") {
    faults.drop_rate = rate();
  } else if (name == "bit-errors") {
    faults.corruption_rate = rate();
  } else if (name == "missing-block") {
    faults.missing_block = block();
  } else if (name == "slow-block") {
    faults.slow_block = block();
  } else {
    throw std::invalid_argument("no fault '" + what + "'; the faults: " + std::string(fault_names));
  }
}

}  // namespace

std::optional<int64_t> bus_time_ns(std::string_view text) {
  return time_ns(text);
}

void add_slave_faults(BusOptions& options, std::string_view spec) {
  try {
    const size_t colon = spec.find(':');
    const auto slave =
        colon == std::string_view::npos ? std::nullopt : whole_number(spec.substr(0, colon), 10);
    if (!slave || *slave < 1 || *slave > 247)
      throw std::invalid_argument("not ADDR:FAULT[,FAULT...] with ADDR a slave from 1 to 247");
    SlaveFaults& faults = options.slave_faults[static_cast<uint8_t>(*slave)];
    std::string_view rest = spec.substr(colon + 1);
    for (;;) {
      const size_t comma = rest.find(',');
      const std::string_view fault = rest.substr(0, comma);
      const size_t equals = fault.find('=');
      add_fault(faults, fault.substr(0, equals),
                equals == std::string_view::npos ? std::nullopt
                                                 : std::optional(fault.substr(equals + 1)));
      if (comma == std::string_view::npos) break;
      rest.remove_prefix(comma + 1);
    }
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string(spec) + ": " + e.what());
  }
}

ClockQuality clock_of(Delivery delivery) {
  switch (delivery) {
    case Delivery::per_byte:
      return ClockQuality::per_byte;
    case Delivery::bursts:
    case Delivery::usb_packets:
    case Delivery::per_frame:
    case Delivery::whole_frames:
      return ClockQuality::per_chunk;
    case Delivery::untimed:
      return ClockQuality::none;
  }
  return ClockQuality::none;
}

namespace {

// Stamps each read as the adapter's clock would: late by up to the jitter, rounded up to the
// resolution, never earlier than the read before.
void apply_clock_error(std::vector<DeliveredChunk>& chunks, ClockError clock,
                       std::mt19937_64& rng) {
  int64_t previous = INT64_MIN;
  for (auto& c : chunks) {
    int64_t t = c.t_ns;
    if (clock.jitter_ns > 0)
      t += static_cast<int64_t>(rng() % static_cast<uint64_t>(clock.jitter_ns));
    t = (t + clock.resolution_ns - 1) / clock.resolution_ns * clock.resolution_ns;
    c.t_ns = previous = std::max(previous, t);
  }
}

}  // namespace

std::vector<DeliveredChunk> deliver(const BusCapture& capture, Delivery delivery, uint64_t seed,
                                    ClockError clock) {
  std::vector<DeliveredChunk> chunks;
  const auto& ends = capture.end_ns;
  const uint64_t n = capture.bytes.size();
  std::mt19937_64 rng(seed);
  auto chance = [&](double p) { return std::uniform_real_distribution<double>(0, 1)(rng) < p; };
  switch (delivery) {
    case Delivery::per_byte:
      for (uint64_t i = 0; i < n; ++i) chunks.push_back({ends[i], i, 1});
      break;
    case Delivery::untimed:
      for (uint64_t i = 0; i < n; i += 4096)
        chunks.push_back({0, i, static_cast<uint32_t>(std::min<uint64_t>(4096, n - i))});
      break;
    case Delivery::bursts:
    case Delivery::usb_packets: {
      // An FTDI chip sends its 64-byte USB packet (2 status bytes, 62 of data) once it is full,
      // and what it holds when its latency timer runs out: at 115200 baud a full packet every
      // 5.4 ms, not every 16 ms.
      constexpr int64_t period = 16'000'000;
      const uint64_t packet = delivery == Delivery::usb_packets ? 62 : n;
      for (uint64_t i = 0; i < n;) {
        const int64_t due = (ends[i] / period + 1) * period;
        uint64_t j = i;
        while (j < n && ends[j] <= due && j - i < packet) ++j;
        chunks.push_back({j - i == packet ? ends[j - 1] : due, i, static_cast<uint32_t>(j - i)});
        i = j;
      }
      break;
    }
    case Delivery::whole_frames:
    case Delivery::per_frame: {
      const double change_rate = delivery == Delivery::per_frame ? 0.2 : 0.0;
      // Cut where a gap-based sniffer would: at every frame and noise boundary, then split
      // some pieces in two and merge some neighbours.
      std::vector<uint64_t> cuts;
      for (const auto& f : capture.frames) {
        cuts.push_back(f.offset);
        cuts.push_back(f.offset + f.size);
      }
      for (uint64_t i = 1; i < n; ++i)
        if (ends[i] - ends[i - 1] > 3 * (ends[1] - ends[0])) cuts.push_back(i);
      cuts.push_back(0);
      cuts.push_back(n);
      std::sort(cuts.begin(), cuts.end());
      cuts.erase(std::unique(cuts.begin(), cuts.end()), cuts.end());
      // A sniffer merges pieces only across a silence shorter than its own gap threshold (one
      // set too long, or a USB adapter's latency timer), never across a master's time-out.
      constexpr int64_t merge_below_ns = 20'000'000;
      auto silence_after = [&](uint64_t b) {
        return b < n ? ends[b] - ends[b - 1] - (ends[1] - ends[0]) : INT64_MAX;  // less a character
      };
      std::vector<uint64_t> kept{0};
      for (size_t c = 1; c < cuts.size(); ++c) {
        const uint64_t a = kept.back(), b = cuts[c];
        if (b - a > 2 && chance(change_rate)) kept.push_back(a + 1 + rng() % (b - a - 1));  // split
        const bool merge = silence_after(b) < merge_below_ns && chance(change_rate);
        if (!merge) kept.push_back(b);
      }
      for (size_t c = 1; c < kept.size(); ++c) {
        const uint64_t a = kept[c - 1], b = kept[c];
        if (b > a) chunks.push_back({ends[b - 1] + 1'000'000, a, static_cast<uint32_t>(b - a)});
      }
      break;
    }
  }
  if (delivery != Delivery::untimed) apply_clock_error(chunks, clock, rng);
  return chunks;
}

}  // namespace modtap::busgen
