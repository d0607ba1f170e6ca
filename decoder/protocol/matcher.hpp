// Pairs requests with responses on one bus: decides each frame's role, measures turnaround,
// and reports time-outs, broadcasts, unsolicited responses, responses that do not fit, and
// noise where an answer was awaited.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <functional>
#include <optional>

#include "decoder/protocol/frame_sink.hpp"
#include "decoder/protocol/framing_evidence.hpp"
#include "decoder/protocol/records.hpp"

namespace modtap {

// Each slave's own time-out, where its device model gives one (0: the bus's), read at each
// request: the model stage adds a slave's when the slave identifies itself.
using SlaveTimeouts = std::array<int64_t, 256>;

// The shortest time-out masters use: no master sends again sooner while it waits for an
// answer, so a request that does is another master's.
inline constexpr int64_t shortest_master_timeout_ns = 50'000'000;

struct MatcherOptions {
  int64_t timeout_ns = 1'000'000'000;
  bool timeout_told = false;  // timeout_ns is the master's, told: it sends nothing again sooner
  const SlaveTimeouts* slave_timeout_ns = nullptr;  // a slave's own (told); none or 0: timeout_ns
  int64_t t35_ns = 0;        // below this a response counts as a fast turnaround
  bool timed = true;         // false when the source has no clock: no latency, no silence
  bool exact_clock = false;  // latencies are exact enough to judge turnaround
  // How late a clock that stamps reads, not bytes, may put a frame: a read that also holds the
  // frame after it is stamped when that one ended.
  int64_t clock_lag_ns = 0;
  FramingObserver* observer = nullptr;  // told how a copy of the pending request was judged
};

class Matcher {
 public:
  using TimeoutHandler = std::function<void(const Timeout&)>;

  Matcher(const MatcherOptions& options, TimeoutHandler on_timeout);

  // Decides the role and fills request, latency and findings. `channel_role` is what the
  // frame's port says of its direction.
  void on_frame(Frame& frame, ChannelRole channel_role);
  // Noise where a slave's answer was awaited is marked so, with the request it came after.
  void on_noise(Noise& noise, ChannelRole channel_role);
  // Any record or the clock moving on: a pending request older than the time-out expires.
  void advance(int64_t now_ns);
  void finish(int64_t end_ns);

  // A copy of an echo request (FC05/06/08/16...) that the master may have given up on: the
  // pending one past the time its answer takes, or the one that timed out last. It is the
  // slave's late answer or the master's retry, and only the master's next move tells: the time
  // by which a request of the master's that shows it did not wait for the copy's answer would
  // come (Analyzer holds the copy until then). None where the frame is no such copy.
  std::optional<int64_t> copy_in_doubt(const Frame& frame);
  // What copy_in_doubt asks first, cheaply, of every frame: a good frame that reads as a
  // request, of the pending request's slave later than its answer takes (or past its time-out),
  // or of the slave whose request timed out last.
  bool may_be_copy_in_doubt(const Frame& frame) const {
    if (!options_.timed || !frame.check_ok || !frame.fit.request) return false;
    const uint8_t slave = frame.slave();
    if (pending_ && pending_->slave == slave) {
      const int64_t waited = frame.t_ns - pending_->end_ns;
      return !too_soon_for_retry(*pending_, waited) || waited > pending_->timeout_ns ||
             (!pending_->timeout_told && waited >= shortest_master_timeout_ns);
    }
    return overdue_open_ && overdue_.slave == slave;
  }
  // Whether `next`, the first frame after such a copy, is the master's request to another slave
  // or function, sent before the master waits for an answer: then the copy was no request.
  static bool moved_on_after(const Frame& copy, const Frame& next, int64_t decide_by_ns);
  // A copy of the pending request that only its slave's learned turnaround reads as the echo:
  // the master's time-out untold, and the copy as late as a master may time out. A slave that
  // answers after the master's time-out teaches a turnaround that late, and every retry of the
  // master's then reads as its echo, the slave's answer after it as a request. The same bytes
  // again, and the master moving on at once, show the retry (Analyzer holds both): the time by
  // which those bytes would come, the slave's answer time after this copy. None where the frame
  // is no such copy.
  std::optional<int64_t> echo_in_doubt(const Frame& frame) const;
  // The time by which the master's request to another slave or function shows that it did not
  // wait for an answer to `copy`, sent `since_ns` after what it copies: a master that sends again
  // waits at least half as long again for the answer (its time-out not told).
  static int64_t untold_decide_by(const Frame& copy, int64_t since_ns) {
    return copy.end_ns + (copy.t_ns - since_ns) / 2;
  }
  // The copy echo_in_doubt held was the master's retry: the same bytes after it answered it.
  void on_retry_copy(Frame& frame);
  // The copy in doubt taken for the late answer of the request it copies.
  void on_late_copy(Frame& frame);
  bool copies_pending(const Frame& frame) const { return pending_ && copies(frame, *pending_); }
  // What the bus waits for while the copy is held in doubt, and after: its answer, as after a
  // retry, so that the bytes after it are framed as they would be were it the master's.
  void doubt(const Frame& copy);
  void end_doubt();

