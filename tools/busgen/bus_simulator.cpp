#include "tools/busgen/bus_simulator.hpp"

#include <algorithm>
#include <array>
#include <random>
#include <utility>

#include "decoder/checksum.hpp"
#include "decoder/function_codes.hpp"

namespace modtap::busgen {

using decoder::Mode;
using decoder::Role;
using Bytes = std::vector<uint8_t>;

void encode_frame(Mode mode, const Bytes& body, Bytes& out) {
  if (mode == Mode::rtu) {
    out.insert(out.end(), body.begin(), body.end());
    const uint16_t crc = decoder::crc16(body);
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
  put(decoder::lrc(body));
  out.push_back('\r');
  out.push_back('\n');
}

namespace {

class Simulator {
 public:
  explicit Simulator(const BusOptions& o)
      : o_(o), rng_(o.seed), char_ns_(o.format.char_time_ns()), t35_(o.format.t35_ns()) {}

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

  size_t send_frame(const Bytes& body, Role role, int64_t gap_ns, std::optional<size_t> request) {
    Bytes wire;
    encode_frame(o_.mode, body, wire);
    uint32_t findings = 0;
    uint64_t offset;
    if (o_.mode == Mode::rtu && chance(o_.pause_rate)) {
      offset = send_with_pause(wire, gap_ns);
      findings = decoder::finding_gap_in_frame;
    } else {
      offset = send(wire, gap_ns);
    }
    capture_.frames.push_back(
        {offset, static_cast<uint32_t>(wire.size()), role, request, findings});
    return capture_.frames.size() - 1;
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
  // or any slave.
  uint8_t next_slave() {
    if (o_.polled_slaves == 0) return static_cast<uint8_t>(pick(1, 247));
    return static_cast<uint8_t>(polls_++ % o_.polled_slaves + 1);
  }

  void transaction() {
    const bool broadcast = chance(o_.broadcast_rate);
    const uint8_t slave = broadcast ? 0 : next_slave();
    Bytes request{slave}, response{slave};
    uint32_t request_findings = 0;
    if (!broadcast && chance(o_.out_of_spec_rate)) {
      request_findings = out_of_spec(request, response);
    } else if (o_.polled_slaves) {
      scan_step(slave, request, response);
    } else {
      build(slave, request, response, broadcast);
    }

    if (chance(o_.noise_rate)) {
      Bytes junk;
      random_bytes(junk, pick(1, 40));
      send(junk, idle_gap());
    }
    if (chance(o_.truncation_rate)) {
      Bytes wire;
      encode_frame(o_.mode, request, wire);
      wire.resize(pick(1, static_cast<unsigned>(wire.size() - 1)));
      send(wire, idle_gap());
    }
    size_t req = send_request(request, request_findings, idle_gap());
    if (broadcast) return;
    while (chance(o_.no_response_rate)) {
      capture_.timed_out.push_back(req);
      // Retries only once the bus has shown how fast slaves answer: before that, a copy of an
      // echo request is ambiguous by design (docs/framing.md, "Retries and echoes").
      if (answered_ < 20 || !chance(o_.retry_rate)) {
        timing_out_ns_ = o_.retry_after_ns;
        return;
      }
      req = send_request(request, request_findings | decoder::finding_retry,
                         o_.retry_after_ns + pick(0, 50'000'000));
    }
    int64_t turnaround =
        chance(o_.fast_turnaround_rate) ? char_ns_ * pick(15, 30) / 10 : t35_ + pick(0, 3'000'000);
    if (o_.min_turnaround_ns) turnaround = o_.min_turnaround_ns + pick(0, 3'000'000);
    if (o_.back_to_back) turnaround = 0;
    if (chance(o_.garbled_rate)) {
      timing_out_ns_ = o_.retry_after_ns;  // what came was no answer it could read
      return send_garbled(slave, turnaround);
    }
    if (chance(o_.glitch_rate)) turnaround = glitch(turnaround);
    ++answered_;
    if (damageable(response) && chance(o_.cut_rate)) return send_cut(response, turnaround, req);
    if (damageable(response) && chance(o_.collision_rate))
      return send_collided(response, turnaround, req);
    send_frame(response, Role::response, turnaround, req);
  }

  size_t send_request(const Bytes& request, uint32_t findings, int64_t gap_ns) {
    if (chance(o_.request_glitch_rate)) gap_ns = glitch(gap_ns);
    const size_t req = send_frame(request, Role::request, gap_ns, std::nullopt);
    capture_.frames[req].findings |= findings;
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
    const auto length = decoder::body_length(Role::response, response);
    return length.kind == decoder::BodyLength::Kind::known;
  }

  void send_cut(const Bytes& response, int64_t gap_ns, size_t req) {
    Bytes wire;
    encode_frame(o_.mode, response, wire);
    wire.resize(pick(3, static_cast<unsigned>(wire.size() - 1)));
    send_damaged(wire, gap_ns, req, decoder::Damage::cut);
  }

  // Another device starts while the response's last bytes are on the wire: they arrive garbled
  // and the other device's bytes follow at once.
  void send_collided(const Bytes& response, int64_t gap_ns, size_t req) {
    Bytes wire;
    encode_frame(o_.mode, response, wire);
    const size_t garbled = pick(1, 3);
    for (size_t i = wire.size() - garbled; i < wire.size(); ++i)
      wire[i] ^= static_cast<uint8_t>(pick(1, 255));
    send_damaged(wire, gap_ns, req, decoder::Damage::collision);
    Bytes other;
    random_bytes(other, pick(1, 6));
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

  void send_damaged(const Bytes& wire, int64_t gap_ns, size_t req, decoder::Damage damage) {
    const uint64_t offset = send(wire, gap_ns);
    capture_.frames.push_back({offset, static_cast<uint32_t>(wire.size()), Role::response, req,
                               decoder::finding_bad_check, damage});
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
    uint32_t findings = decoder::finding_quantity_out_of_spec;
    if (kind == 0) u16(req, chance(0.2) ? 0 : pick(126, 300));
    if (kind == 1) u16(req, chance(0.2) ? 0 : pick(2001, 4000));
    if (kind >= 2) {  // a byte count one more than the quantity needs
      const unsigned qty = pick(1, 20);
      const unsigned count = (kind == 2 ? qty * 2 : (qty + 7) / 8) + 1;
      u16(req, qty);
      req.push_back(static_cast<uint8_t>(count));
      random_bytes(req, count);
      findings = decoder::finding_byte_count_mismatch;
    }
    exception(rsp, fc, 0x03);
    return findings;
  }

  void exception(Bytes& rsp, uint8_t fc, uint8_t code) {
    rsp.push_back(static_cast<uint8_t>(fc | 0x80));
    rsp.push_back(code);
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
    const auto unicast = decoder::public_function_codes();
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
    }
    (void)slave;
  }

  void fill(uint8_t fc, Bytes& req, Bytes& rsp) {
    switch (fc) {
      case 0x01:
      case 0x02: {
        const unsigned qty = pick(1, 80);
        u16(req, pick(0, 0xFFFF - qty));
        u16(req, qty);
        rsp.push_back(static_cast<uint8_t>((qty + 7) / 8));
        random_bytes(rsp, (qty + 7) / 8);
        break;
      }
      case 0x03:
      case 0x04: {
        const unsigned qty = pick(1, 40);
        u16(req, pick(0, 0xFFFF - qty));
        u16(req, qty);
        rsp.push_back(static_cast<uint8_t>(qty * 2));
        random_bytes(rsp, qty * 2);
        break;
      }
      case 0x05:
        u16(req, pick(0, 0xFFFF));
        u16(req, chance(0.5) ? 0xFF00 : 0x0000);
        rsp.assign(req.begin(), req.end());
        break;
      case 0x06:
      case 0x16:
        u16(req, pick(0, 0xFFFF));
        random_bytes(req, fc == 0x06 ? 2 : 4);
        rsp.assign(req.begin(), req.end());
        break;
      case 0x07:
        rsp.push_back(static_cast<uint8_t>(pick(0, 255)));
        break;
      case 0x08: {
        static constexpr uint16_t subs[] = {0x0000, 0x000A, 0x000B, 0x000C, 0x000D, 0x000E, 0x0012};
        const uint16_t sub = subs[pick(0, 6)];
        u16(req, sub);
        random_bytes(req, sub == 0 ? pick(1, 4) * 2 : 2);
        rsp.assign(req.begin(), req.end());
        if (sub != 0) {
          rsp.resize(rsp.size() - 2);
          random_bytes(rsp, 2);
        }
        break;
      }
      case 0x0B:
        random_bytes(rsp, 4);
        break;
      case 0x0C: {
        const unsigned events = pick(0, 20);
        rsp.push_back(static_cast<uint8_t>(6 + events));
        random_bytes(rsp, 6 + events);
        break;
      }
      case 0x0F:
      case 0x10: {
        const unsigned qty = fc == 0x0F ? pick(1, 80) : pick(1, 30);
        const unsigned count = fc == 0x0F ? (qty + 7) / 8 : qty * 2;
        u16(req, pick(0, 0xFFFF - qty));
        u16(req, qty);
        req.push_back(static_cast<uint8_t>(count));
        random_bytes(req, count);
        rsp.insert(rsp.end(), req.begin() + 2, req.begin() + 6);
        break;
      }
      case 0x11: {
        const unsigned count = pick(2, 20);
        rsp.push_back(static_cast<uint8_t>(count));
        random_bytes(rsp, count);
        break;
      }
      case 0x14: {
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
        break;
      }
      case 0x15: {
        const unsigned subs = pick(1, 3);
        Bytes data;
        for (unsigned i = 0; i < subs; ++i) {
          const unsigned length = pick(1, 5);
          data.push_back(6);
          u16(data, pick(1, 10));
          u16(data, pick(0, 9999));
          u16(data, length);
          random_bytes(data, length * 2);
        }
        req.push_back(static_cast<uint8_t>(data.size()));
        req.insert(req.end(), data.begin(), data.end());
        rsp.assign(req.begin(), req.end());
        break;
      }
      case 0x17: {
        const unsigned read_qty = pick(1, 20), write_qty = pick(1, 10);
        u16(req, pick(0, 1000));
        u16(req, read_qty);
        u16(req, pick(0, 1000));
        u16(req, write_qty);
        req.push_back(static_cast<uint8_t>(write_qty * 2));
        random_bytes(req, write_qty * 2);
        rsp.push_back(static_cast<uint8_t>(read_qty * 2));
        random_bytes(rsp, read_qty * 2);
        break;
      }
      case 0x18: {
        const unsigned count = pick(0, 31);
        u16(req, pick(0, 0xFFFF));
        u16(rsp, 2 + count * 2);
        u16(rsp, count);
        random_bytes(rsp, count * 2);
        break;
      }
      case 0x2B: {
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
        break;
      }
      default: {  // a vendor code: some data both ways
        random_bytes(req, pick(0, 6));
        random_bytes(rsp, pick(0, 6));
      }
    }
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
  int64_t timing_out_ns_ = 0;  // the master's time-out, still to run before its next request
};

}  // namespace

BusCapture simulate(const BusOptions& options) {
  return Simulator(options).run();
}

decoder::ClockQuality clock_of(Delivery delivery) {
  switch (delivery) {
    case Delivery::per_byte:
      return decoder::ClockQuality::per_byte;
    case Delivery::bursts:
    case Delivery::per_frame:
    case Delivery::whole_frames:
      return decoder::ClockQuality::per_chunk;
    case Delivery::untimed:
      return decoder::ClockQuality::none;
  }
  return decoder::ClockQuality::none;
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
    case Delivery::bursts: {
      constexpr int64_t period = 16'000'000;
      for (uint64_t i = 0; i < n;) {
        const int64_t due = (ends[i] / period + 1) * period;
        uint64_t j = i;
        while (j < n && ends[j] <= due) ++j;
        chunks.push_back({due, i, static_cast<uint32_t>(j - i)});
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
