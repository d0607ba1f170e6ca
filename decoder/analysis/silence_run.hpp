// A slave's time-outs in a row since it was last heard, and the silence they began: the one
// definition the diagnostics (answers-again), the statistics (outages) and the problems (a slave
// that stopped, a restart) count by. Each keeps its own run, as each sees its own records (the
// statistics only those -Y picks), but a run is the same thing in all three.
#pragma once

#include <cstdint>
#include <utility>

#include "decoder/protocol/findings.hpp"
#include "decoder/protocol/records.hpp"

namespace modtap {

struct SilenceRun {
  uint64_t timeouts = 0;
  uint64_t first_request = 0;  // the first request it left unanswered
  int64_t since_ns = 0;        // the end of that request

  // A request it left unanswered; whether the run became a silence with it.
  bool unanswered(const Timeout& timeout) {
    if (timeouts++ == 0) {
      first_request = timeout.request;
      since_ns = timeout.t_ns - timeout.waited_ns;
    }
    return timeouts == silent_after_timeouts;
  }
  // silent_after_timeouts or more in a row: the slave has gone silent.
  bool silent() const { return timeouts >= silent_after_timeouts; }
  // The slave was heard (an answer, garbled or not): the run ends; what it was.
  SilenceRun heard() { return std::exchange(*this, SilenceRun{}); }
};

}  // namespace modtap