  const Expectation& expectation() const { return expectation_; }
  // Answers in a read of their own, and those of them placed to begin before their request
  // ended: at the line's real speed none does, so many say the line is faster than told.
  uint64_t timed_answers() const { return timed_answers_; }
  uint64_t early_answers() const { return early_answers_; }

 private:
  struct Pending {
    uint64_t index = 0;
    uint16_t channel = 0;
    int64_t end_ns = 0;
    int64_t timeout_ns = 0;
    bool timeout_told = false;  // the master's time-out for it is known, not a default
    uint8_t slave = 0;
    uint16_t adu_size = 0;
    uint8_t retries = 0;
    bool ambiguous_end = false;
    uint64_t end_read = 0;              // Frame::end_read
    bool garbled_answer = false;        // noise or a bad-check frame came in its answer's time
    bool timed_out_in_silence = false;  // its wait ran out with nothing on the line
    uint16_t size = 0;                  // PDU bytes kept (enough for echo and fit checks)
    std::array<uint8_t, 256> pdu;       // left uninitialised: only `size` bytes are ever read
  };
  // An echo just taken for the answer that may have been the master's retry (its request's
  // slot stays as it was until the next request but one).
  struct AmbiguousEcho {
    const Pending* request;
    uint64_t index;
    int64_t end_ns;
    uint64_t end_read;
  };

  // What a frame that repeats the pending request byte for byte is: its (echo) response, the
  // master's retry, or either; none when it is no such copy.
  enum class Copy : uint8_t { none, response, retry, ambiguous };
  // A copy of the pending request judged, with what told its runner-up apart.
  struct CopyJudgement {
    Copy copy = Copy::none;
    Margin margin{};
  };
  CopyJudgement judge_copy(const Frame& frame) const;
  static bool copies(const Frame& frame, const Pending& request);
  static bool may_answer(const Frame& frame, const Pending& request);
  // How soon after its request a copy of it can only be the answer, and from when it may be
  // the master's retry (from when it can only be one, once a turnaround is learned). The first:
  // twice the longest turnaround seen (the slave's, else the bus's middle) and 20 ms; with nothing
  // learned, 50 ms, the shortest time-out masters use. A master told to wait (--timeout, a
  // model's time-out) sends nothing again before its time-out, less what the clock may take
  // off, and may from then on, however slowly its slave answers: an answer that late is late.
  int64_t answered_within_ns(const Pending& request) const {
    return request.timeout_told ? told_wait_ns(request) : answer_time_ns(request.slave);
  }
  // Whether a copy `waited_ns` after its request came before the master's retry could: in the
  // time its answer takes, and sooner than the master's own retries have come (where its
  // time-out is not told: a told one stands).
  bool too_soon_for_retry(const Pending& request, int64_t waited_ns) const {
    return waited_ns < answered_within_ns(request) &&
           (request.timeout_told || !as_late_as_a_retry(waited_ns));
  }
  int64_t told_wait_ns(const Pending& request) const {
    return request.timeout_told ? request.timeout_ns - options_.clock_lag_ns : 0;
  }
  int64_t answer_time_ns(uint8_t slave) const {
    constexpr int64_t slack_ns = 20'000'000;
    const int64_t learned = turnaround_learned(slave);
    return learned ? 2 * learned + slack_ns : shortest_master_timeout_ns;
  }
  int64_t answer_over_ns(uint8_t slave) const;
  int64_t retry_from_ns(const Pending& request) const;
  int64_t turnaround_learned(uint8_t slave) const {
    return turnaround_ns_[slave] ? turnaround_ns_[slave] : bus_turnaround();
  }
  void learn_retry_interval(const Frame& retry, const Pending& first);
  bool as_late_as_a_retry(int64_t waited_ns) const;
  void learn_turnaround(uint8_t slave, int64_t latency_ns);
  int64_t bus_turnaround() const {
    return slaves_timed_ ? ordered_turnarounds_[slaves_timed_ / 2] : 0;
  }

