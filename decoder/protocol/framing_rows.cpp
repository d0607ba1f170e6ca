// The rows of the RTU readings' evidence table (decoder/protocol/framing_evidence.hpp holds their
// features and bits): what the bytes around a span whose length rules and CRC agree say against
// it being one frame, and the questions of the bus each row asks.
#include <algorithm>
#include <cstring>

#include "decoder/protocol/checksum.hpp"
#include "decoder/protocol/function_codes.hpp"
#include "decoder/protocol/rtu_readings.hpp"  // the rows are the readings': they read the stream

namespace modtap {

// What the bus says against the span [at, at + length) being one frame, where a reading's length
// rules and CRC agree on it: refuted, in either role, once the rows that hold outweigh its CRC
// (framing_evidence.hpp); waiting where a row whose bytes have not come could refute it.
RtuReadings::Verdict RtuReadings::weigh_span(const Reading& r, Evidence& why) {
  return weigh_rows<
      Row{Evidence::good_frame_before_silence, &RtuReadings::good_frame_before_silence},
      Row{Evidence::broke_off_at_silence, &RtuReadings::broke_off_at_silence},
      Row{Evidence::answer_read_as_request, &RtuReadings::answer_read_as_request},
      Row{Evidence::request_inside_awaited_answer, &RtuReadings::request_inside_awaited_answer},
      Row{Evidence::unawaited_answer_inside_awaited_answer,
          &RtuReadings::unawaited_answer_inside_awaited_answer},
      Row{Evidence::predicted_inside_awaited_answer, &RtuReadings::predicted_inside_awaited_answer},
      Row{Evidence::retry_and_glitch, &RtuReadings::retry_and_glitch},
      Row{Evidence::retry_read_as_answer, &RtuReadings::retry_read_as_answer},
      Row{Evidence::answer_copying_request, &RtuReadings::answer_copying_request},
      Row{Evidence::answer_cut_before_request, &RtuReadings::answer_cut_before_request},
      Row{Evidence::swallows_known_frame, &RtuReadings::swallows_known_frame_reading},
      Row{Evidence::swallows_exchange, &RtuReadings::swallows_exchange_reading},
      Row{Evidence::resent_inside, &RtuReadings::resent_inside},
      Row{Evidence::swallows_request, &RtuReadings::swallows_request_reading}>(r, why);
}

// What the bus says against every span from `at`, whatever its end: a row that outweighs the
// most a CRC could say, so no end is sought.
std::optional<Evidence> RtuReadings::weigh_start(uint64_t at) {
  static_assert(row_bits<Evidence::vendor_frame_inside_awaited_answer> > span_bits);
  constexpr Evidence row = Evidence::vendor_frame_inside_awaited_answer;
  if (refutes_alone<row>(vendor_frame_inside_awaited_answer(at))) return row;
  return std::nullopt;
}

// Inside the span the awaited answer's structure claims, a collision's junk passes a CRC 1
// start in 65,536, most often as a vendor code or an unnamed exception, whose end only a CRC
// search 256 bytes on could tell. An exception's code not yet come may still be a standard one.
RtuReadings::RowFeatures RtuReadings::vendor_frame_inside_awaited_answer(uint64_t at) {
  FeatureSet held;
  if (at + 3 <= s_.end && held.add(Feature::awaited_header, inside_awaited_span(at)))
    held.add(Feature::vendor_code, !standard_frame(at));
  return {held};
}

RtuReadings::RowWeights::RowWeights(const FeatureWeights& weights) : span(weights.span()) {
  for (size_t i = 0; i < rows.size(); ++i)
    rows[i] = static_cast<int16_t>(weights.of(evidence_table[i]));
}

// The rows unrolled at compile time: weighing runs once a frame. Each row finds the features of
// its reading; where all it needs hold, its weight comes off the span's score. Below nothing
// the span is refuted, and the rows after need not be weighed: they only take off.
template <RtuReadings::Row... rows>
RtuReadings::Verdict RtuReadings::weigh_rows(const Reading& r, Evidence& why) {
  Weight weight(row_weights_);
  if ((weight.refuted<rows.evidence>((this->*rows.finds)(r)) || ...)) {
    why = *weight.refuting;
    return Verdict::refuted;
  }
  why = weight.unknown.value_or(Evidence::length_and_crc);
  return weight.unknown ? Verdict::wait : Verdict::keep;
}

// A frame ends before a silence inside the reading, and what came after it kept the CRC good (a
// trailing 0x00 keeps a zero residue zero): the other reading, if any, is the frame.
RtuReadings::RowFeatures RtuReadings::good_frame_before_silence(const Reading& r) {
  const uint64_t gap = s_.timeline.first_gap_after(r.at);
  FeatureSet held;
  if (held.add(Feature::silence_inside, gap < r.at + r.length))
    held.add(Feature::another_crc, gap - r.at >= min_adu && rtu_crc_holds(bytes(r.at, gap)));
  return {held};
}

// A silence inside a frame, with a good frame starting right after it (or after the glitch of
// the driver that sends it), means this was a frame that broke off, whatever its CRC says.
RtuReadings::RowFeatures RtuReadings::broke_off_at_silence(const Reading& r) {
  const uint64_t gap = s_.timeline.first_gap_after(r.at);
  if (gap >= r.at + r.length) return {};
  return frame_after_silence(gap, r.final);
}

// What the bytes after the silence at `gap` say of a span across it: that it broke off there,
// where a good frame starts right after the silence or after its driver's glitch.
RtuReadings::RowFeatures RtuReadings::frame_after_silence(uint64_t gap, bool final) {
  FeatureSet held{Feature::silence_inside};
  const Match after = match_at(gap, final, 0);
  if (held.add(Feature::another_crc,
               after.kind == Match::Kind::found || glitch_then_frame(gap, final, 0)))
    return {held};
  return {held, after.kind == Match::Kind::need_more && !final};
}

// The first bytes after the request, too soon for the master's next one, read as a request:
// beginning as the awaited answer, every byte its request predicts in place, as a request the
// standard does not allow, a talked-over answer whose junk passed a CRC; a glitch and the
// awaited answer's slave and function code, that answer after its driver's glitch, whatever
// request they read as. A request the standard allows may be the master's (a short time-out).
RtuReadings::RowFeatures RtuReadings::answer_read_as_request(const Reading& r) {
  FeatureSet held;
  if (r.role != Role::request || !first_after_request(r.at) ||
      !held.add(Feature::too_soon_for_retry, too_soon_for_retry(r.at)) ||
      awaited_.copies_request(from(r.at), r.length))
    return {held};
  const uint8_t* p = at_ptr(r.at);
  const bool junk_as_request =
      r.other && awaited_.begins(from(r.at)) &&
      request_spec_findings({p + 1, static_cast<size_t>(r.length - 1 - crc_size)}) != 0;
  held.add(Feature::awaited_header, junk_as_request || glitch_then_awaited(r.at));
  return {held};
}

// A request inside the span the awaited answer's structure claims is a collision's junk that
// passed a CRC unless its own answer follows it (after a cut answer, the master's next request
// and its answer). A silence after it may be its slave's; with no clock, where the master's
// time-out after a silent slave cannot show, no rule.
RtuReadings::RowFeatures RtuReadings::request_inside_awaited_answer(const Reading& r) {
  FeatureSet held;
  if (r.role != Role::request || *at_ptr(r.at) == 0 || options_.clock == ClockQuality::none ||
      !held.add(Feature::awaited_header, inside_awaited_span(r.at)))
    return {held};
  const auto answered = answer_follows(r.at, r.at + r.length, r.final);
  if (!answered) return to_come(held);
  held.add(Feature::no_answer_after, !*answered);
  return {held};
}

// An answer nobody awaits inside the span the awaited answer's structure claims is a
// collision's junk that passed a CRC, unless its own request comes right before it (after a cut
// answer, the master's next request and its answer). So is a reading, in either role, that
// starts at the answering driver's glitch and runs over that answer (a 0xFF read as station 255).
RtuReadings::RowFeatures RtuReadings::unawaited_answer_inside_awaited_answer(const Reading& r) {
  const bool answer = r.role == Role::response;
  FeatureSet held;
  if (held.add(Feature::awaited_header,
               (answer && inside_awaited_span(r.at)) || glitch_then_awaited(r.at)))
    held.add(Feature::unexpected_sender,
             unexpected_sender(r.at, answer) && !request_right_before(r.at, r.final));
  return {held};
}

// Whether a request of the slave and function of the answer at `at`, inside the awaited span,
// ends right before it or before its driver's glitch.
bool RtuReadings::request_right_before(uint64_t at, bool final) {
  const uint8_t* p = at_ptr(at);
  for (uint64_t start = s_.head + 1; start + min_adu <= at; ++start) {
    if (*at_ptr(start) != p[0] || at_ptr(start)[1] != (p[1] & 0x7F)) continue;
    const Match request = match_at(start, final, 0);
    const uint64_t end = start + request.length;
    if (request.kind == Match::Kind::found && request.fit.request &&
        (end == at || (end + 1 == at && is_glitch_byte(*at_ptr(end)))))
      return true;
  }
  return false;
}

// Inside the span the awaited answer claims, a span whose every byte, its CRC's too, is the one
// the request tells the answer has there (an echo's) holds its CRC because the request does.
// One that runs on past that span is not explained so.
RtuReadings::RowFeatures RtuReadings::predicted_inside_awaited_answer(const Reading& r) {
  const std::optional<uint64_t> answer = r.at > s_.head ? awaited_start(s_.head) : std::nullopt;
  const uint64_t end = r.at + r.length;
  FeatureSet held;
  if (held.add(Feature::awaited_header,
               answer && r.at > *answer && end <= *answer + *awaited_.length(from(*answer))))
    held.add(Feature::predicted_bytes,
             awaited_.tells_every_byte(bytes(*answer, end), r.at - *answer));
  return {held};
}

// A copy of the pending request and a glitch read as a response of one more byte (FC07's): on a
// bus of glitches the copy is the likelier (a master's retry), unless too soon for a retry.
RtuReadings::RowFeatures RtuReadings::retry_and_glitch(const Reading& r) {
  FeatureSet held;
  if (r.other && *r.other == Role::request && at_ptr(r.at)[r.length - 1] == 0x00 &&
      held.add(Feature::glitch_odds, s_.glitch_odds.zero_glitch_likelier()) &&
      s_.timeline.after_quiet_line(r.at + r.length - 1))
    held.add(Feature::another_crc,
             awaited_.copies_request(from(r.at), r.length - 1) && !too_soon_for_retry(r.at));
  return {held};
}

// The pending request again (a retry) starts a response that ends elsewhere: shorter where the
// copy's CRC ends in 0x00s (they keep a CRC good), longer where a byte count runs on and its
// CRC holds by chance, not where the answer begins so by a chance its structure often meets
// (FC07's, whose status is the copy's CRC low byte). The copy is the reading, once its bytes
// are there to say so.
RtuReadings::RowFeatures RtuReadings::retry_read_as_answer(const Reading& r) {
  const size_t copy = awaited_.request_size();
  if (!r.other || *r.other != Role::request || copy == r.length ||
      !awaited_.repeats_request(bytes(r.at, r.at + std::min<size_t>(copy, r.length))) ||
      (copy < r.length && awaited_.may_begin_with_copy(bytes(r.at, r.at + copy), r.length)))
    return {};
  if (r.at + copy > s_.end) return {{}, !r.final};
  FeatureSet held;
  if (!held.add(Feature::another_crc, awaited_.copies_request(from(r.at), copy)) ||
      too_soon_for_retry(r.at))
    return {held};
  // A longer answer that begins as its request: the copy read apart leaves the rest to junk
  // (`leaves-junk`, as much against the copy as `request-again` is for it), and the answer,
  // whose CRC holds, stands.
  const std::optional<bool> junk = copy > r.length ? false : leaves_junk(r.at + copy, r.final);
  if (!junk) return to_come(held);
  held.add(Feature::request_again, !*junk);
  return {held};
}

// Whether the bytes from `next` on are junk: no frame starts there, nor the awaited answer
// (talked over or cut), after its driver's glitch or not, and no silence comes before them.
// Nothing while the bytes that tell are still to come.
std::optional<bool> RtuReadings::leaves_junk(uint64_t next, bool final) {
  const uint64_t answer = next + (is_glitch_byte(*at_ptr(next)) ? 1 : 0);
  if (answer + 2 > s_.end) return final ? std::optional(false) : std::nullopt;
  const Match after = match_at(next, final, 0);
  if (after.kind == Match::Kind::need_more && !final) return std::nullopt;
  return after.kind != Match::Kind::found && !s_.timeline.gap_at(next) &&
         !glitch_then_frame(next, final, 0) && !awaited_.has_header(from(answer));
}

// A copy of the pending request too soon for a retry, where the awaited answer is longer, is
// that answer damaged, right where the answer begins if it may begin so (FC07's whose status is
// the request's CRC low byte). After a damaged answer a master may repeat its request as soon:
// there only bytes no frame explains after the copy make it the answer, unless they begin as the
// answer to it would, after its driver's glitch or not (its own answer talked over).
RtuReadings::RowFeatures RtuReadings::answer_copying_request(const Reading& r) {
  FeatureSet held;
  if (!r.other || *r.other != Role::response || !awaited_.copies_request(from(r.at), r.length) ||
      !held.add(Feature::too_soon_for_retry, too_soon_for_retry(r.at)))
    return {held};
  const auto awaited = awaited_.length(from(r.at));
  if (!awaited || *awaited <= r.length) return {held};
  const std::optional<bool> begun = copy_begins_answer(r, *awaited);
  if (!begun) return to_come(held);
  held.add(Feature::awaited_header, *begun);
  return {held};
}

// Whether the copy of the pending request read as `r` begins the awaited answer, `awaited`
// bytes long: right where that answer begins, if it may begin so, or with bytes no frame
// explains after it, which do not begin as the answer to the copy would. Nothing while what
// follows is still to come.
std::optional<bool> RtuReadings::copy_begins_answer(const Reading& r, size_t awaited) {
  const uint64_t end = r.at + r.length;
  if (first_after_request(r.at) && awaited_.may_begin_with_copy(bytes(r.at, end), awaited))
    return true;
  if (end == s_.end) return r.final ? std::optional(false) : std::nullopt;
  if (s_.timeline.gap_at(end)) return false;
  const Match next = match_at(end, r.final, 0);
  const uint64_t answer = end + (is_glitch_byte(*at_ptr(end)) ? 1 : 0);
  if ((next.kind == Match::Kind::need_more || answer + 3 > s_.end) && !r.final) return std::nullopt;
  return next.kind == Match::Kind::none && !glitch_then_frame(end, r.final, 0) &&
         !awaited_.starts(from(answer));
}

// The awaited response cut one or two bytes short, whose missing CRC the next request's first
// bytes repeat, reads whole and good, the rest of the request as junk. Only on a bus channel (on
// a split tap the request is on the other), and for a reading that may search on (not nested
// in another's judgement, nor a CRC search at its depth), so that it never nests.
RtuReadings::RowFeatures RtuReadings::answer_cut_before_request(const Reading& r) {
  const uint8_t* p = at_ptr(r.at);
  if (r.role != Role::response || options_.role != ChannelRole::bus || r.search <= 0 ||
      !expected_.pending || expected_.slave != p[0] || expected_.function != (p[1] & 0x7F))
    return {};
  const auto cut = cut_before_frame(r.at, r.length, r.final, r.search);
  if (!cut) return to_come();
  if (!*cut) return {};
  return {{Feature::another_crc, Feature::leaves_junk}};
}

// A reserved address is as often a turnaround's 0xFF, and an answer nobody awaits (another
// slave's or function's while a request waits) a collision's junk that passed a CRC: such a
// frame gives way to one a bus carries inside it. A frame from an expected sender keeps it.
RtuReadings::RowFeatures RtuReadings::swallows_known_frame_reading(const Reading& r) {
  FeatureSet held;
  if (!held.add(Feature::unexpected_sender, unexpected_sender(r.at, r.role == Role::response)))
    return {held};
  return swallows_known_frame(r.at, r.at + r.length, false, true, r.final)
      .with(Feature::unexpected_sender);
}

// A reserved address, or an answer while a request of another slave or function waits.
bool RtuReadings::unexpected_sender(uint64_t at, bool answer) const {
  const uint8_t* p = at_ptr(at);
  return p[0] > max_unicast_slave ||
         (answer && expected_.pending &&
          (expected_.slave != p[0] || expected_.function != (p[1] & 0x7F)));
}

// A turnaround's glitch where the answer is due, then the awaited answer's slave and function
// code: the answering driver turned on, whatever the answer's bytes after its header turn out.
bool RtuReadings::glitch_then_awaited(uint64_t at) const {
  return first_after_request(at) && is_glitch_byte(*at_ptr(at)) &&
         awaited_.has_header(from(at + 1));
}

// Nor does any frame whose CRC holds by chance across a whole exchange: junk after it, and
// inside it a request with its own answer's first bytes after it.
RtuReadings::RowFeatures RtuReadings::swallows_exchange_reading(const Reading& r) {
  return r.search > 0 ? swallows_exchange(r.at, r.at + r.length, r.final) : RowFeatures{};
}

// A span whose CRC holds across a frame cut short and a whole request after it: the cut
// frame's bytes took the CRC back to its start value (the tail of a good span is good exactly
// where the CRC of the bytes before it is the register's start value), 1 time in 65,536, and
// the request's bytes did the rest. A frame of the request's slave and function code next (its
// answer, or the master's retry after a silence), after a glitch or not, says the request was
// sent. Only the awaited answer is weighed so, as a cut answer is what the master's next
// request follows; nothing while the bytes after it are still to come, unless no more can.
RtuReadings::RowFeatures RtuReadings::swallows_request_reading(const Reading& r) {
  const uint8_t* p = at_ptr(r.at);
  if (r.role != Role::response || options_.role != ChannelRole::bus || r.search <= 0 ||
      !expected_.pending || expected_.slave != p[0] || expected_.function != (p[1] & 0x7F))
    return {};
  // No frame of a request's kin starts with a glitch's byte: no slave answers to 0 or 255, and
  // a master does not repeat a broadcast.
  const uint64_t end = r.at + r.length;
  const uint64_t next = end + (end < s_.end && is_glitch_byte(*at_ptr(end)) ? 1 : 0);
  if (next + 2 > s_.end) return {{}, !r.final && request_ending(r.at, end)};
  if (!request_before_kin(r.at, end, next)) return {};
  return {{Feature::another_crc, Feature::answer_after}};
}

// A request that broke off and was sent again at once, read as one span (a master sends again;
// a slave answers once): where the span's own slave and function code start again inside it, as
// a request whose length rules and CRC agree and that runs past the span's end, and the span's
// bytes before it are that request's first bytes, the span's CRC held by chance (1 in 65,536, or
// 1 cut in 256 where the missing last CRC byte is the slave address the request sent again
// begins with). A clock that sees the pause before the request sent again refutes the span by
// that silence alone.
RtuReadings::RowFeatures RtuReadings::resent_inside(const Reading& r) {
  if (r.role != Role::request) return {};
  const uint64_t end = r.at + r.length;
  const bool open = end == s_.end;  // what follows is still to come
  if ((open && r.final) || (!open && s_.timeline.gap_at(end))) return {};
  const uint8_t* first = at_ptr(r.at);
  // A header may start at the span's last byte, once the byte after it has come.
  if (open && *at_ptr(end - 1) == first[0]) return to_come();
  const uint8_t* stop = at_ptr(open ? end - 1 : end);
  for (const uint8_t* p = first + 1; p < stop; ++p) {
    p = static_cast<const uint8_t*>(std::memchr(p, first[0], static_cast<size_t>(stop - p)));
    if (!p) break;
    if (p[1] != first[1]) continue;
    const uint64_t start = r.at + static_cast<uint64_t>(p - first);
    const Match again = match_at(start, r.final, 0);
    if (again.kind == Match::Kind::need_more && !r.final) return to_come();
    const uint64_t broken_off = start - r.at;
    if (again.kind == Match::Kind::found && again.fit.request && start + again.length > end &&
        again.length > broken_off && std::equal(first, p, p))
      return {{Feature::another_crc, Feature::broken_off_copy}};
  }
  return {};
}

// A request's length where its function code alone tells it, else 0: the function codes' own
// length rules, asked once of a header alone and kept, as this is asked of every answer.
uint16_t RtuReadings::request_length_of_code(uint8_t function) {
  static const std::array<uint16_t, 128> lengths = [] {
    std::array<uint16_t, 128> table{};
    for (uint8_t code = 1; code < table.size(); ++code) {
      const uint8_t header[] = {1, code};
      const BodyLength body = body_length(Role::request, header);
      if (body.kind == BodyLength::Kind::known) table[code] = body.bytes + crc_size;
    }
    return table;
  }();
  return lengths[function & 0x7F];
}

// Whether a request ends at `end` inside the good span [begin, end) whose slave and function
// code the frame at `next` begins with. Where the code alone tells the request's length, it
// can start at one place only; else its header is looked for, a byte at a time.
bool RtuReadings::request_before_kin(uint64_t begin, uint64_t end, uint64_t next) const {
  const uint8_t header[] = {*at_ptr(next), static_cast<uint8_t>(*at_ptr(next + 1) & 0x7F)};
  if (const uint16_t length = request_length_of_code(header[1])) {
    const uint64_t start = end - length;
    return end - begin > length && std::equal(header, header + 2, at_ptr(start)) &&
           crc16(bytes(begin, start)) == 0xFFFF && request_spans(start, end);
  }
  const uint8_t* first = at_ptr(begin);
  const uint8_t* last = at_ptr(end - min_adu);
  for (const uint8_t* p = first + 1; p <= last; ++p) {
    p = static_cast<const uint8_t*>(std::memchr(p, header[0], static_cast<size_t>(last + 1 - p)));
    if (!p) return false;
    if (p[1] == header[1] && crc16({first, p}) == 0xFFFF &&
        request_spans(begin + static_cast<uint64_t>(p - first), end))
      return true;
  }
  return false;
}

// Where a request whose length rules and CRC agree ends at `end` inside the good span
// [begin, end), if one does: where the CRC of the bytes before it is back at its start value.
std::optional<uint64_t> RtuReadings::request_ending(uint64_t begin, uint64_t end) const {
  const std::span<const uint8_t> heads = bytes(begin, end - min_adu);
  for (size_t k = 1; (k = crc16_back_to_start(heads, k)) != 0; ++k)
    if (request_spans(begin + k, end)) return begin + k;
  return std::nullopt;
}

// Whether what follows the request [at, end), after a glitch if one comes, may be its answer:
// its slave and function code (an exception's too), a silence, or the end of the input.
// Nothing while the bytes that tell are still to come.
std::optional<bool> RtuReadings::answer_follows(uint64_t at, uint64_t end, bool final) const {
  const uint64_t answer = end + (end < s_.end && is_glitch_byte(*at_ptr(end)) ? 1 : 0);
  if (answer + 2 > s_.end) return final ? std::optional(true) : std::nullopt;
  if (s_.timeline.gap_at(end) || s_.timeline.gap_at(answer)) return true;
  const uint8_t* request = at_ptr(at);
  const uint8_t* p = at_ptr(answer);
  return p[0] == request[0] && (p[1] & 0x7F) == request[1];
}

// Whether junk follows [begin, end) and a request starts inside it with a frame of its slave
// and function code (its answer) right after it, or after a glitch. Junk first, and a public
// function code right after (or after a glitch) is taken to begin a frame without looking
// further: a frame follows almost every frame, and the search inside is rare. Unknown while such
// a request's answer has yet to come, so that where a read ends does not decide.
RtuReadings::RowFeatures RtuReadings::swallows_exchange(uint64_t begin, uint64_t end, bool final) {
  if (end + 3 > s_.end) return {};
  const uint8_t* after = at_ptr(end);
  if (is_public_function(after[1] & 0x7F) ||
      (is_glitch_byte(after[0]) && is_public_function(after[2] & 0x7F)) ||
      s_.timeline.gap_at(end) || match_at(end, final, 0).kind != Match::Kind::none ||
      glitch_then_frame(end, final, 0))
    return {};
  const FeatureSet held{Feature::leaves_junk};
  bool to_come = false;
  for (uint64_t inner = begin + 1; inner < end && inner + 3 <= s_.end; ++inner) {
    if (!standard_frame(inner)) continue;
    const Match request = match_at(inner, final, 0);
    if (request.kind != Match::Kind::found || !request.fit.request) continue;
    const uint64_t after = inner + request.length;
    const bool glitch = after < s_.end && is_glitch_byte(*at_ptr(after));
    for (uint64_t answer = after; answer <= after + (glitch ? 1 : 0); ++answer) {
      if (answer + 2 > s_.end) {
        to_come |= !final;  // the answer's first bytes are still to come
        continue;
      }
      if (std::equal(at_ptr(inner), at_ptr(inner + 2), at_ptr(answer)) &&
          match_at(answer, final, 0).kind != Match::Kind::none)
        return {{Feature::leaves_junk, Feature::another_crc, Feature::answer_after}};
    }
  }
  return {held, to_come};
}

// Whether the response [at, at + length) is one cut short with the next request right behind
// it: nothing starts after it (not even after a glitch), and a whole request starts inside it
// and runs past its end (its first bytes, most often, repeat the missing CRC); nothing while
// what follows is to come. With no bytes after it, it waits only where its last byte came in a
// read of its own and bytes before it in a read of several (a pcapng packet's first byte is
// read apart, to time it; a glitch's packet may come between), or where the read of its first
// byte began before it (a timer's reads end anywhere): waiting at every read's end would hold
// every frame back.
std::optional<bool> RtuReadings::cut_before_frame(uint64_t at, uint16_t length, bool final,
                                                  int search) {
  const uint64_t end = at + length;
  if (end == s_.end) {
    if (final || options_.clock != ClockQuality::per_chunk || s_.timeline.empty()) return false;
    if (s_.timeline.read_starts_inside(at)) return std::nullopt;
    if (s_.timeline.last().first != end - 1 || !s_.timeline.reads_several(at, end - 1))
      return false;
    return std::nullopt;
  }
  const bool glitch = is_glitch_byte(*at_ptr(end));
  if (s_.timeline.gap_at(end) || checks_at(end) || (glitch && checks_at(end + 1))) return false;
  const Match after = match_at(end, final, 0);
  if (after.kind == Match::Kind::found || glitch_then_frame(end, final, 0)) return false;
  // While what follows is still to come, only a request in the CRC bytes is looked for (their
  // repeat is 1 cut in 256), and waits for it; any other once junk follows.
  const bool open = after.kind == Match::Kind::need_more && !final;
  const std::optional<bool> across =
      request_across(open ? end - crc_size : at + 1, end, final, search);
  if (open && across != false) return std::nullopt;
  return across;
}

// Whether a frame whose length rules and CRC agree, in either role, starts at `at`: what most
// often follows a frame, told before anything costlier is asked.
bool RtuReadings::checks_at(uint64_t at) const {
  for (const Role role : {Role::request, Role::response}) {
    const BodyLength body = body_length(role, bytes(at, s_.end));
    const uint64_t end = at + body.bytes + crc_size;
    if (body.kind == BodyLength::Kind::known && end <= s_.end && rtu_crc_holds(bytes(at, end)))
      return true;
  }
  return false;
}

// Whether a request starts in [first, end) and runs past `end`; nothing while one may. Only a
// public function code starts one, and not where its header says it ends before `end`.
std::optional<bool> RtuReadings::request_across(uint64_t first, uint64_t end, bool final,
                                                int search) {
  bool open = false;
  for (uint64_t start = first; start < end; ++start) {
    const uint8_t fc = *at_ptr(start + 1);
    if ((fc & 0x80) || !is_public_function(fc)) continue;
    const BodyLength body = body_length(Role::request, bytes(start, s_.end));
    const uint64_t known_end = start + body.bytes + crc_size;
    if (body.kind == BodyLength::Kind::invalid ||
        (body.kind == BodyLength::Kind::known &&
         (known_end <= end || (known_end <= s_.end && !rtu_crc_holds(bytes(start, known_end))))))
      continue;
    const Match request = match_at(start, final, search - 1);
    if (request.kind == Match::Kind::found && request.fit.request && start + request.length > end)
      return true;
    open |= request.kind == Match::Kind::need_more && !final;
  }
  return open ? std::nullopt : std::optional<bool>(false);
}

}  // namespace modtap
