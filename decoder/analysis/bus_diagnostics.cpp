#include "decoder/analysis/bus_diagnostics.hpp"

#include <algorithm>
#include <cstdlib>
#include <utility>

namespace modtap {

BusDiagnostics::BusDiagnostics(SerialFormat format, ClockQuality clock, RecordSink& next,
                               int64_t read_jitter_ns)
    : t35_ns_(format.t35_ns()), sees_gaps_(clock == ClockQuality::per_byte), next_(next) {
  if (clock == ClockQuality::per_byte) jitter_floor_ns_ = 0;
  if (clock == ClockQuality::per_chunk) jitter_floor_ns_ = read_jitter_ns;
}

void BusDiagnostics::on_frame(const Frame& frame) {
  const uint32_t found = diagnose(frame);
  if (found == 0) {
    next_.on_frame(frame);
    return;
  }
  Frame diagnosed = frame;
  diagnosed.findings |= found;
  next_.on_frame(diagnosed);
}

uint32_t BusDiagnostics::diagnose(const Frame& frame) {
  uint32_t found = 0;
  if (frame.channel >= last_end_ns_.size()) last_end_ns_.resize(frame.channel + 1);
  auto& last_end = last_end_ns_[frame.channel];
  // A response's early start is the matcher's fast-turnaround; a request's is the master's.
  if (sees_gaps_ && frame.role == Role::request && last_end && frame.t_ns >= *last_end &&
      frame.t_ns - *last_end < t35_ns_)
    found |= finding_short_gap;
  last_end = frame.end_ns;
  // A garbled answer to a request is the device speaking, however badly: it is not silent.
  if (!frame.check_ok && frame.role == Role::response && frame.request)
    found |= back_from_silence(slaves_[frame.device()]);
  if (!frame.check_ok || frame.adu.empty()) return found;
  SlaveHistory& slave = slaves_[frame.slave()];
  if (frame.role == Role::request) {
    slave.timed_out_function.reset();  // the master asked again: a response now is for that
    return found | polled(frame, slave);
  }
  if (frame.role == Role::response) found |= answered(frame, slave);
  return found;
}

uint32_t BusDiagnostics::answered(const Frame& frame, SlaveHistory& slave) {
  uint32_t found = 0;
  const uint8_t function = frame.function() & 0x7F;
  if ((frame.findings & finding_unsolicited) && slave.timed_out_function == function)
    found |= finding_late_response;
  slave.timed_out_function.reset();
  found |= back_from_silence(slave);
  if (frame.is_exception() && frame.adu.size() > 2) {
    const bool same = slave.exceptions_in_a_row > 0 && slave.exception == frame.adu[2] &&
                      slave.exception_function == function;
    slave.exceptions_in_a_row = same ? slave.exceptions_in_a_row + 1 : 1;
    slave.exception = frame.adu[2];
    slave.exception_function = function;
    if (slave.exceptions_in_a_row >= storm_exceptions) found |= finding_exception_storm;
  } else {
    slave.exceptions_in_a_row = 0;
  }
  return found;
}

// The slave was heard: after a silence, its answer is the finding that says it is back.
uint32_t BusDiagnostics::back_from_silence(SlaveHistory& slave) {
  return slave.silence.heard().silent() ? uint32_t{finding_answers_again} : 0u;
}

// A master polls each slave in a cycle; a request far off the slave's usual interval shows the
// cycle stalled (a slow answer elsewhere, retries, a busy master) or hurried. A retry is the
// master's time-out at work, already a finding: it neither counts nor resets the cycle.
uint32_t BusDiagnostics::polled(const Frame& frame, SlaveHistory& slave) {
  if (!jitter_floor_ns_ || frame.slave() == 0 || (frame.findings & finding_retry)) return 0;
  const std::optional<int64_t> last = std::exchange(slave.last_poll_ns, frame.t_ns);
  if (!last || frame.t_ns < *last) return 0;
  const int64_t interval = frame.t_ns - *last;
  uint32_t found = 0;
  const size_t known = std::min(slave.intervals_seen, poll_history);
  if (known >= poll_history_known) {
    const int64_t median = slave.sorted[known / 2];
    if (std::abs(interval - median) * 2 >= median &&
        std::abs(interval - median) > *jitter_floor_ns_)
      found = finding_poll_jitter;
  }
  remember_interval(slave, interval);
  return found;
}

// The ring takes the interval in the oldest one's place; the sorted copy trades them by
// insertion, a few dozen instructions where sorting for each request cost a few hundred. The
// places are counted, not searched for: a binary search through intervals that vary
// mispredicts a branch at nearly every step, and a branch-free count of 16 does not.
void BusDiagnostics::remember_interval(SlaveHistory& slave, int64_t interval) {
  const size_t known = std::min(slave.intervals_seen, poll_history);
  int64_t* begin = slave.sorted.data();
  int64_t* end = begin + known;
  int64_t& slot = slave.intervals[slave.intervals_seen++ % poll_history];
  if (known == poll_history) {
    int64_t* oldest = begin + count_before(slave.sorted, known, slot, false);  // a copy of it
    std::move(oldest + 1, end, oldest);
    --end;
  }
  slot = interval;
  int64_t* at =
      begin + count_before(slave.sorted, static_cast<size_t>(end - begin), interval, true);
  std::move_backward(at, end, end + 1);
  *at = interval;
}

// Where `value` goes among the first `n` sorted values: before its equals, or after them.
size_t BusDiagnostics::count_before(const std::array<int64_t, poll_history>& sorted, size_t n,
                                    int64_t value, bool after_equals) {
  const auto first = sorted.begin(), last = sorted.begin() + static_cast<ptrdiff_t>(n);
  const auto at =
      after_equals ? std::upper_bound(first, last, value) : std::lower_bound(first, last, value);
  return static_cast<size_t>(at - first);
}

void BusDiagnostics::on_noise(const Noise& noise) {
  if (noise.damaged_answer) back_from_silence(slaves_[noise.request_slave]);
  next_.on_noise(noise);
}

void BusDiagnostics::on_timeout(const Timeout& timeout) {
  if (timeout.timed_out()) {
    SlaveHistory& slave = slaves_[timeout.slave];
    slave.timed_out_function = timeout.function & 0x7F;
    slave.silence.unanswered(timeout);
  }
  next_.on_timeout(timeout);
}

}  // namespace modtap
