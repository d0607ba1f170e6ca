// A Modbus serial bus simulator for tests and benchmarks: a master polling slaves with every
// public function code, slaves answering (or not), with character timing, fast turnarounds,
// turnaround glitches, line noise and truncated frames, faulty slaves, and the exact ground
// truth of it all.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string_view>
#include <vector>

#include "decoder/protocol/records.hpp"
#include "decoder/protocol/serial_format.hpp"

namespace modtap::busgen {

// Holding registers start to start + count - 1.
struct RegisterBlock {
  uint16_t start = 0;
  uint16_t count = 0;
  friend bool operator==(const RegisterBlock&, const RegisterBlock&) = default;
};

// What one slave does wrong, for a diagnosis to find. All off by default; a fault that is off
// draws nothing from the simulator's random numbers, so the rest of the bus stays as it was.
struct SlaveFaults {
  bool absent = false;  // never answers: a dead device, or a polled address with nothing behind it
  // Answers until this bus time (from the capture's start), never after: it died or lost power.
  std::optional<int64_t> stops_after_ns;
  // Restarts this often (a watchdog, a brown-out): silent for the first 5 s of every period of
  // bus time after the first, answering cleanly in between.
  std::optional<int64_t> restarts_every_ns;
  double drop_rate = 0.0;  // misses this share of requests (a busy CPU, a marginal receiver)
  // A slow device: answers after this and up to 3 ms more instead of the bus's turnaround. At
  // the master's time-out (retry_after_ns) or beyond, it answers late, as below.
  std::optional<int64_t> turnaround_ns;
  // Answers only after the master gave up: its turnaround is beyond the master's time-out, so
  // it answers t3.5 to t3.5 + 3 ms after the time-out ran out (this wins over turnaround_ns).
  bool answers_after_timeout = false;
  // This share of its answers arrive with a bit flipped in 1 to 3 bytes (a weak driver, a bad
  // stub), their structure whole: Damage::corrupted. The address byte may be hit.
  double corruption_rate = 0.0;
  // Registers it does not have: a FC03 read touching them gets exception 02, Illegal Data
  // Address. With a scan list, the master reads the block from this slave every cycle, right
  // after its usual read (a master configured for another firmware).
  std::optional<RegisterBlock> missing_block;
  // A block it answers slowly (one it computes, a gateway's remote registers): read every cycle
  // as a missing block is, its answer comes 60 to 63 ms after the request; the rest as usual.
  std::optional<RegisterBlock> slow_block;
  bool duplicate_address = false;  // a second device has its address: both answer, over each other
  bool turnaround_glitch = false;  // its driver puts a 0x00 or 0xFF on the line before every answer
  // Set to half the bus's baud rate: each of its bits lasts two of the line's, so every answer
  // reads as junk about twice its length, where the answer is due (Damage-free truth: garbled).
  bool half_baud = false;
  friend bool operator==(const SlaveFaults&, const SlaveFaults&) = default;
};

struct BusOptions {
  uint64_t seed = 1;
  size_t transactions = 1000;
  SerialFormat format;
  Mode mode = Mode::rtu;
  // Rates are per transaction, between 0 and 1.
  double exception_rate = 0.05;
  double no_response_rate = 0.03;  // the slave stays silent; the master waits out its time-out
  double broadcast_rate = 0.03;
  double fast_turnaround_rate = 0.2;  // the slave answers after less than t3.5
  int64_t min_turnaround_ns = 0;  // slaves answer after this and up to 3 ms more (NTA5000: 10 ms)
  double glitch_rate = 0.0;       // a 0x00 or 0xFF as the slave's driver turns on
  double request_glitch_rate = 0.0;    // the same as the master's driver turns on
  double noise_rate = 0.0;             // a burst of junk between transactions
  double truncation_rate = 0.0;        // the master's request breaks off, then is sent again
  double unknown_function_rate = 0.0;  // a vendor function code the length rules do not know
  // FC15 Write File Record with records up to the standard's 245 bytes of request data (a
  // drive's parameter download), not a few registers: echoes as long as their requests.
  bool long_file_records = false;
  // What real masters and buses do beyond the clean picture:
  double out_of_spec_rate = 0.0;  // a request over the standard's limits, answered by exception 03
  double retry_rate = 0.0;        // an unanswered request is sent again after the master's time-out
  // The master's time-out: after a request no answer came to (silence, or bytes that are no
  // frame), it sends nothing before it is over, neither the retry nor its next request. A cut
  // or talked-over answer ends the wait at once: the master has its CRC error.
  int64_t retry_after_ns = 200'000'000;
  double cut_rate = 0.0;        // the response breaks off (the slave resets, a wire comes loose)
  double collision_rate = 0.0;  // another device talks over the response's last bytes
  double pause_rate = 0.0;      // a sender pauses inside a frame, longer than t1.5 (RTU)
  double garbled_rate = 0.0;    // the answer comes as bytes that are no frame (a slave at another
                                // baud rate): its answer, garbled
  // Line noise (a bad termination): this share of every frame, requests and answers alike,
  // arrives with a bit flipped in 1 to 3 bytes, as SlaveFaults::corruption_rate. A slave ignores
  // a corrupted request, so the master waits out its time-out.
  double corruption_rate = 0.0;
  // A trunk not terminated: reflections flip bits in frames with odds that grow with their
  // length, none at 8 bytes, this at 32 and on (capped at 1), from every sender alike.
  double reflection_rate = 0.0;
  // A contactor or a drive switching nearby: a burst of 2 to 6 junk bytes every this long (and
  // up to 1 ms more), from the first period on. One that falls between frames is junk there;
  // one that falls on a frame (or too close before it) destroys that frame's check.
  int64_t noise_burst_period_ns = 0;
  // A second master on the line (an HMI, a gateway, a laptop left polling): every this long it
  // reads slave 201 on its own program, as soon as the line is quiet, which may be right after
  // the first master's request, before that request's answer. Its slave answers first; the
  // first master's slave, waiting for the line, after.
  int64_t second_master_period_ns = 0;
  int64_t poll_gap_ns = 5'000'000;  // master's idle time between transactions (at least)
  bool back_to_back = false;        // no idle time at all: the densest file for benchmarks
  // 0: each request goes to a slave picked at random from 1-247 (every address exercised);
  // N: the master polls slaves 1 to N in turn with the same read, as a PLC's scan list does.
  unsigned polled_slaves = 0;
  std::map<uint8_t, SlaveFaults> slave_faults;  // by address, 1-247; slave 0 has none
};

// Adds faults written as on busgen's command line, "ADDR:FAULT[,FAULT...]": absent, stops=TIME,
// drop=RATE, slow=TIME, late, bit-errors=RATE, missing-block=START+COUNT (START as 0400H,
// 0x400 or 1024), slow-block=START+COUNT, duplicate, glitch, half-baud, restarts=TIME; TIME as
// 131ms, 60s, 500us or 2.5s. Throws std::invalid_argument saying what is wrong.
void add_slave_faults(BusOptions& options, std::string_view spec);
// A time written as on busgen's command line (131ms, 60s, 500us, 2.5s); none where it is not.
std::optional<int64_t> bus_time_ns(std::string_view text);

// A frame the master or a slave really sent.
struct TruthFrame {
  uint64_t offset = 0;  // in the byte stream
  uint32_t size = 0;
  Role role = Role::request;
  std::optional<size_t> request;  // for a response: its request's position in `frames`
  uint32_t findings = 0;          // what the analyzer must say of it (finding_*)
  // A frame damaged on the wire: its bytes as they arrived, its check bad, and how it broke. A
  // corrupted request opens no transaction (no slave takes it): it is never in `timed_out`.
  Damage damage = Damage::none;
  // The slave it is to or from, as sent: a bit error may have changed the address on the wire.
  uint8_t slave = 0;
  // A response that came after the master's time-out (retry_after_ns) ran out; its request is
  // in `timed_out`. An analyzer whose time-out is the master's sees it as an unsolicited answer.
  bool late = false;
  friend bool operator==(const TruthFrame&, const TruthFrame&) = default;
};

// Two devices of one address answered a request at once (SlaveFaults::duplicate_address), the
// second 0 to 1.9 characters after the first: the bytes that were on the wire. Begun within
// the same bit, they read as one answer, in `frames`: good where both said the same, else
// corrupted where they differed (the master has its CRC error). Otherwise they are junk, in
// `garbled`: the answer, garbled.
struct Clash {
  size_t request = 0;  // its position in `frames`
  uint64_t offset = 0;
  uint32_t size = 0;
  friend bool operator==(const Clash&, const Clash&) = default;
};

struct BusCapture {
  std::vector<uint8_t> bytes;
  std::vector<int64_t> end_ns;  // when each byte's stop bit ended
  std::vector<TruthFrame> frames;
  // Positions in `frames` of good requests the master's time-out ran out on: unanswered, or
  // answered late. Junk in the answer's time is the answer, garbled (`garbled`), no time-out.
  std::vector<size_t> timed_out;
  std::vector<uint64_t> garbled;  // where each garbled answer begins in the byte stream
  std::vector<Clash> clashes;
  friend bool operator==(const BusCapture&, const BusCapture&) = default;
};

BusCapture simulate(const BusOptions& options);

// Appends one frame in the mode's wire form (RTU: adu + CRC; ASCII: ':' hex LRC CR LF).
void encode_frame(Mode mode, const std::vector<uint8_t>& body, std::vector<uint8_t>& out);

// How an adapter hands bytes to the program that reads it.
enum class Delivery {
  per_byte,      // each byte with its exact time (a logic analyzer)
  bursts,        // FTDI-style: whatever arrived, every 16 ms
  usb_packets,   // FTDI as it is: a packet once 62 bytes have come, else every 16 ms
  per_frame,     // a gap-based sniffer: one chunk per frame, some split, some merged
  whole_frames,  // exactly one chunk per frame or run of noise: what tshark's mbrtu needs
  untimed,       // a raw file: blocks with no time
};

struct DeliveredChunk {
  int64_t t_ns = 0;
  uint64_t offset = 0;
  uint32_t size = 0;
};

// How wrong the adapter's clock is: each read is stamped late by up to `jitter_ns` (a USB
// adapter, a busy host) and rounded up to `resolution_ns` (a coarse timer). Stamps never go back.
struct ClockError {
  int64_t jitter_ns = 0;
  int64_t resolution_ns = 1;
};

std::vector<DeliveredChunk> deliver(const BusCapture& capture, Delivery delivery, uint64_t seed,
                                    ClockError clock = {});
ClockQuality clock_of(Delivery delivery);

}  // namespace modtap::busgen
