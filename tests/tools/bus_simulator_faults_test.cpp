// The bus simulator's faulty slaves: each fault, set on one slave of a scan list, does what
// its device would on the wire, to that slave only, and the truth says so exactly.
#include "tools/busgen/bus_simulator.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "decoder/protocol/analyzer.hpp"
#include "decoder/protocol/checksum.hpp"
#include "tests/support/collector.hpp"

namespace modtap::busgen {
namespace {
using Bytes = std::vector<uint8_t>;

// Five slaves polled in turn on an otherwise clean bus (no exceptions, silences or broadcasts),
// so that whatever goes wrong is the fault's.
BusOptions scan(size_t transactions = 1000, uint64_t seed = 1) {
  BusOptions o;
  o.seed = seed;
  o.transactions = transactions;
  o.polled_slaves = 5;
  o.exception_rate = 0;
  o.no_response_rate = 0;
  o.broadcast_rate = 0;
  return o;
}

// What the --faults option of busgen adds, on a scan list.
BusOptions rough_scan(uint64_t seed) {
  BusOptions o;
  o.seed = seed;
  o.transactions = 2000;
  o.polled_slaves = 5;
  o.glitch_rate = o.request_glitch_rate = o.noise_rate = o.truncation_rate = 0.01;
  o.retry_rate = o.cut_rate = o.collision_rate = o.out_of_spec_rate = 0.01;
  o.unknown_function_rate = o.pause_rate = o.garbled_rate = 0.01;
  return o;
}

Bytes wire(const BusCapture& c, uint64_t offset, size_t size) {
  return Bytes(c.bytes.begin() + static_cast<ptrdiff_t>(offset),
               c.bytes.begin() + static_cast<ptrdiff_t>(offset + size));
}
Bytes wire(const BusCapture& c, const TruthFrame& f) {
  return wire(c, f.offset, f.size);
}

// An RTU frame: the body and its CRC.
Bytes rtu(Bytes body) {
  const uint16_t crc = crc16(body);
  body.push_back(static_cast<uint8_t>(crc & 0xFF));
  body.push_back(static_cast<uint8_t>(crc >> 8));
  return body;
}

bool crc_ok(const Bytes& w) {
  const size_t n = w.size();
  return n >= 4 && crc16(std::span(w).first(n - 2)) == (w[n - 2] | w[n - 1] << 8);
}

// When a frame's first byte began, and when its last byte ended.
int64_t start_ns(const BusCapture& c, uint64_t offset, const BusOptions& o) {
  return c.end_ns[offset] - o.format.char_time_ns();
}
int64_t end_ns(const BusCapture& c, const TruthFrame& f) {
  return c.end_ns[f.offset + f.size - 1];
}

std::vector<size_t> requests_to(const BusCapture& c, uint8_t slave) {
  std::vector<size_t> out;
  for (size_t i = 0; i < c.frames.size(); ++i)
    if (c.frames[i].role == Role::request && c.frames[i].slave == slave) out.push_back(i);
  return out;
}

// Each answered request's response.
std::map<size_t, size_t> responses(const BusCapture& c) {
  std::map<size_t, size_t> out;
  for (size_t i = 0; i < c.frames.size(); ++i)
    if (c.frames[i].role == Role::response) out[*c.frames[i].request] = i;
  return out;
}

std::set<size_t> timed_out(const BusCapture& c) {
  return {c.timed_out.begin(), c.timed_out.end()};
}

// The frame sent right after frame i.
const TruthFrame* next_frame(const BusCapture& c, size_t i) {
  return i + 1 < c.frames.size() ? &c.frames[i + 1] : nullptr;
}

TEST(SlaveFaults, FaultsAllOffAreTheHealthyBusToTheLastByte) {
  for (BusOptions o : {scan(), rough_scan(7)}) {
    const BusCapture healthy = simulate(o);
    o.slave_faults[2] = {};
    o.slave_faults[5] = {};
    o.corruption_rate = 0;
    EXPECT_EQ(simulate(o), healthy);
  }
  BusOptions any_slave = rough_scan(8);
  any_slave.polled_slaves = 0;
  const BusCapture healthy = simulate(any_slave);
  any_slave.slave_faults[17] = {};
  EXPECT_EQ(simulate(any_slave), healthy);
}

TEST(SlaveFaults, TheSameSeedGivesTheSameFaultyBus) {
  BusOptions o = rough_scan(3);
  o.corruption_rate = 0.02;
  add_slave_faults(o, "1:drop=0.2,glitch");
  add_slave_faults(o, "2:slow=120ms,bit-errors=0.2");
  add_slave_faults(o, "3:duplicate");
  add_slave_faults(o, "4:missing-block=0400H+4,late");
  EXPECT_EQ(simulate(o), simulate(o));
}

// A fault changes what one slave does, not whom the master polls or in what order.
TEST(SlaveFaults, TheScanListKeepsItsOrder) {
  BusOptions o = scan();
  o.slave_faults[3].absent = true;
  o.slave_faults[4].drop_rate = 0.5;
  const BusCapture c = simulate(o);
  unsigned expected = 1;
  for (const auto& f : c.frames) {
    if (f.role != Role::request) continue;
    ASSERT_EQ(f.slave, expected);
    expected = expected % 5 + 1;
  }
}

TEST(SlaveFaults, AnAbsentSlaveLeavesEveryRequestUnansweredForTheWholeTimeOut) {
  BusOptions o = scan();
  o.slave_faults[3].absent = true;
  const BusCapture c = simulate(o);
  const auto to_3 = requests_to(c, 3);
  ASSERT_EQ(to_3.size(), 200u);
  EXPECT_EQ(timed_out(c), std::set<size_t>(to_3.begin(), to_3.end()));
  const auto answered = responses(c);
  for (size_t req : to_3) {
    EXPECT_FALSE(answered.count(req));
    // The master waits out its time-out before it sends anything again.
    const TruthFrame* next = next_frame(c, req);
    if (next) {
      EXPECT_GE(start_ns(c, next->offset, o) - end_ns(c, c.frames[req]), o.retry_after_ns);
    }
  }
  for (const auto& f : c.frames) {
    if (f.role != Role::response) continue;
    EXPECT_NE(f.slave, 3);
    EXPECT_NE(c.bytes[f.offset], 3);
  }
  EXPECT_EQ(answered.size(), 800u);  // everyone else answers every time
}

// Its usual setting: a master tries a silent slave three more times, then moves on.
TEST(SlaveFaults, TheMasterGivesASilentSlaveUpAfterThreeRetries) {
  BusOptions o = scan();
  o.retry_rate = 1.0;
  o.slave_faults[3].absent = true;
  const BusCapture c = simulate(o);
  std::vector<size_t> run;
  size_t runs_of_four = 0;
  auto end_run = [&] {
    if (run.empty()) return;
    // Retries start once the bus has shown how fast slaves answer (20 answers).
    EXPECT_TRUE(run.size() == 1 || run.size() == 4) << run.size();
    for (size_t i = 0; i < run.size(); ++i)
      EXPECT_EQ((c.frames[run[i]].findings & finding_retry) != 0, i > 0);
    runs_of_four += run.size() == 4;
    run.clear();
  };
  for (size_t i = 0; i < c.frames.size(); ++i) {
    if (c.frames[i].role != Role::request) continue;
    if (c.frames[i].slave == 3) {
      run.push_back(i);
    } else {
      end_run();
    }
  }
  end_run();
  EXPECT_GT(runs_of_four, 150u);
  EXPECT_EQ(c.timed_out.size(), requests_to(c, 3).size());
}

TEST(SlaveFaults, AStoppedSlaveAnswersUntilItStopsAndNeverAfter) {
  BusOptions o = scan();
  o.slave_faults[2].stops_after_ns = 10'000'000'000;
  const BusCapture c = simulate(o);
  const auto answered = responses(c);
  const auto unanswered = timed_out(c);
  size_t before = 0, after = 0;
  for (size_t req : requests_to(c, 2)) {
    const bool stopped = end_ns(c, c.frames[req]) >= 10'000'000'000;
    before += !stopped;
    after += stopped;
    EXPECT_EQ(answered.count(req), stopped ? 0u : 1u);
    EXPECT_EQ(unanswered.count(req), stopped ? 1u : 0u);
  }
  EXPECT_GT(before, 50u);
  EXPECT_GT(after, 50u);
  EXPECT_EQ(unanswered.size(), after);
}

TEST(SlaveFaults, ADroppingSlaveMissesItsShareOfRequestsAndNoOneElseMissesAny) {
  BusOptions o = scan(3000);
  o.slave_faults[4].drop_rate = 0.3;
  const BusCapture c = simulate(o);
  const auto to_4 = requests_to(c, 4);
  size_t dropped = 0;
  for (size_t req : c.timed_out) {
    EXPECT_EQ(c.frames[req].slave, 4);
    ++dropped;
  }
  const double share = static_cast<double>(dropped) / static_cast<double>(to_4.size());
  EXPECT_GT(share, 0.24);
  EXPECT_LT(share, 0.36);
  EXPECT_EQ(responses(c).size() + dropped, o.transactions);
}

TEST(SlaveFaults, ASlowSlaveAnswersAfterItsTurnaround) {
  BusOptions o = scan();
  o.slave_faults[2].turnaround_ns = 131'000'000;
  const BusCapture c = simulate(o);
  size_t slow = 0;
  for (const auto& [req, rsp] : responses(c)) {
    const int64_t turnaround = start_ns(c, c.frames[rsp].offset, o) - end_ns(c, c.frames[req]);
    if (c.frames[req].slave == 2) {
      EXPECT_GE(turnaround, 131'000'000);
      EXPECT_LE(turnaround, 134'000'000);
      ++slow;
    } else {
      EXPECT_LT(turnaround, 10'000'000);
    }
    EXPECT_FALSE(c.frames[rsp].late);
  }
  EXPECT_EQ(slow, 200u);
  EXPECT_TRUE(c.timed_out.empty());  // slow, still within the master's 200 ms
}

// The late answer comes after the master gave up and before it sends its next request, which
// waits its usual idle time after the line fell quiet.
TEST(SlaveFaults, ALateAnswerComesAfterTheMastersTimeOutAndBeforeItsNextRequest) {
  BusOptions o = scan();
  o.slave_faults[5].answers_after_timeout = true;
  o.slave_faults[3].turnaround_ns = 250'000'000;  // slower than the time-out: late as well
  const BusCapture c = simulate(o);
  const auto answered = responses(c);
  std::set<size_t> late_requests;
  for (uint8_t slave : {3, 5})
    for (size_t req : requests_to(c, slave)) late_requests.insert(req);
  EXPECT_EQ(timed_out(c), late_requests);
  for (const auto& [req, rsp] : answered) {
    const TruthFrame& answer = c.frames[rsp];
    EXPECT_EQ(answer.late, late_requests.count(req) == 1);
    EXPECT_TRUE(crc_ok(wire(c, answer)));  // a whole answer, only too late
    if (!answer.late) continue;
    const int64_t turnaround = start_ns(c, answer.offset, o) - end_ns(c, c.frames[req]);
    EXPECT_GT(turnaround, o.retry_after_ns);
    if (answer.slave == 5) {
      EXPECT_LE(turnaround, o.retry_after_ns + o.format.t35_ns() + 3'000'000);
    }
    EXPECT_EQ(rsp, req + 1);
    const TruthFrame* next = next_frame(c, rsp);
    if (next) {
      EXPECT_GE(start_ns(c, next->offset, o) - end_ns(c, answer), o.poll_gap_ns);
    }
  }
  EXPECT_EQ(answered.size(), o.transactions);  // every request has its answer, some late
}

TEST(SlaveFaults, ASlaveWithBitErrorsDamagesItsShareOfAnswersAndNoOneElses) {
  BusOptions o = scan(3000);
  o.slave_faults[5].corruption_rate = 0.3;
  const BusCapture c = simulate(o);
  size_t answers_of_5 = 0, damaged = 0, address_hit = 0;
  for (const auto& f : c.frames) {
    const Bytes w = wire(c, f);
    if (f.role == Role::request || f.slave != 5) {
      EXPECT_EQ(f.damage, Damage::none);
      EXPECT_TRUE(crc_ok(w));
      continue;
    }
    ++answers_of_5;
    EXPECT_EQ(c.frames[*f.request].slave, 5);
    ASSERT_EQ(w.size(), 13u);  // structure whole: as long as a good answer
    if (f.damage == Damage::none) {
      EXPECT_TRUE(crc_ok(w));
      EXPECT_EQ(f.findings, 0u);
      continue;
    }
    ++damaged;
    EXPECT_EQ(f.damage, Damage::corrupted);
    EXPECT_EQ(f.findings, finding_bad_check);
    EXPECT_FALSE(crc_ok(w));
    EXPECT_EQ(w[1], 0x03);  // the function code and byte count tell its length: never hit
    EXPECT_EQ(w[2], 8);
    EXPECT_GE(w[0], 1);
    EXPECT_LE(w[0], 247);
    address_hit += w[0] != 5;
  }
  EXPECT_EQ(answers_of_5, 600u);
  EXPECT_GT(damaged, 600 * 0.24);
  EXPECT_LT(damaged, 600 * 0.36);
  EXPECT_GT(address_hit, 5u);        // the truth still says whose answer it was
  EXPECT_TRUE(c.timed_out.empty());  // a CRC error ends the master's wait at once
}

// Line noise hits the master's requests too: a slave ignores a request whose check fails, so
// nobody answers it, the master waits out its time-out, and no transaction was opened.
TEST(SlaveFaults, LineNoiseDamagesRequestsAndAnswersOfEverySlave) {
  BusOptions o = scan(3000);
  o.corruption_rate = 0.05;
  const BusCapture c = simulate(o);
  const auto answered = responses(c);
  std::set<uint8_t> slaves_hit;
  size_t requests_hit = 0, answers_hit = 0;
  for (size_t i = 0; i < c.frames.size(); ++i) {
    const TruthFrame& f = c.frames[i];
    EXPECT_EQ(crc_ok(wire(c, f)), f.damage == Damage::none);
    if (f.damage == Damage::none) continue;
    EXPECT_EQ(f.damage, Damage::corrupted);
    slaves_hit.insert(f.slave);
    if (f.role == Role::response) {
      ++answers_hit;
      continue;
    }
    ++requests_hit;
    EXPECT_FALSE(answered.count(i));
    const TruthFrame* next = next_frame(c, i);
    if (next) {
      EXPECT_GE(start_ns(c, next->offset, o) - end_ns(c, f), o.retry_after_ns);
    }
  }
  EXPECT_GT(requests_hit, 100u);
  EXPECT_GT(answers_hit, 100u);
  EXPECT_EQ(slaves_hit, (std::set<uint8_t>{1, 2, 3, 4, 5}));
  EXPECT_TRUE(c.timed_out.empty());
  EXPECT_EQ(answered.size() + requests_hit, o.transactions);
}

// A restarting slave is silent the first 5 s of every period after the first, each request then
// timed out, and answers every request between; no other slave misses one.
TEST(SlaveFaults, ARestartingSlaveIsSilentFiveSecondsOfEveryPeriod) {
  BusOptions o = scan(4000);
  o.slave_faults[2].restarts_every_ns = 7'000'000'000;
  const BusCapture c = simulate(o);
  const auto answered = responses(c);
  const auto unanswered = timed_out(c);
  size_t silent = 0;
  for (size_t req : requests_to(c, 2)) {
    const int64_t asked = end_ns(c, c.frames[req]);  // when the simulator asks the slave
    const bool down = asked >= 7'000'000'000 && asked % 7'000'000'000 < 5'000'000'000;
    EXPECT_EQ(unanswered.count(req), down ? 1u : 0u) << asked;
    EXPECT_EQ(answered.count(req), down ? 0u : 1u) << asked;
    silent += down;
  }
  EXPECT_GT(silent, 20u);
  EXPECT_EQ(unanswered.size(), silent);
}

// A slow block is answered 60 to 63 ms after its read, every cycle; the slave's other reads and
// every other slave's come at the bus's turnaround.
TEST(SlaveFaults, ASlowBlockIsAnsweredLateAndTheRestOnTime) {
  BusOptions o = scan();
  o.slave_faults[3].slow_block = RegisterBlock{0x0100, 8};
  const BusCapture c = simulate(o);
  size_t slow = 0;
  for (const auto& [req, rsp] : responses(c)) {
    const Bytes request = wire(c, c.frames[req]);
    const int64_t turnaround = start_ns(c, c.frames[rsp].offset, o) - end_ns(c, c.frames[req]);
    const bool block = request[0] == 3 && request[2] == 0x01 && request[3] == 0x00;
    if (block) {
      EXPECT_GE(turnaround, 60'000'000);
      EXPECT_LE(turnaround, 63'000'000);
      ++slow;
    } else {
      EXPECT_LT(turnaround, 10'000'000);
    }
  }
  EXPECT_GT(slow, 100u);
}

// Reflections damage long frames and never one of 8 bytes or fewer; a damaged frame holds no span
// whose CRC holds (a good frame inside it no receiver could tell from one sent).
TEST(SlaveFaults, ReflectionsDamageLongFramesAndLeaveNoGoodSpanInside) {
  BusOptions o = scan(3000);
  o.polled_slaves = 0;  // reads and writes of every length
  o.reflection_rate = 0.5;
  const BusCapture c = simulate(o);
  size_t short_damaged = 0, long_frames = 0, long_damaged = 0;
  for (const TruthFrame& f : c.frames) {
    const bool damaged = f.damage == Damage::corrupted;
    if (f.size <= 8) short_damaged += damaged;
    if (f.size >= 32) {
      ++long_frames;
      long_damaged += damaged;
    }
    if (!damaged) continue;
    const Bytes bytes = wire(c, f);
    for (size_t first = 0; first + 4 <= bytes.size(); ++first)
      for (size_t end = first + 4; end <= bytes.size(); ++end)
        EXPECT_FALSE(crc_ok(Bytes(bytes.begin() + static_cast<ptrdiff_t>(first),
                                  bytes.begin() + static_cast<ptrdiff_t>(end))))
            << "frame at " << f.offset << ": a good span at " << first << "-" << end;
  }
  EXPECT_EQ(short_damaged, 0u);
  EXPECT_GT(long_frames, 100u);
  const double share = static_cast<double>(long_damaged) / static_cast<double>(long_frames);
  EXPECT_GT(share, 0.4);
  EXPECT_LT(share, 0.6);
}

// Noise bursts come at their period, 2 to 6 bytes of junk each between frames, or over a frame,
// whose check then fails.
TEST(SlaveFaults, NoiseBurstsComeAtTheirPeriod) {
  BusOptions o = scan(3000);
  o.noise_burst_period_ns = 700'000'000;
  const BusCapture c = simulate(o);
  std::vector<bool> framed(c.bytes.size(), false);
  for (const TruthFrame& f : c.frames) std::fill_n(framed.begin() + f.offset, f.size, true);
  std::vector<int64_t> bursts;
  for (size_t i = 0; i < c.bytes.size(); ++i) {
    if (framed[i] || (i > 0 && !framed[i - 1])) continue;
    size_t end = i;
    while (end < c.bytes.size() && !framed[end]) ++end;
    EXPECT_GE(end - i, 2u);
    EXPECT_LE(end - i, 6u);
    bursts.push_back(c.end_ns[i] - o.format.char_time_ns());
  }
  size_t on_frames = 0;
  for (const TruthFrame& f : c.frames) on_frames += f.damage == Damage::corrupted;
  // A beat brings junk between frames or a frame it fell on, unless it fell on bytes sent
  // already, which went with them: nearly every beat, never more.
  const auto beats = static_cast<size_t>(c.end_ns.back() / 700'000'000);
  EXPECT_GT(bursts.size(), 0u);
  EXPECT_GT(on_frames, 0u);
  EXPECT_LE(bursts.size() + on_frames, beats + 1);
  EXPECT_GE(bursts.size() + on_frames, beats * 9 / 10);
  // Junk between frames starts on its beat, give or take the jitter of up to 1 ms a beat.
  for (const int64_t t : bursts) {
    const double beat = static_cast<double>(t) / 700'000'000.0;
    EXPECT_LT(std::abs(beat - std::round(beat)) * 700, std::round(beat) + 1) << t;
  }
}

// The scan list reads the missing block from its slave every cycle, right after its usual
// read, and gets exception 02 each time.
TEST(SlaveFaults, ReadsOfAMissingBlockGetIllegalDataAddress) {
  BusOptions o = scan(1200);
  o.slave_faults[2].missing_block = RegisterBlock{0x0400, 4};
  const BusCapture c = simulate(o);
  const auto answered = responses(c);
  std::vector<uint8_t> order;
  size_t block_reads = 0;
  for (size_t i = 0; i < c.frames.size(); ++i) {
    const TruthFrame& f = c.frames[i];
    if (f.role != Role::request) continue;
    order.push_back(f.slave);
    const Bytes rsp = wire(c, c.frames[answered.at(i)]);
    if (wire(c, f) == rtu({2, 0x03, 0x04, 0x00, 0x00, 0x04})) {
      EXPECT_EQ(rsp, rtu({2, 0x83, 0x02}));
      ++block_reads;
    } else {
      EXPECT_EQ(wire(c, f)[3], 0x00);  // the usual read of 0000H
      EXPECT_EQ(rsp.size(), 13u);
      EXPECT_EQ(rsp[1], 0x03);
    }
  }
  EXPECT_EQ(block_reads, 200u);
  for (size_t i = 0; i < order.size(); ++i)
    ASSERT_EQ(order[i], (std::vector<uint8_t>{1, 2, 2, 3, 4, 5})[i % 6]) << i;
}

TEST(SlaveFaults, AMissingBlockUnderTheUsualReadFailsEveryRead) {
  BusOptions o = scan();
  o.slave_faults[2].missing_block = RegisterBlock{0x0002, 10};
  const BusCapture c = simulate(o);
  size_t exceptions = 0;
  for (const auto& [req, rsp] : responses(c)) {
    const Bytes w = wire(c, c.frames[rsp]);
    EXPECT_EQ(w[1] == 0x83 && w[2] == 0x02, c.frames[req].slave == 2);
    exceptions += w[1] == 0x83;
  }
  EXPECT_EQ(exceptions, requests_to(c, 2).size());  // its usual read, and the block's
  EXPECT_GT(exceptions, 300u);
}

// With each request to a slave picked at random, only the FC03 reads that touch the block fail.
TEST(SlaveFaults, AnyFc03ReadTouchingTheBlockFailsWhenSlavesArePickedAtRandom) {
  BusOptions o;
  o.transactions = 3000;
  o.exception_rate = 0;
  for (unsigned slave = 1; slave <= 247; ++slave)
    o.slave_faults[static_cast<uint8_t>(slave)].missing_block = RegisterBlock{0x8000, 0x7FFF};
  const BusCapture c = simulate(o);
  size_t touching = 0, clear = 0;
  for (const auto& [req, rsp] : responses(c)) {
    const Bytes q = wire(c, c.frames[req]), r = wire(c, c.frames[rsp]);
    if (q[1] != 0x03) {
      EXPECT_FALSE(r[1] & 0x80);
      continue;
    }
    const unsigned start = q[2] << 8 | q[3], count = q[4] << 8 | q[5];
    const bool touches = start + count > 0x8000 && start < 0xFFFF;
    EXPECT_EQ(r[1] == 0x83 && r[2] == 0x02, touches);
    touching += touches;
    clear += !touches;
  }
  EXPECT_GT(touching, 50u);
  EXPECT_GT(clear, 50u);
}

// Two devices with one address answer together: mostly junk on the wire (the master times
// out), and begun within the same bit, an answer whose differing bytes are garbage.
TEST(SlaveFaults, TwoDevicesWithOneAddressAnswerOverEachOther) {
  BusOptions o = scan(3000);
  o.slave_faults[4].duplicate_address = true;
  const BusCapture c = simulate(o);
  const auto to_4 = requests_to(c, 4);
  ASSERT_EQ(c.clashes.size(), to_4.size());
  const auto answered = responses(c);
  const auto unanswered = timed_out(c);
  const std::set<uint64_t> garbled(c.garbled.begin(), c.garbled.end());
  size_t as_junk = 0, as_frame = 0;
  for (size_t i = 0; i < c.clashes.size(); ++i) {
    const Clash& clash = c.clashes[i];
    EXPECT_EQ(clash.request, to_4[i]);
    const Bytes w = wire(c, clash.offset, clash.size);
    if (garbled.count(clash.offset)) {
      ++as_junk;
      EXPECT_FALSE(unanswered.count(clash.request));  // answered, garbled
      EXPECT_FALSE(answered.count(clash.request));
      EXPECT_GE(w.size(), 14u);  // both answers, the second 0.1 to 1.9 characters late
      EXPECT_LE(w.size(), 15u);
      // Never the slave's answer begun: its address and then its function code.
      EXPECT_FALSE(w[0] == 4 && (w[1] & 0x7F) == 0x03);
      continue;
    }
    ++as_frame;
    EXPECT_FALSE(unanswered.count(clash.request));
    const TruthFrame& f = c.frames[answered.at(clash.request)];
    EXPECT_EQ(f.offset, clash.offset);
    EXPECT_EQ(f.size, clash.size);
    EXPECT_EQ(f.damage, Damage::corrupted);  // the twin's registers read otherwise
    EXPECT_FALSE(crc_ok(w));
    EXPECT_EQ(Bytes(w.begin(), w.begin() + 3), (Bytes{4, 0x03, 8}));  // what both said alike
  }
  EXPECT_GT(as_junk, 8 * as_frame);
  EXPECT_GT(as_frame, 5u);
  EXPECT_TRUE(unanswered.empty());  // everyone answered, slave 4 at times garbled
}

TEST(SlaveFaults, AGlitchingSlavePutsAGlitchBeforeEveryAnswer) {
  BusOptions o = scan();
  o.slave_faults[1].turnaround_glitch = true;
  const BusCapture c = simulate(o);
  for (const auto& [req, rsp] : responses(c)) {
    const TruthFrame &q = c.frames[req], &r = c.frames[rsp];
    const uint64_t between = r.offset - (q.offset + q.size);
    EXPECT_EQ(between, q.slave == 1 ? 1u : 0u);
    if (between) {
      EXPECT_TRUE(c.bytes[r.offset - 1] == 0x00 || c.bytes[r.offset - 1] == 0xFF);
    }
  }
}

// In ASCII a bit error changes a hex digit to another: the frame still reads, its LRC wrong.
TEST(SlaveFaults, AsciiBitErrorsKeepTheFrameReadable) {
  BusOptions o = scan();
  o.mode = Mode::ascii;
  o.format.data_bits = 7;
  o.slave_faults[2].corruption_rate = 0.5;
  const BusCapture c = simulate(o);
  size_t damaged = 0;
  for (const auto& f : c.frames) {
    if (f.damage == Damage::none) continue;
    ++damaged;
    EXPECT_EQ(f.slave, 2);
    const Bytes w = wire(c, f);
    ASSERT_EQ(w.front(), ':');
    ASSERT_EQ(w[w.size() - 2], '\r');
    ASSERT_EQ(w.back(), '\n');
    Bytes adu;
    for (size_t i = 1; i + 2 < w.size(); i += 2)
      adu.push_back(
          static_cast<uint8_t>(std::stoi(std::string(w.begin() + static_cast<ptrdiff_t>(i),
                                                     w.begin() + static_cast<ptrdiff_t>(i + 2)),
                                         nullptr, 16)));
    EXPECT_NE(lrc(std::span(adu).first(adu.size() - 1)), adu.back());
  }
  EXPECT_GT(damaged, 60u);
}

// The truth holds for a reader of the wire: every frame it lists is found at its place by
// modtap's framer as that frame, with the damage the truth gives it, but where the bytes do
// not tell: a damaged answer whose address was hit is another slave's to a reader that awaits
// this one's (read as junk, at times with a chance good CRC in it), and a damaged request whose
// third byte is no longer 0 reads as well as a read's answer cut short. Those are never taken
// for good frames.
TEST(SlaveFaults, TheAnalyzerFindsEachFrameAsTheTruthSays) {
  BusOptions o = scan(3000);
  o.corruption_rate = 0.03;
  add_slave_faults(o, "1:missing-block=0010H+4");
  add_slave_faults(o, "2:drop=0.1");
  add_slave_faults(o, "3:late");
  add_slave_faults(o, "4:duplicate");
  add_slave_faults(o, "5:bit-errors=0.3");
  const BusCapture c = simulate(o);
  AnalyzerOptions options;
  options.mode = ModeChoice::rtu;
  options.clock = ClockQuality::per_byte;
  testing::Collector out;
  Analyzer analyzer(options, {{"bus", ChannelRole::bus}}, out);
  for (size_t i = 0; i < c.bytes.size(); ++i) analyzer.push({0, c.end_ns[i], {&c.bytes[i], 1}});
  analyzer.finish();
  std::map<uint64_t, const testing::Record*> at;
  for (const auto& r : out.records)
    if (r.type == testing::Record::Type::frame) at[r.offset] = &r;
  size_t damaged = 0, untold = 0;
  for (const auto& f : c.frames) {
    const Bytes w = wire(c, f);
    const auto found = at.find(f.offset);
    const bool address_hit = w[0] != f.slave;
    const bool reads_as_answer = f.role == Role::request && f.damage != Damage::none && w[2] != 0;
    if (address_hit || reads_as_answer) {
      ++untold;
      if (found != at.end()) {
        EXPECT_FALSE(found->second->check_ok) << f.offset;
      }
      continue;
    }
    ASSERT_NE(found, at.end()) << f.offset;
    const testing::Record& r = *found->second;
    EXPECT_EQ(r.raw, w) << f.offset;
    EXPECT_EQ(r.check_ok, f.damage == Damage::none) << f.offset;
    EXPECT_EQ(r.damage, f.damage) << f.offset;
    damaged += f.damage != Damage::none;
  }
  EXPECT_GT(damaged, 200u);
  EXPECT_LT(untold * 2, damaged);
}

TEST(SlaveFaults, WrittenAsOnTheCommandLine) {
  BusOptions o;
  add_slave_faults(o, "3:absent");
  add_slave_faults(o, "2:slow=131ms,glitch");
  add_slave_faults(o, "4:drop=0.28");
  add_slave_faults(o, "5:bit-errors=0.1");
  add_slave_faults(o, "1:stops=60s");
  add_slave_faults(o, "6:missing-block=0400H+4");
  add_slave_faults(o, "7:duplicate,late");
  add_slave_faults(o, "8:missing-block=0x10+2,stops=2.5s,slow=500us");
  add_slave_faults(o, "9:missing-block=100+125");
  EXPECT_TRUE(o.slave_faults[3].absent);
  EXPECT_EQ(o.slave_faults[2].turnaround_ns, 131'000'000);
  EXPECT_TRUE(o.slave_faults[2].turnaround_glitch);
  EXPECT_EQ(o.slave_faults[4].drop_rate, 0.28);
  EXPECT_EQ(o.slave_faults[5].corruption_rate, 0.1);
  EXPECT_EQ(o.slave_faults[1].stops_after_ns, 60'000'000'000);
  EXPECT_EQ(o.slave_faults[6].missing_block, (RegisterBlock{0x0400, 4}));
  EXPECT_TRUE(o.slave_faults[7].duplicate_address);
  EXPECT_TRUE(o.slave_faults[7].answers_after_timeout);
  EXPECT_EQ(o.slave_faults[8].missing_block, (RegisterBlock{0x10, 2}));
  EXPECT_EQ(o.slave_faults[8].stops_after_ns, 2'500'000'000);
  EXPECT_EQ(o.slave_faults[8].turnaround_ns, 500'000);
  EXPECT_EQ(o.slave_faults[9].missing_block, (RegisterBlock{100, 125}));
  EXPECT_EQ(o.slave_faults.size(), 9u);
}

TEST(SlaveFaults, ABadFaultSaysWhatIsWrong) {
  auto error_of = [](const char* spec) -> std::string {
    BusOptions o;
    try {
      add_slave_faults(o, spec);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "accepted";
  };
  EXPECT_EQ(error_of("absent"),
            "absent: not ADDR:FAULT[,FAULT...] with ADDR a slave from 1 to 247");
  EXPECT_EQ(error_of("0:absent").substr(0, 14), "0:absent: not ");
  EXPECT_EQ(error_of("248:absent").substr(0, 16), "248:absent: not ");
  EXPECT_NE(error_of("3:sleepy").find("no fault 'sleepy'; the faults: absent, stops=TIME"),
            std::string::npos);
  EXPECT_EQ(error_of("2:slow=131"),
            "2:slow=131: slow wants a time with its unit, as 131ms, 60s, 500us");
  EXPECT_EQ(error_of("2:slow=-5ms"),
            "2:slow=-5ms: slow wants a time with its unit, as 131ms, 60s, 500us");
  EXPECT_EQ(error_of("4:drop=1.5"), "4:drop=1.5: drop wants a rate from 0 to 1");
  EXPECT_EQ(error_of("4:bit-errors=x"), "4:bit-errors=x: bit-errors wants a rate from 0 to 1");
  EXPECT_EQ(error_of("4:drop"), "4:drop: drop needs a value: drop=...");
  EXPECT_EQ(error_of("3:absent=yes"), "3:absent=yes: absent takes no value");
  for (const char* block :
       {"6:missing-block=0400H", "6:missing-block=0400H+0", "6:missing-block=0400H+126",
        "6:missing-block=FFFEH+4", "6:missing-block=04G0H+4"})
    EXPECT_NE(error_of(block).find("missing-block wants START+COUNT, as 0400H+4"),
              std::string::npos)
        << block;
}

}  // namespace
}  // namespace modtap::busgen
