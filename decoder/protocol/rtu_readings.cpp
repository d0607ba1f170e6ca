#include "decoder/protocol/rtu_readings.hpp"

#include <algorithm>
#include <array>

#include "decoder/protocol/checksum.hpp"
#include "decoder/protocol/function_codes.hpp"

namespace modtap {
RtuReadings::RtuReadings(uint16_t channel, const RtuFramerOptions& options,
                         const Expectation& expected, const RtuStream& stream)
    : channel_(channel),
      options_(options),
      expected_(expected),
      awaited_(expected, options.role != ChannelRole::master),
      s_(stream),
      row_weights_(options.weights) {}

// Function code 0 is no function's: no frame starts there.
bool RtuReadings::may_start(uint8_t fc) {
  return (fc & 0x7F) != 0;
}

// Reads are never broadcast, and only answers carry the exception bit.
bool RtuReadings::may_start_request(uint8_t slave, uint8_t fc) {
  return may_start(fc) && !(fc & 0x80) && (slave != 0 || may_broadcast(fc));
}

RtuReadings::Match RtuReadings::match_at(uint64_t at, bool final, int search, bool observed) {
  if (options_.observer && observed) options_.observer->on_start(channel_, at);
  if (s_.end - at < 2) return need_more();
  const Readings readings = readings_at(at);
  if (const std::optional<Evidence> row = readings.count ? weigh_start(at) : std::nullopt) {
    for (size_t i = 0; observed && i < readings.count; ++i)
      observe(at, readings.order[i], {}, ReadingOutcome::refuted_at_start, *row);
    return {};
  }
  bool waiting = false;
  std::optional<std::pair<uint16_t, Evidence>> refuted;  // a span refuted, in either role
  for (size_t i = 0; i < readings.count; ++i) {
    const Role role = readings.order[i];
    Match m = match_role(role, at, final, search);
    const Role other = role == Role::request ? Role::response : Role::request;
    const bool other_allowed = readings.allows(other);
    if (m.kind == Match::Kind::found) {
      const bool refuted_span = refuted && refuted->first == m.length;
      Evidence why = refuted_span ? refuted->second : Evidence::length_and_crc;
      const Verdict verdict =
          refuted_span
              ? Verdict::refuted
              : weigh_span({at, role, m.length, other_allowed ? &other : nullptr, final, search},
                           why);
      if (observed) observe(at, role, m, outcome_of(verdict), why);
      if (verdict == Verdict::wait) return need_more();
      if (verdict == Verdict::refuted) {
        refuted = {m.length, why};
        continue;
      }
      // The same bytes may read as the other role too (echo codes 05, 06, 08, ...).
      if (other_allowed && fits_role(other, at, m.length)) m.fit = {true, true};
      return m;
    }
    const bool open = m.kind == Match::Kind::need_more;
    if (observed)
      observe(at, role, {}, open ? ReadingOutcome::waiting : ReadingOutcome::no_frame,
              open ? Evidence::more_bytes_needed : Evidence::no_good_end);
    // The likelier reading is still open: wait for it rather than take the other one early,
    // unless a silence with a good frame after it says it never completes (a master's retry
    // read as the response its slave did not send).
    if (!open || blocked_by_gap(at, final)) continue;
    if (!final) return m;
    waiting = true;
  }
  return waiting ? need_more() : Match{};
}

// The roles the bytes at `at` may be read in, the likelier first: the response where the bus
// waits for an answer of this slave and function. None where no frame can start.
RtuReadings::Readings RtuReadings::readings_at(uint64_t at) const {
  const uint8_t* p = at_ptr(at);
  const uint8_t fc = p[1];
  Readings readings;
  if (!may_start(fc)) return readings;
  readings.request = options_.role != ChannelRole::slave && may_start_request(p[0], fc);
  readings.response = options_.role != ChannelRole::master && p[0] != 0;
  const bool response_first =
      expected_.pending && expected_.slave == p[0] && expected_.function == (fc & 0x7F);
  for (const Role role : response_first ? std::array{Role::response, Role::request}
                                        : std::array{Role::request, Role::response})
    if (readings.allows(role)) readings.order[readings.count++] = role;
  return readings;
}

ReadingOutcome RtuReadings::outcome_of(Verdict verdict) {
  static constexpr ReadingOutcome outcomes[] = {ReadingOutcome::kept, ReadingOutcome::refuted,
                                                ReadingOutcome::waiting};
  return outcomes[static_cast<size_t>(verdict)];
}

void RtuReadings::observe(uint64_t at, Role role, const Match& match, ReadingOutcome outcome,
                          Evidence why) const {
  if (options_.observer)
    options_.observer->on_reading(
        {channel_, at, role, match.length, match.end, outcome, why, match.end_margin});
}

RtuReadings::Match RtuReadings::match_role(Role role, uint64_t at, bool final, int search) {
  const uint64_t avail = s_.end - at;
  const uint8_t* p = at_ptr(at);
  const BodyLength body = body_length(role, {p, static_cast<size_t>(avail)});
  const RoleFit fit{role == Role::request, role == Role::response};
  switch (body.kind) {
    case BodyLength::Kind::need_more:
      return need_more();
    case BodyLength::Kind::invalid:
      return {};
    case BodyLength::Kind::known: {
      const uint16_t total = body.bytes + crc_size;
      if (total > max_rtu_adu) return {};
      if (avail < total) return need_more();
      if (rtu_crc_holds({p, total})) return {Match::Kind::found, total, fit};
      return {};
    }
    case BodyLength::Kind::variable: {
      const Expectation& expected = expected_;
      if (role == Role::response && expected.echo_size && expected.slave == p[0] &&
          expected.function == p[1]) {
        if (avail < expected.echo_size) return need_more();
        if (rtu_crc_holds({p, expected.echo_size})) {
          // The echo of a request whose end was in doubt is in doubt alike, where the runner-up
          // of its end stands.
          const uint16_t n = expected.echo_size;
          if (!expected.echo_end_in_doubt)
            return {Match::Kind::found, n, fit, {}, SpanEnd::echo_length};
          if (avail == n && !final) return need_more();
          Margin doubt = longer_end(at, at + n);
          if (!doubt.stands()) consider(doubt, shorter_end(at, at + n, final, search - 1));
          return {Match::Kind::found, n, fit, doubt, SpanEnd::echo_length};
        }
      }
      if (search <= 0) return {};
      return search_end(at, std::max<size_t>(body.bytes + crc_size, min_adu), fit, final, search,
                        body.public_header);
    }
  }
  return {};
}

// A bounded CRC search for the end of a frame of no fixed length, from `first` bytes on. Its
// hit stands once something confirms it (span_end_table), a turnaround glitch only where
// nothing else does, and never where it swallows a frame a bus carries; the header of a public
// function whose length only its CRC tells (`public_header`, the feature public-header) confirms
// its first end once nothing more can.
RtuReadings::Match RtuReadings::search_end(uint64_t at, size_t first, RoleFit fit, bool final,
                                           int search, bool public_header) {
  const uint64_t avail = s_.end - at;
  const uint64_t limit = std::min<uint64_t>(avail, max_rtu_adu);
  const bool in_junk = at >= crc_index_.begin() && at < crc_index_.end();
  if (!in_junk) {
    const Match m = first_confirmed_end(at, first, limit, fit, final, search);
    if (m.kind == Match::Kind::found) return m;
  }
  std::array<uint16_t, max_rtu_adu> hits;  // lengths with a good CRC, ascending
  const size_t hit_count = good_lengths(at, first, limit, hits);
  // Junk's usual case, at nearly every start: no end to weigh.
  if (hit_count == 0) return !final && avail < max_rtu_adu ? need_more() : Match{};
  const bool unexpected = unexpected_sender(at, fit.response);
  bool open = false;
  Match alone;  // a public function's first plausible end nothing confirmed
  for (bool allow_glitch : {false, true}) {
    for (size_t i = 0; i < hit_count; ++i) {
      const uint16_t n = hits[i];
      const bool zero_appended = i > 0 && hits[i - 1] == n - 1;
      const Margin shorter = zero_appended ? shorter_end(at, at + n, final, search - 1) : Margin{};
      if (glitch_appended(at, at + n, shorter)) {
        open |= at + n == s_.end;
        continue;
      }
      // Whether it swallows a frame is the costly question: asked only where it decides.
      const std::optional<SpanEnd> confirmed =
          confirmed_end(at, at + n, final, search - 1, allow_glitch);
      const bool at_end = at + n == s_.end;
      // Of two ends a byte apart, the longer stands where the shorter's 0x00 is ruled out as a
      // glitch.
      const bool may_stand_alone =
          public_header && (!alone.length || (alone.length == n - 1u && shorter.decided()));
      if (!confirmed && !at_end && !may_stand_alone) continue;
      // A hit does not wait for a frame inside still to come (final): the search's end waits.
      if (swallows_known_frame(at, at + n, true, unexpected, true).held().has(Feature::another_crc))
        continue;
      // Confirmed only by taking the next 0x00 for a glitch, where one byte more holds too; or
      // ending in a 0x00 that could be a glitch after a good frame one byte shorter.
      Margin doubt = allow_glitch ? longer_end(at, at + n) : Margin{};
      if (!doubt.stands()) consider(doubt, shorter);
      if (confirmed) return {Match::Kind::found, n, fit, doubt, *confirmed};
      open |= at_end;
      if (may_stand_alone) alone = {Match::Kind::found, n, fit, shorter, SpanEnd::header_alone};
    }
  }
  // A public function followed by junk: once nothing more can confirm an end (the input's
  // end, or a silence with a good frame after it), its header confirms the first, and one
  // byte more stands beside it where a 0x00 after it makes that good too.
  if (alone.length && (final || (avail >= max_rtu_adu && !open) || blocked_by_gap(at, final))) {
    Margin doubt = longer_end(at, at + alone.length);
    if (!doubt.stands()) consider(doubt, alone.end_margin);
    alone.end_margin = doubt;
    return alone;
  }
  if (!final && (avail < max_rtu_adu || open)) return need_more();
  return {};
}

// Both readings of a start often search the same span (an unknown function code reads as a
// request and as a response alike), so the last answer is kept.
size_t RtuReadings::good_lengths(uint64_t at, size_t first, size_t limit,
                                 std::array<uint16_t, max_rtu_adu>& lengths) {
  CrcHits& last = last_hits_;
  if (last.at != at || last.first != first || last.limit != limit) {
    last.at = at;
    last.first = first;
    last.limit = limit;
    last.count = 0;
    index_span(at, at + limit);
    crc_index_.good_ends(at, at + first, at + limit, [&](uint64_t end) {
      last.lengths[last.count++] = static_cast<uint16_t>(end - at);
    });
  }
  // Copied out: confirming one of them searches further on, which replaces the kept answer.
  std::copy_n(last.lengths.begin(), last.count, lengths.begin());
  return last.count;
}

// A frame with no fixed length is found by running the CRC from its start, stopping at its end
// as soon as something confirms it: few steps for a real frame. Where this finds nothing, the
// bytes are junk, and the CRC index takes over for this start and the ones after it.
RtuReadings::Match RtuReadings::first_confirmed_end(uint64_t at, size_t first, size_t limit,
                                                    RoleFit fit, bool final, int search) {
  const uint8_t* p = at_ptr(at);
  uint16_t crc = crc16({p, first - crc_size});
  bool previous_hit = false;
  for (size_t n = first; n <= limit; ++n) {
    const bool hit = crc == wire_crc({p, n});
    const bool zero_appended = hit && previous_hit;
    previous_hit = hit;
    crc = crc16_step(crc, p[n - crc_size]);
    if (!hit) continue;
    const Margin shorter = zero_appended ? shorter_end(at, at + n, final, search - 1) : Margin{};
    if (glitch_appended(at, at + n, shorter)) continue;
    const std::optional<SpanEnd> confirmed = confirmed_end(at, at + n, final, search - 1, false);
    if (confirmed &&
        !swallows_known_frame(at, at + n, true, unexpected_sender(at, fit.response), true)
             .held()
             .has(Feature::another_crc))
      return {Match::Kind::found, static_cast<uint16_t>(n), fit, shorter, *confirmed};
  }
  return {};
}

// A CRC end right after a CRC end is the shorter frame with a 0x00 appended, the next driver's
// glitch, unless what tells against that reading decides (`shorter`: a silence right after
// the 0x00, a clock per byte that saw it sent straight on, a second glitch it would need), or
// the longer frame's exact copy follows it (FC08's echo) on a bus whose glitches do not make
// the glitch the likelier.
bool RtuReadings::glitch_appended(uint64_t begin, uint64_t end, const Margin& shorter) const {
  if (shorter.runner_up != RunnerUp::shorter || shorter.decided()) return false;
  return s_.glitch_odds.zero_glitch_likelier() || !copy_follows(begin, end);
}

// The runner-up of a good frame's end (framing_evidence.hpp, Margin): the same frame one byte
// longer, the 0x00 after it its own (a CRC that holds keeps holding with a 0x00 appended), or
// one byte shorter, its last 0x00 the next driver's glitch. The longer is told apart by a
// silence before the byte, the shorter by a silence after it, a clock per byte that saw it sent
// straight on, or a second glitch that reading would need at one turnaround.
Margin RtuReadings::longer_end(uint64_t at, uint64_t end) const {
  if (end >= s_.end || end - at >= max_rtu_adu || *at_ptr(end) != 0x00) return {};
  Margin margin{RunnerUp::longer};
  margin.tell(Feature::silence_inside, s_.timeline.gap_at(end));
  return margin;
}

Margin RtuReadings::shorter_end(uint64_t at, uint64_t end, bool final, int search) {
  if (*at_ptr(end - 1) != 0x00) return {};
  Margin margin{RunnerUp::shorter};
  margin.tell(Feature::silence_after, s_.timeline.gap_at(end)) ||
      margin.tell(Feature::sent_straight_on, !s_.timeline.after_quiet_line(end - 1)) ||
      margin.tell(Feature::second_glitch,
                  glitch_then_frame(end, final, search) || glitch_then_kin(at, end));
  return margin;
}

// A turnaround's glitch at `end`, then a frame of the slave and function code of the frame at
// `at` (its answer, cut or talked over though it may be, or the master's next request to it):
// two bytes that begin a frame, as likely by chance as a CRC.
bool RtuReadings::glitch_then_kin(uint64_t at, uint64_t end) const {
  if (end + 3 > s_.end || !is_glitch_byte(*at_ptr(end))) return false;
  const uint8_t* frame = at_ptr(at);
  const uint8_t* next = at_ptr(end + 1);
  return next[0] == frame[0] && (next[1] & 0x7F) == (frame[1] & 0x7F);
}

// Of two runner-ups, the one that stands, else the first there is (--explain names it).
void RtuReadings::consider(Margin& margin, const Margin& other) {
  if (other.stands() || margin.runner_up == RunnerUp::none) margin = other;
}

// A turnaround's glitch at `at` with a good frame right behind it.
bool RtuReadings::glitch_then_frame(uint64_t at, bool final, int search) {
  return at + 1 < s_.end && is_glitch_byte(*at_ptr(at)) &&
         match_at(at + 1, final, search).kind == Match::Kind::found;
}

// The CRC index is kept only over what is searched: traffic whose lengths the function codes
// tell never pays for it, and junk is indexed once, however many starts search it.
void RtuReadings::index_span(uint64_t begin, uint64_t end) {
  if (begin < crc_index_.begin() || begin > crc_index_.end()) crc_index_.restart(begin);
  const uint64_t from = crc_index_.end();
  if (end > from) crc_index_.append({at_ptr(from), static_cast<size_t>(end - from)});
}

bool RtuReadings::fits_role(Role role, uint64_t at, uint16_t length) const {
  const BodyLength body = body_length(role, {at_ptr(at), length});
  if (body.kind == BodyLength::Kind::known) return body.bytes + crc_size == length;
  return body.kind == BodyLength::Kind::variable && body.bytes + crc_size <= length;
}

// Whether a request may start at `start` and its length rules end it at `end`. Asked 1 time in
// 65,536, so kept out of line: the hot paths inline the questions it asks.
[[gnu::cold, gnu::noinline]] bool RtuReadings::request_spans(uint64_t start, uint64_t end) const {
  const uint8_t* p = at_ptr(start);
  return may_start_request(p[0], p[1]) &&
         fits_role(Role::request, start, static_cast<uint16_t>(end - start));
}

// The first confirmation of a searched end that holds (span_end_table: each is a feature that
// makes up for the search's tries alone, so the first is enough), the end of the input where
// it is final, or none.
std::optional<SpanEnd> RtuReadings::confirmed_end(uint64_t begin, uint64_t end, bool final,
                                                  int search, bool allow_glitch) {
  if (end == s_.end) return final ? std::optional(SpanEnd::input_end) : std::nullopt;
  if (s_.timeline.gap_at(end)) return SpanEnd::silence_after;
  if (end > s_.head && s_.timeline.paused_before(end)) return SpanEnd::pause_after;
  if (match_at(end, final, search).kind == Match::Kind::found) return SpanEnd::frame_after;
  if (copy_follows(begin, end)) return SpanEnd::copy_after;
  // A turnaround glitch between this frame and the next still confirms this end; without
  // this, the glitch's 0x00 would be taken into the frame (it keeps the CRC residue zero).
  const uint8_t next = *at_ptr(end);
  if (allow_glitch && is_glitch_byte(next) && end + 1 < s_.end &&
      (s_.timeline.gap_at(end + 1) || match_at(end + 1, final, search).kind == Match::Kind::found))
    return SpanEnd::glitch_then_frame;
  return std::nullopt;
}

// An exact copy right behind is the echo of FC08 Return Query Data; a silence inside it says
// its bytes were not one frame (a glitch after an echo can complete a false copy).
bool RtuReadings::copy_follows(uint64_t begin, uint64_t end, uint64_t copy) const {
  const uint64_t size = end - begin;
  return copy + size <= s_.end && std::equal(at_ptr(begin), at_ptr(end), at_ptr(copy)) &&
         s_.timeline.first_gap_after(copy) >= copy + size;
}

// Whether a frame a bus carries starts inside [begin, end), wherever it ends, and outweighs the
// span (keeps_frame_inside, framing_evidence.hpp): inside a long frame, bytes pass a CRC as a
// vendor code or an unnamed exception now and then. An exact copy after the span outweighs it.
// Unknown while such a frame's bytes are still to come, unless `final`.
RtuReadings::RowFeatures RtuReadings::swallows_known_frame(uint64_t begin, uint64_t end,
                                                           bool searched, bool unexpected,
                                                           bool final) {
  const FeatureWeights& weights = options_.weights;
  if (keeps_frame_inside(searched, unexpected, false, weights)) return {};
  if (keeps_frame_inside(searched, unexpected, true, weights) && copy_follows(begin, end))
    return {};
  bool to_come = false;
  for (uint64_t inner = begin + 1; inner < end; ++inner) {
    if (inner + 3 > s_.end) return {{}, !final};
    if (!standard_frame(inner)) continue;
    const Match::Kind kind = match_at(inner, false, 0).kind;
    if (kind == Match::Kind::found || copied_frame_at(inner))
      return {{Feature::another_crc, Feature::bus_code}};
    to_come |= kind == Match::Kind::need_more && !final;
  }
  return {{}, to_come};
}

// A frame with no length of its own (FC08 Return Query Data) whose CRC holds where its exact
// copy follows, right after it or after the answering driver's glitch: a query and its echo.
// The copy makes up for the search's tries (copy-after).
bool RtuReadings::copied_frame_at(uint64_t at) {
  const BodyLength body = body_length(Role::request, from(at));
  if (body.kind != BodyLength::Kind::variable) return false;
  const size_t first = std::max<size_t>(body.bytes + crc_size, min_adu);
  std::array<uint16_t, max_rtu_adu> hits;
  const size_t count = good_lengths(at, first, std::min<uint64_t>(s_.end - at, max_rtu_adu), hits);
  for (size_t i = 0; i < count; ++i) {
    const uint64_t end = at + hits[i];
    if (copy_follows(at, end) ||
        (end < s_.end && is_glitch_byte(*at_ptr(end)) && copy_follows(at, end, end + 1)))
      return true;
  }
  return false;
}

// Where `broke-off-at-silence` refutes every span across the first silence after `at`, every
// reading of the bytes at `at` ends before it: none waits for bytes beyond it.
bool RtuReadings::blocked_by_gap(uint64_t at, bool final) {
  const uint64_t gap = s_.timeline.first_gap_after(at);
  return gap < s_.end &&
         refutes_alone<Evidence::broke_off_at_silence>(frame_after_silence(gap, final));
}

// Where the awaited response starting at `at` begins, after its driver's glitch if one is there.
std::optional<uint64_t> RtuReadings::awaited_start(uint64_t at) const {
  if (at >= s_.end) return std::nullopt;
  if (awaited_.length(from(at))) return at;
  if (at + 1 < s_.end && is_glitch_byte(*at_ptr(at)) && awaited_.length(from(at + 1)))
    return at + 1;
  return std::nullopt;
}

// Where that response ends by its structure (its bytes may be still to come); 0 where none.
uint64_t RtuReadings::awaited_end(uint64_t at) const {
  const std::optional<uint64_t> start = awaited_start(at);
  return start ? *start + *awaited_.length(from(*start)) : 0;
}

// Whether the frame at `at` has a code a bus carries (`bus-code`): a public function code, and
// for an exception a code the standard names.
bool RtuReadings::standard_frame(uint64_t at) const {
  const uint8_t* p = at_ptr(at);
  const uint8_t fc = p[1];
  if (!(fc & 0x80)) return is_public_function(fc);
  return is_public_function(fc & 0x7F) && !exception_name(p[2]).empty();
}

// Whether `at` is where the bytes after the last frame begin, or a lone glitch after it ends:
// while a request is pending, where its answer begins. Bytes after junk are not.
bool RtuReadings::first_after_request(uint64_t at) const {
  return at == s_.answer_start ||
         (at == s_.answer_start + 1 && s_.answer_start >= s_.head && s_.answer_start < s_.end &&
          is_glitch_byte(*at_ptr(s_.answer_start)));
}

}  // namespace modtap
