#include "decoder/protocol/matcher.hpp"

#include <algorithm>
#include <utility>

#include "decoder/protocol/framing_evidence.hpp"
#include "decoder/protocol/function_codes.hpp"

namespace modtap {
Matcher::Matcher(const MatcherOptions& options, TimeoutHandler on_timeout)
    : options_(options), on_timeout_(std::move(on_timeout)) {}

inline void Matcher::set_pending(Pending* pending) {
  pending_ = pending;
  // With nothing pending, the answer the bus may still get is the late one of the request that
  // timed out last: its bytes are read as that answer first.
  expectation_ = pending             ? expecting(*pending)
                 : interrupted_open_ ? expecting(interrupted_)
                 : overdue_open_     ? overdue_expectation_
                                     : Expectation{};
}

inline Expectation Matcher::expecting(const Pending& request) const {
  const bool echoed = response_prefix({request.pdu.data(), request.size}).echoes_request;
  return {true,
          request.slave,
          request.pdu[0],
          static_cast<uint16_t>(echoed ? request.adu_size : 0),
          echoed && request.ambiguous_end,
          {request.pdu.data(), request.size},
          options_.timed ? request.end_ns + retry_from_ns(request) : 0};
}

inline void Matcher::remember(Pending& p, const Frame& frame) const {
  const auto pdu = frame.pdu();
  p.index = frame.index;
  p.channel = frame.channel;
  p.end_ns = frame.end_ns;
  p.slave = frame.slave();
  const int64_t own = options_.slave_timeout_ns ? (*options_.slave_timeout_ns)[p.slave] : 0;
  p.timeout_ns = own ? own : options_.timeout_ns;
  p.timeout_told = own || options_.timeout_told;
  p.adu_size = static_cast<uint16_t>(frame.adu.size());
  p.retries = frame.retries;
  p.end_read = frame.end_read;
  p.ambiguous_end = frame.findings & finding_ambiguous_end;
  p.garbled_answer = false;
  p.timed_out_in_silence = false;
  p.size = static_cast<uint16_t>(std::min(pdu.size(), p.pdu.size()));
  std::copy_n(pdu.begin(), p.size, p.pdu.begin());
}

// While a copy in doubt waits, the framers read the bytes after it as they would after the
// master's retry: that copy pending. Once it is told, the bus waits for what it did before.
void Matcher::doubt(const Frame& copy) {
  remember(held_copy_, copy);
  expectation_ = expecting(held_copy_);
}

void Matcher::end_doubt() {
  set_pending(pending_);
}

void Matcher::on_frame(Frame& frame, ChannelRole channel_role) {
  advance(frame.t_ns);
  const bool garbage = !frame.check_ok && awaits_answer(channel_role) && !pending_matches(frame);
  if (garbage) frame.findings |= finding_garbage_after_request;
  if (garbage && in_answer_time(frame.t_ns, channel_role)) return garbled_answer(frame);
  const CopyJudgement judgement = judge_copy(frame);
  const Copy copy = judgement.copy;
  const RoleDecision rule = decide_role({frame, channel_role, judgement});
  frame.role = rule.role;
  tell_role(frame, rule.why);
  // --explain: what told echo and retry apart, where both could be and that decided the role.
  const bool copy_decided = rule.why == RoleReason::retry || rule.why == RoleReason::awaited_answer;
  if (copy_decided && judgement.margin.runner_up != RunnerUp::none && options_.observer)
    options_.observer->on_copy(frame.channel, frame.offset, judgement.margin);
  // Right after an echo that may have been a retry, a frame that may answer the same request
  // is as ambiguous as a request, and an answer only a retry leaves room for answers that.
  const auto echo = std::exchange(ambiguous_echo_, std::nullopt);
  const bool after_echo = echo && may_answer(frame, *echo->request);
  if (frame.role == Role::request) {
    if (after_echo) frame.findings |= finding_ambiguous_echo;
    on_request(frame);
  } else if (frame.role == Role::response && after_echo && !pending_matches(frame)) {
    answers_retry(frame, *echo);
  } else if (frame.role == Role::response) {
    on_response(frame, copy);
  }
}

// A glitch is a driver turning on, so it says nothing of the answer. Other noise in the answer's
// time is the answer, garbled past reading (a slave at another baud rate, a bad line).
void Matcher::on_noise(Noise& noise, ChannelRole channel_role) {
  advance(noise.t_ns);
  if (!awaits_answer(channel_role) || noise.reason == NoiseReason::glitch) return;
  noise.findings |= finding_garbage_after_request;
  noise.request = pending_->index;
  noise.request_slave = pending_->slave;
  noise.damaged_answer = in_answer_time(noise.t_ns, channel_role);
  pending_->garbled_answer |= noise.damaged_answer;
}

// A frame with a bad check in the answer's time is the answer, whatever its damaged address or
// function code says. The wait goes on: junk may come before the answer itself (a vendor code
// of no length rule, a device starting at the wrong moment). If nothing readable follows, the
// slave did answer, garbled: no time-out. One that is the answer whole with bits flipped ends
// the wait, and a bad frame after it is the master's next request, sent on its CRC error, not a
// second answer: on RTU's binary, one as long as the request tells its answer is, or one of the
// awaited function whose own structure says where it ends (Damage::corrupted).
void Matcher::garbled_answer(Frame& frame) {
  frame.role = Role::response;
  tell_role(frame, RoleReason::garbled_answer);
  frame.request = pending_->index;
  frame.request_slave = pending_->slave;
  pending_->garbled_answer = true;
  if (frame.mode != Mode::rtu) return;
  const uint16_t told = told_answer_size(pending_->slave, {pending_->pdu.data(), pending_->size});
  const bool whole = (told && frame.adu.size() == told + 2u) ||
                     (frame.damage == Damage::corrupted && frame.adu.size() >= 2 &&
                      (frame.function() & 0x7F) == pending_->pdu[0]);
  if (!whole) return;
  resumed_ns_ = frame.end_ns;
  set_pending(nullptr);
}

// Whether something starting at `t_ns` on this channel comes where the pending request's answer
// belongs: in the time its slave answers in, and what the clock may add (a master told to wait
// longer still hears junk after that as junk). Without a clock nothing tells junk that came
// after the master gave up from a garbled answer.
bool Matcher::in_answer_time(int64_t t_ns, ChannelRole channel_role) const {
  return awaits_answer(channel_role) && options_.timed &&
         t_ns - pending_->end_ns < answer_over_ns(pending_->slave);
}

// Whether what comes on this channel now is where the pending request's answer belongs: on a
// split tap, the master's own channel carries none.
bool Matcher::awaits_answer(ChannelRole channel_role) const {
  return pending_ && channel_role != ChannelRole::master;
}

// A frame's role: the first rule that holds, in this order. Its port's direction says it on a
// split tap; the exception bit, or a structure that fits one role only, says it on a bus. Where
// both fit (an echo) or neither (a frame too damaged to tell), what the bus waits for decides,
// unless the frame is the pending request again, or another request of its kind that does not
// fit as the answer (a write of other values), sent past the time for its answer: the master's,
// after its time-out. A late answer that fits (a FC08 counter, a read of 3 bytes of coils, as
// long as their requests) stays the answer. A frame that answers the request that timed out
// last is that slave's answer, late: while the master waits for another slave's answer it
// sends nothing, and a request that is not the same again fits as that answer by chance (the
// same again is told by the master's next move: Analyzer holds it, copy_in_doubt).
inline bool Matcher::has_exception_bit(const RoleCase& c) const {
  return c.frame.is_exception();  // even on a damaged frame or an unexpected slave
}
inline bool Matcher::fits_request_only(const RoleCase& c) const {
  return c.frame.fit.request && !c.frame.fit.response;
}
inline bool Matcher::fits_response_only(const RoleCase& c) const {
  return c.frame.fit.response && !c.frame.fit.request;
}
inline bool Matcher::taken_for_retry(const RoleCase& c) const {
  return c.judgement.copy == Copy::retry;
}
inline bool Matcher::another_request_of_its_kind(const RoleCase& c) const {
  return pending_matches(c.frame) && c.judgement.copy == Copy::none && c.frame.check_ok &&
         c.frame.fit.request && !fits_pending(c.frame) && past_answer_time(c.frame);
}
inline bool Matcher::of_the_pending_request(const RoleCase& c) const {
  return pending_matches(c.frame);
}
inline bool Matcher::answers_overdue_now(const RoleCase& c) const {
  return answers_overdue(c.frame) && (in_answer_time(c.frame.t_ns, c.channel) ||
                                      (c.frame.fit.response && !copies(c.frame, overdue_)));
}
// After the other exchange: a copy of the request set aside, too soon for its master's retry,
// is its echo. Its slave answers once the line is quiet, so its time runs from that exchange's
// end.
inline bool Matcher::answers_interrupted_now(const RoleCase& c) const {
  if (!answers_interrupted(c.frame)) return false;
  if (!copies(c.frame, interrupted_)) return c.frame.fit.response;
  return options_.timed && too_soon_for_retry(interrupted_, c.frame.t_ns - resumed_ns_);
}
inline bool Matcher::fits_a_request(const RoleCase& c) const {
  return c.frame.fit.request;
}

// The rules unrolled at compile time, as the framer's evidence rows are: a role is given to
// every frame.
template <Matcher::RoleRule... rules>
inline Matcher::RoleDecision Matcher::first_holding(const RoleCase& c) const {
  RoleDecision decision{RoleReason::fits_neither, Role::unknown};
  (void)(((this->*rules.holds)(c) && (decision = {rules.why, rules.role}, true)) || ...);
  return decision;
}

Matcher::RoleDecision Matcher::decide_role(const RoleCase& c) const {
  return first_holding<
      RoleRule{RoleReason::master_channel, Role::request, &Matcher::on_master_channel},
      RoleRule{RoleReason::slave_channel, Role::response, &Matcher::on_slave_channel},
      RoleRule{RoleReason::exception_bit, Role::response, &Matcher::has_exception_bit},
      RoleRule{RoleReason::fits_request_only, Role::request, &Matcher::fits_request_only},
      RoleRule{RoleReason::fits_response_only, Role::response, &Matcher::fits_response_only},
      RoleRule{RoleReason::retry, Role::request, &Matcher::taken_for_retry},
      RoleRule{RoleReason::another_request, Role::request, &Matcher::another_request_of_its_kind},
      RoleRule{RoleReason::awaited_answer, Role::response, &Matcher::of_the_pending_request},
      RoleRule{RoleReason::overdue_answer, Role::response, &Matcher::answers_overdue_now},
      RoleRule{RoleReason::interrupted_answer, Role::response, &Matcher::answers_interrupted_now},
      RoleRule{RoleReason::fits_request, Role::request, &Matcher::fits_a_request}>(c);
}

bool Matcher::fits(const Frame& frame, const Pending& request) {
  return check_response_fit({request.pdu.data(), request.size}, frame.pdu()) == finding_none;
}

// Past the pending request's time for a retry, once a turnaround is known (the slave's, else
// the bus's).
bool Matcher::long_after_answer_due(const Frame& frame) const {
  const uint8_t slave = pending_->slave;
  return options_.timed && turnaround_learned(slave) &&
         frame.t_ns - pending_->end_ns >= retry_from_ns(*pending_);
}

// Past the time the pending request's answer comes in, and what the clock may add to a frame's
// time; with nothing learned, past the shortest time-out masters use. An answer that late and
// unfit would be two rare things, where a master's next request after a time-out is common.
bool Matcher::past_answer_time(const Frame& frame) const {
  return options_.timed &&
         frame.t_ns - pending_->end_ns >= answered_within_ns(*pending_) + options_.clock_lag_ns;
}

// A copy of the request, or a frame that fits as its answer (a FC08 counter, an exception).
bool Matcher::may_answer(const Frame& frame, const Pending& request) {
  return frame.check_ok && frame.slave() == request.slave &&
         (frame.function() & 0x7F) == request.pdu[0] &&
         (frame.is_exception() || copies(frame, request) || fits(frame, request));
}

bool Matcher::copies(const Frame& frame, const Pending& request) {
  const auto pdu = frame.pdu();
  return frame.slave() == request.slave && std::equal(pdu.begin(), pdu.end(), request.pdu.begin(),
                                                      request.pdu.begin() + request.size);
}

// A master that gets no answer sends the same request again after its own time-out (50 ms to
// 1 s in practice); for the echo codes that copy is byte for byte what the response would be.
// The slave's turnaround, learned from answers no retry could fake, tells them apart: a copy
// much later than the slave ever answered is a retry. Each reading is the other's runner-up
// (framing_evidence.hpp, Margin): the echo wins where its time tells against a retry, the retry
// where its time tells against an echo; where neither does (no clock, nothing learned, a copy
// only as late as the clock may stamp the answer late) it is taken for the echo, the retry
// standing beside it.
Matcher::CopyJudgement Matcher::judge_copy(const Frame& frame) const {
  if (!pending_ || !copies_pending(frame)) return {};
  // Where no answer is its request again (FC20's carries records), the copy is a retry.
  const auto pdu = std::span<const uint8_t>(pending_->pdu.data(), pending_->size);
  if (check_response_fit(pdu, pdu) != finding_none) return {Copy::retry, {}};
  const int64_t waited = frame.t_ns - pending_->end_ns;
  const bool timed = options_.timed;
  Margin against_retry{RunnerUp::retry};
  if (against_retry.tell(Feature::too_soon_for_retry,
                         timed && too_soon_for_retry(*pending_, waited)))
    return {Copy::response, against_retry};
  Margin against_echo{RunnerUp::echo};
  if (against_echo.tell(Feature::late_as_a_retry,
                        timed && (long_after_answer_due(frame) || as_late_as_a_retry(waited))))
    return {Copy::retry, against_echo};
  return {Copy::ambiguous, against_retry};
}

// How soon the master sends a request again, from retries no echo could fake: a copy of a
// request whose answer is no copy of it (a read), or one sent after the wait ran out in silence.
void Matcher::learn_retry_interval(const Frame& retry, const Pending& first) {
  const auto pdu = std::span<const uint8_t>(first.pdu.data(), first.size);
  const bool echo_could_fake = check_response_fit(pdu, pdu) == finding_none;
  if (!options_.timed || (echo_could_fake && !first.timed_out_in_silence)) return;
  const int64_t interval = retry.t_ns - first.end_ns;
  if (interval > 0 && (!retry_interval_ns_ || interval < retry_interval_ns_))
    retry_interval_ns_ = interval;
}

// A slave's longest turnaround grows; the slaves' are kept in order, so that what a slave not
// heard yet is taken to need is their middle (the slower, of two in the middle), not the
// slowest: one slow device, or one that answers past the master's time-out, says nothing of the
// others, and taken for all it made every other slave's retry, until that slave answered once,
// read as its answer.
void Matcher::learn_turnaround(uint8_t slave, int64_t latency_ns) {
  int64_t& longest = turnaround_ns_[slave];
  if (latency_ns <= longest) return;
  int64_t* first = ordered_turnarounds_.data();
  int64_t* last = first + slaves_timed_;
  int64_t* old = first;
  if (longest) {
    old = std::lower_bound(first, last, longest);
  } else {  // a slave timed for the first time: its 0 sorts first
    std::move_backward(first, last, last + 1);
    ++last;
    ++slaves_timed_;
  }
  // The old figure out, the ones between it and the new one down a place, the new one in.
  int64_t* place = std::upper_bound(old + 1, last, latency_ns);
  std::move(old + 1, place, old);
  *(place - 1) = latency_ns;
  longest = latency_ns;
}

// Whether a copy this long after its request is as late as the master's retries come, allowing
// for how late the clock may stamp it.
bool Matcher::as_late_as_a_retry(int64_t waited_ns) const {
  return retry_interval_ns_ && waited_ns + options_.clock_lag_ns >= retry_interval_ns_;
}

// Past the answer's time and what the clock may add to one frame's time (a turnaround learned
// on a read stamped on time says nothing of how late the next read is stamped); with nothing
// learned, 50 ms on, where a copy may be either.
int64_t Matcher::answer_over_ns(uint8_t slave) const {
  const int64_t within = answer_time_ns(slave);
  return turnaround_learned(slave) ? within + options_.clock_lag_ns : within;
}

// From when the master may send again: past its slave's answer time, and past its time-out
// where told; where not, no later than its own retries have come, less what the clock may
// take off (as the matcher judges a copy: too_soon_for_retry), so that the framer too reads a
// copy that late as the master's.
int64_t Matcher::retry_from_ns(const Pending& request) const {
  if (request.timeout_told) return told_wait_ns(request);
  const int64_t from = answer_over_ns(request.slave);
  if (!retry_interval_ns_) return from;
  return std::min(from, retry_interval_ns_ - options_.clock_lag_ns);
}

bool Matcher::pending_matches(const Frame& frame) const {
  return pending_ && pending_->slave == frame.slave() &&
         pending_->pdu[0] == (frame.function() & 0x7F);
}

void Matcher::on_request(Frame& frame) {
  const bool cut_in = cuts_in(frame);
  if (pending_ && !cut_in) expire(frame.t_ns, TimeoutReason::next_request);
  // The slave of a request set aside, asked again, gave up on answering it.
  if (interrupted_open_ && !cut_in && interrupted_.slave == frame.slave())
    expire_interrupted(frame.t_ns, TimeoutReason::next_request);
  // A slave ignores a request whose check fails, so it opens no transaction.
  if (!frame.check_ok) return;
  frame.findings |= request_spec_findings(frame.pdu());
  if (frame.slave() == 0) {
    frame.findings |= finding_broadcast;
    if (!may_broadcast(frame.function())) frame.findings |= finding_illegal_broadcast;
    return;
  }
  const auto pdu = frame.pdu();
  if (unanswered_ && unanswered_->slave == frame.slave() &&
      std::equal(pdu.begin(), pdu.end(), unanswered_->pdu.begin(),
                 unanswered_->pdu.begin() + unanswered_->size)) {
    frame.findings |= finding_retry;
    frame.retries = static_cast<uint8_t>(std::min(unanswered_->retries + 1, 255));
    learn_retry_interval(frame, *unanswered_);
  }
  unanswered_ = nullptr;
  // The slave asked anew answers the new request, not the one it let time out.
  if (overdue_open_ && overdue_.slave == frame.slave()) overdue_open_ = false;
  if (cut_in) set_aside();
  Pending& p = slots_[next_slot_];
  next_slot_ ^= 1;
  remember(p, frame);
  set_pending(&p);
}

bool Matcher::cuts_in(const Frame& frame) const {
  if (!pending_ || !options_.timed || !frame.check_ok || copies(frame, *pending_)) return false;
  const int64_t waited = frame.t_ns - pending_->end_ns;
  const int64_t master_waits =
      pending_->timeout_told ? told_wait_ns(*pending_) : shortest_master_timeout_ns;
  // A clock per read may place it before the pending request's end: sooner still.
  return waited < std::min(master_waits, answer_over_ns(pending_->slave));
}

// One request set aside at a time: an earlier one still unanswered has timed out by now.
void Matcher::set_aside() {
  if (interrupted_open_) expire_interrupted(pending_->end_ns, TimeoutReason::next_request);
  interrupted_ = *pending_;
  interrupted_open_ = true;
  resumed_ns_ = interrupted_.end_ns;
  set_pending(nullptr);
}

// The answer to a request set aside, after the exchange that cut in: paired, on time. Its wait
// holds another exchange, so it teaches nothing of the slave's turnaround; where the clock did
// not see its start (placed back to back with the other exchange's last byte), it has none.
void Matcher::interrupted_answer(Frame& frame) {
  tell_pair(frame, PairReason::set_aside);
  frame.request = interrupted_.index;
  frame.request_slave = interrupted_.slave;
  frame.request_pdu = {interrupted_.pdu.data(), interrupted_.size};
  frame.findings |= finding_after_other_master;
  if (!frame.untimed_start && count_turnaround(frame, interrupted_.end_ns, interrupted_.end_read))
    frame.latency_ns = frame.t_ns - interrupted_.end_ns;
  if (frame.check_ok)
    frame.findings |= check_response_fit({interrupted_.pdu.data(), interrupted_.size}, frame.pdu());
  interrupted_open_ = false;
  set_pending(pending_);
}

void Matcher::on_response(Frame& frame, Copy copy) {
  if (!pending_matches(frame)) {
    if (answers_interrupted(frame)) return interrupted_answer(frame);
    if (answers_overdue(frame)) return late_answer(frame);
    frame.findings |= finding_unsolicited;
    return tell_pair(frame, PairReason::none);
  }
  tell_pair(frame, PairReason::pending);
  frame.request = pending_->index;
  frame.request_slave = pending_->slave;
  frame.request_pdu = {pending_->pdu.data(), pending_->size};
  if (copy == Copy::ambiguous) {
    frame.findings |= finding_ambiguous_echo;
    ambiguous_echo_ = AmbiguousEcho{pending_, frame.index, frame.end_ns, frame.end_read};
  }
  // An answer in its request's read has no latency to show, but its placed one still bounds
  // the slave's turnaround for telling a retry from an echo. Only an answer no request could
  // be teaches it: not a copy (a retry's), nor a frame that reads as a request too and came
  // as late as the master's next one may (a FC08 counter 211 ms on would double every
  // slave's time for a retry).
  const int64_t waited = frame.t_ns - pending_->end_ns;
  const bool may_be_request = frame.fit.request && past_answer_time(frame);
  if (options_.timed && waited >= 0 && copy == Copy::none && frame.check_ok && !may_be_request)
    learn_turnaround(pending_->slave, waited);
  if (count_turnaround(frame, pending_->end_ns, pending_->end_read)) {
    frame.latency_ns = frame.t_ns - pending_->end_ns;
    if (options_.exact_clock && *frame.latency_ns < options_.t35_ns)
      frame.findings |= finding_fast_turnaround;
  }
  if (frame.check_ok)
    frame.findings |= check_response_fit({pending_->pdu.data(), pending_->size}, frame.pdu());
  resumed_ns_ = frame.end_ns;
  set_pending(nullptr);
}

// An answer right after an ambiguous echo, that only an answer can be: no slave answers twice,
// so the echo was the master's retry, and this answers it.
void Matcher::answers_retry(Frame& frame, const AmbiguousEcho& echo) {
  tell_pair(frame, PairReason::echo_as_retry);
  frame.request = echo.index;
  frame.request_slave = echo.request->slave;
  frame.request_pdu = {echo.request->pdu.data(), echo.request->size};
  if (count_turnaround(frame, echo.end_ns, echo.end_read))
    frame.latency_ns = frame.t_ns - echo.end_ns;
}

// An answer after its request's time-out (the master's next request, or silence as long as the
// time-out): the slave did answer, late. It counts against the master's time-out, not as an
// answer the master got, and a slave answers once.
void Matcher::late_answer(Frame& frame) {
  tell_pair(frame, PairReason::overdue);
  frame.role = Role::response;
  frame.request = overdue_.index;
  frame.request_slave = overdue_.slave;
  frame.request_pdu = {overdue_.pdu.data(), overdue_.size};
  frame.findings |= finding_late_response;
  if (count_turnaround(frame, overdue_.end_ns, overdue_.end_read))
    frame.latency_ns = frame.t_ns - overdue_.end_ns;
  overdue_open_ = false;
  set_pending(pending_);
}

// A copy of a request whose answer is that request again, where the master may have given up
// waiting: the pending request's copy too late for its answer (judge_copy's retry), or the
// copy of the one that timed out last. A master sends a retry only after its time-out, and then
// waits as long again for the retry's answer: its time-out where told, less what the clock may
// take off, else at least half the copy's wait since its request. A request of the master's
// own sooner than that shows it never waited for the copy's answer.
std::optional<int64_t> Matcher::copy_in_doubt(const Frame& frame) {
  advance(frame.t_ns);  // a pending request whose time-out has run out by now is overdue
  const Pending* request = copied_in_doubt(frame);
  if (!request) return std::nullopt;
  if (!request->timeout_told) return untold_decide_by(frame, request->end_ns);
  return frame.end_ns + request->timeout_ns - options_.clock_lag_ns;
}

const Matcher::Pending* Matcher::copied_in_doubt(const Frame& frame) const {
  const Pending* request = pending_matches(frame) ? pending_ : overdue_open_ ? &overdue_ : nullptr;
  // Most copies of the pending request are its echo, in the time an answer takes.
  if (!request ||
      (request == pending_ && too_soon_for_retry(*request, frame.t_ns - request->end_ns)))
    return nullptr;
  if (!copies(frame, *request)) return nullptr;
  if (request != pending_ &&
      (in_answer_time(frame.t_ns, ChannelRole::bus) || !in_late_answer_time(frame, *request)))
    return nullptr;
  const auto pdu = std::span<const uint8_t>(request->pdu.data(), request->size);
  if (!response_prefix(pdu).echoes_request) return nullptr;  // no echo could be it
  if (request == pending_ && judge_copy(frame).copy != Copy::retry) return nullptr;
  return request;
}

// A late answer comes within a time-out of its request's; a copy long after is the master
// asking again.
bool Matcher::in_late_answer_time(const Frame& frame, const Pending& request) {
  return frame.t_ns - request.end_ns < 2 * request.timeout_ns;
}

// The master's request to another slave or function, sooner than it waits for an answer.
bool Matcher::moved_on_after(const Frame& copy, const Frame& next, int64_t decide_by_ns) {
  return next.check_ok && next.fit.request && next.channel == copy.channel &&
         next.t_ns < decide_by_ns &&
         (next.slave() != copy.slave() || next.function() != copy.function());
}

// The copy was the answer: to the pending request, as its echo (a turnaround too late to teach
// anything), or to the request that timed out, late.
void Matcher::on_late_copy(Frame& frame) {
  ambiguous_echo_.reset();
  frame.role = Role::response;
  tell_role(frame, RoleReason::held_copy_answer);
  if (pending_matches(frame)) return on_response(frame, Copy::response);
  late_answer(frame);
}

std::optional<int64_t> Matcher::echo_in_doubt(const Frame& frame) const {
  if (!options_.timed || !pending_ || pending_->timeout_told || !frame.check_ok ||
      !copies_pending(frame) || frame.t_ns - pending_->end_ns < shortest_master_timeout_ns ||
      judge_copy(frame).copy != Copy::response)
    return std::nullopt;
  return frame.end_ns + answer_over_ns(pending_->slave);
}

void Matcher::on_retry_copy(Frame& frame) {
  advance(frame.t_ns);
  ambiguous_echo_.reset();
  frame.role = Role::request;
  tell_role(frame, RoleReason::chained_copy_retry);
  on_request(frame);
}

// Whether the clock saw the silence between the request and this answer. A clock that steps
// back, or stamps reads later than the bytes ended, can put a response before its request's
// end: that latency is not measured rather than negative. An answer that came in the read of
// the request's last bytes has no time of its own (a sniffer's packet, a hex log's block).
bool Matcher::count_turnaround(const Frame& frame, int64_t request_end_ns,
                               uint64_t request_end_read) {
  const bool one_read = frame.start_read != 0 && frame.start_read == request_end_read;
  if (!options_.timed || one_read) return false;
  ++timed_answers_;
  early_answers_ += frame.t_ns < request_end_ns;
  return frame.t_ns >= request_end_ns;
}

void Matcher::advance(int64_t now_ns) {
  if (interrupted_open_ && options_.timed && now_ns - interrupted_.end_ns > interrupted_.timeout_ns)
    expire_interrupted(interrupted_.end_ns + interrupted_.timeout_ns, TimeoutReason::silence);
  if (pending_ && options_.timed && now_ns - pending_->end_ns > pending_->timeout_ns)
    expire(pending_->end_ns + pending_->timeout_ns, TimeoutReason::silence);
}

void Matcher::finish(int64_t end_ns) {
  advance(end_ns);
  if (interrupted_open_) expire_interrupted(end_ns, TimeoutReason::end_of_capture);
  if (pending_) expire(end_ns, TimeoutReason::end_of_capture);
}

void Matcher::expire(int64_t now_ns, TimeoutReason reason) {
  Pending& request = *pending_;
  resumed_ns_ = now_ns;
  set_pending(nullptr);
  time_out(request, now_ns, reason);
}

void Matcher::expire_interrupted(int64_t now_ns, TimeoutReason reason) {
  interrupted_open_ = false;
  time_out(interrupted_, now_ns, reason);
  set_pending(pending_);
}

// A request whose wait ran out: overdue from now, its slave's answer late; none where it
// answered, garbled.
void Matcher::time_out(Pending& request, int64_t now_ns, TimeoutReason reason) {
  if (request.garbled_answer) return;
  Timeout t;
  t.request = request.index;
  t.channel = request.channel;
  t.slave = request.slave;
  t.function = request.pdu[0];
  // A clock that stepped back may put `now` before the request's end: it waited no time.
  t.t_ns = std::max(now_ns, request.end_ns);
  t.waited_ns = t.t_ns - request.end_ns;
  t.reason = reason;
  request.timed_out_in_silence = reason == TimeoutReason::silence;
  overdue_ = request;
  unanswered_ = &overdue_;
  overdue_open_ = true;
  overdue_expectation_ = expecting(overdue_);
  set_pending(pending_);
  on_timeout_(t);
}

}  // namespace modtap
