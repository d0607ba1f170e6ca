// A Modbus serial bus simulator for tests and benchmarks: a master polling slaves with every
// public function code, slaves answering (or not), with character timing, fast turnarounds,
// turnaround glitches, line noise and truncated frames, and the exact ground truth of it all.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "decoder/records.hpp"
#include "decoder/serial_format.hpp"

namespace modtap::busgen {

struct BusOptions {
  uint64_t seed = 1;
  size_t transactions = 1000;
  decoder::SerialFormat format;
  decoder::Mode mode = decoder::Mode::rtu;
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
                                // baud rate), and the master times out
  int64_t poll_gap_ns = 5'000'000;  // master's idle time between transactions (at least)
  bool back_to_back = false;        // no idle time at all: the densest file for benchmarks
  // 0: each request goes to a slave picked at random from 1-247 (every address exercised);
  // N: the master polls slaves 1 to N in turn with the same read, as a PLC's scan list does.
  unsigned polled_slaves = 0;
};

// A frame the master or a slave really sent, whole and with a good check.
struct TruthFrame {
  uint64_t offset = 0;  // in the byte stream
  uint32_t size = 0;
  decoder::Role role = decoder::Role::request;
  std::optional<size_t> request;  // for a response: its request's position in `frames`
  uint32_t findings = 0;          // what the analyzer must say of it (decoder::finding_*)
  // A response damaged on the wire: its bytes as sent, its check bad, and how it broke.
  decoder::Damage damage = decoder::Damage::none;
};

struct BusCapture {
  std::vector<uint8_t> bytes;
  std::vector<int64_t> end_ns;  // when each byte's stop bit ended
  std::vector<TruthFrame> frames;
  std::vector<size_t> timed_out;  // positions in `frames` of requests left unanswered
  std::vector<uint64_t> garbled;  // where each garbled answer begins in the byte stream
};

BusCapture simulate(const BusOptions& options);

// Appends one frame in the mode's wire form (RTU: adu + CRC; ASCII: ':' hex LRC CR LF).
void encode_frame(decoder::Mode mode, const std::vector<uint8_t>& body, std::vector<uint8_t>& out);

// How an adapter hands bytes to the program that reads it.
enum class Delivery {
  per_byte,      // each byte with its exact time (a logic analyzer)
  bursts,        // FTDI-style: whatever arrived, every 16 ms
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
decoder::ClockQuality clock_of(Delivery delivery);

}  // namespace modtap::busgen