  // What decides a frame's role: the frame, its port's direction and how a copy of the
  // pending request was judged.
  struct RoleCase {
    const Frame& frame;
    ChannelRole channel;
    const CopyJudgement& judgement;
  };
  // A rule of the role table: where it holds, the frame has its role, for its reason.
  struct RoleRule {
    RoleReason why;
    Role role;
    bool (Matcher::*holds)(const RoleCase&) const;
  };
  struct RoleDecision {
    RoleReason why;
    Role role;
  };
  RoleDecision decide_role(const RoleCase& c) const;
  template <RoleRule... rules>
  RoleDecision first_holding(const RoleCase& c) const;
  bool on_master_channel(const RoleCase& c) const { return c.channel == ChannelRole::master; }
  bool on_slave_channel(const RoleCase& c) const { return c.channel == ChannelRole::slave; }
  bool has_exception_bit(const RoleCase& c) const;
  bool fits_request_only(const RoleCase& c) const;
  bool fits_response_only(const RoleCase& c) const;
  bool taken_for_retry(const RoleCase& c) const;
  bool another_request_of_its_kind(const RoleCase& c) const;
  bool of_the_pending_request(const RoleCase& c) const;
  bool answers_overdue_now(const RoleCase& c) const;
  bool answers_interrupted_now(const RoleCase& c) const;
  bool fits_a_request(const RoleCase& c) const;
  void tell_role(const Frame& frame, RoleReason why) const {
    if (options_.observer) options_.observer->on_role(frame.channel, frame.offset, frame.role, why);
  }
  void tell_pair(const Frame& frame, PairReason how) const {
    if (options_.observer) options_.observer->on_pair(frame.channel, frame.offset, how);
  }
  // Whether the frame fits as the request's answer.
  static bool fits(const Frame& frame, const Pending& request);
  bool fits_pending(const Frame& frame) const { return fits(frame, *pending_); }
  bool long_after_answer_due(const Frame& frame) const;
  bool past_answer_time(const Frame& frame) const;
  // Whether the clock saw the answer's turnaround; counts the answers timed, and the early ones.
  bool count_turnaround(const Frame& frame, int64_t request_end_ns, uint64_t request_end_read);
  void on_request(Frame& frame);
  void on_response(Frame& frame, Copy copy);
  void garbled_answer(Frame& frame);
  void answers_retry(Frame& frame, const AmbiguousEcho& echo);
  // An answer to the request that timed out last, after its time-out: paired, and late.
  bool answers_overdue(const Frame& frame) const {
    return overdue_open_ && in_late_answer_time(frame, overdue_) && may_answer(frame, overdue_);
  }
  void late_answer(Frame& frame);
  // A request sooner after the pending one than its master could have given up on it (its
  // time-out where told, else the shortest masters use), and sooner than its slave's answer
  // would be over: another master's, cutting in. The pending request's answer is still due.
  bool cuts_in(const Frame& frame) const;
  void set_aside();
  bool answers_interrupted(const Frame& frame) const {
    return interrupted_open_ && may_answer(frame, interrupted_);
  }
  void interrupted_answer(Frame& frame);
  static bool in_late_answer_time(const Frame& frame, const Pending& request);
  // The request a copy in doubt copies, and whether it is still pending.
  const Pending* copied_in_doubt(const Frame& frame) const;
  void expire(int64_t now_ns, TimeoutReason reason);
  void expire_interrupted(int64_t now_ns, TimeoutReason reason);
  void time_out(Pending& request, int64_t now_ns, TimeoutReason reason);
  bool pending_matches(const Frame& frame) const;
  bool awaits_answer(ChannelRole channel_role) const;
  bool in_answer_time(int64_t t_ns, ChannelRole channel_role) const;

  MatcherOptions options_;
  TimeoutHandler on_timeout_;
  // Two slots, so a paired request stays readable through its response's callback while
  // no request is copied on the hot path.
  std::array<Pending, 2> slots_;
  uint8_t next_slot_ = 0;
  Pending* pending_ = nullptr;     // the open transaction
  Pending* unanswered_ = nullptr;  // the request that last timed out, until another is sent
  // The request that last timed out, kept until its slave is asked again or answers it late:
  // a slave answers after the master has moved on to others.
  Pending overdue_;
  bool overdue_open_ = false;
  Expectation overdue_expectation_;  // what overdue_ means to a framer, while open
  // The request another master's cut in on, set aside while the other exchange runs: its answer
  // still due, it times out as a pending request does, or once its slave is asked again.
  Pending interrupted_;
  bool interrupted_open_ = false;
  int64_t resumed_ns_ = 0;  // when the exchange that cut in ended: the line was the slave's again
  std::optional<AmbiguousEcho> ambiguous_echo_;  // the last frame, where it was one
  Expectation expectation_;  // what pending_ means to a framer, kept in step with it
  uint64_t timed_answers_ = 0, early_answers_ = 0;
  // The longest turnaround seen per slave, from pairs no retry could fake; and what a slave not
  // heard yet is taken to need: the middle of those (bus_turnaround), kept in order.
  std::array<int64_t, 256> turnaround_ns_{};
  std::array<int64_t, 256> ordered_turnarounds_{};  // the first slaves_timed_ hold them, rising
  uint16_t slaves_timed_ = 0;
  int64_t retry_interval_ns_ = 0;  // the shortest seen from a request's end to its retry

  void set_pending(Pending* pending);
  Expectation expecting(const Pending& request) const;
  void remember(Pending& request, const Frame& frame) const;
  Pending held_copy_;  // the copy in doubt Analyzer holds, as a pending request
};

}  // namespace modtap
