#include "decoder/protocol/rtu_framer.hpp"

#include <algorithm>
#include <array>

#include "decoder/protocol/checksum.hpp"
#include "decoder/protocol/function_codes.hpp"

namespace modtap {
namespace {

// Compact the buffer once this much has been consumed, so memmove stays rare.
constexpr size_t compact_after = 1 << 16;

}  // namespace

RtuFramer::RtuFramer(uint16_t channel, const RtuFramerOptions& options, FrameSink& sink)
    : channel_(channel),
      options_(options),
      sink_(sink),
      s_(options_),
      readings_(channel, options_, sink.expectation(), s_) {
  s_.buf.reserve(compact_after + 4096);
}

void RtuFramer::push(const Chunk& chunk) {
  if (chunk.bytes.empty()) return;
  s_.timeline.add(chunk.bytes.size(), chunk.t_ns, chunk.continues_read);
  s_.buf.insert(s_.buf.end(), chunk.bytes.begin(), chunk.bytes.end());
  s_.end += chunk.bytes.size();
  if (!chunk.read_goes_on) resolve(false);
}

void RtuFramer::flush(int64_t now_ns) {
  if (s_.head < s_.end && options_.clock != ClockQuality::none &&
      s_.timeline.boundary_silence_at(now_ns))
    resolve(true);
}

int64_t RtuFramer::held_since_ns() const {
  return s_.head < s_.end ? s_.timeline.start_time(s_.head) : INT64_MAX;
}

void RtuFramer::finish() {
  resolve(true);
}

void RtuFramer::resolve(bool final) {
  while (s_.head < s_.end) {
    readings_.new_step();
    const Match m = readings_.match_start(s_.head, final);
    if (m.kind == Match::Kind::found) {
      emit_frame(s_.head, m);
      continue;
    }
    if (m.kind == Match::Kind::need_more && !final && !readings_.blocked_by_gap(s_.head, final))
      return;
    bool decided = false;
    const uint64_t next = next_start(s_.head + 1, final, decided);
    if (!decided && next - s_.head <= max_rtu_adu) return;  // may still be one (bad) frame
    emit_unframed(s_.head, next);
  }
}

uint64_t RtuFramer::next_start(uint64_t from, bool final, bool& decided) {
  uint64_t at = std::max(from, scanned_to_);
  for (; at < s_.end; ++at) {
    const Match m = readings_.match_start(at, final);
    if (m.kind == Match::Kind::found) break;
    if (m.kind == Match::Kind::need_more && !final && !readings_.blocked_by_gap(at, final)) {
      scanned_to_ = at;
      decided = false;
      return at;
    }
  }
  scanned_to_ = at;
  decided = true;
  return at;
}

// The bytes [begin, end) as a frame with its place and time; the check is the caller's to judge.
Frame RtuFramer::frame_of(uint64_t begin, uint64_t end, RoleFit fit) const {
  Frame frame;
  frame.channel = channel_;
  frame.mode = Mode::rtu;
  frame.fit = fit;
  frame.offset = begin;
  frame.raw = frame.adu = {at_ptr(begin), static_cast<size_t>(end - begin)};
  const ByteTimeline::SpanTimes times = s_.timeline.span_times(begin, end);
  frame.t_ns = times.start_ns;
  frame.end_ns = times.end_ns;
  frame.untimed_start = times.untimed_start;
  frame.start_read = times.start_read;
  frame.end_read = times.end_read;
  if (s_.timeline.paused_inside(begin, end)) frame.findings = finding_gap_in_frame;
  return frame;
}

void RtuFramer::emit_frame(uint64_t at, const Match& match) {
  s_.glitch_odds.frame();
  Frame frame = frame_of(at, at + match.length, match.fit);
  frame.check_ok = true;
  frame.expected_check = wire_crc(frame.adu);
  if (match.end_margin.stands()) frame.findings |= finding_ambiguous_end;
  sink_.on_frame(frame);
  s_.answer_start = at + match.length;
  consume(at + match.length);
}

// Bytes that start no good frame, up to the next one: cut at every gap mark, then each piece
// is a frame with a bad CRC when its header says exactly its length, else noise.
void RtuFramer::emit_unframed(uint64_t begin, uint64_t end) {
  while (begin < end) {
    const uint64_t gap = std::min(s_.timeline.first_gap_after(begin), end);
    emit_piece(begin, gap);
    begin = gap;
  }
}

// A damaged response: a frame with a bad check, so it stays in the slave's picture. Cut short,
// it has no check to expect; run on, it ends where its structure says, and is not damaged where
// its CRC holds over that length (an unnamed exception code and a glitch after it).
void RtuFramer::emit_damaged(uint64_t begin, uint64_t end, Damage damage, uint32_t findings) {
  Frame frame = frame_of(begin, end, {false, true});
  if (damage != Damage::cut)
    frame.expected_check = crc16(frame.adu.first(frame.adu.size() - crc_size));
  frame.check_ok = damage != Damage::cut && frame.expected_check == wire_crc(frame.adu);
  frame.findings |= findings;
  if (!frame.check_ok) {
    frame.damage = damage;
    frame.findings |= finding_bad_check;
  }
  sink_.on_frame(frame);
  s_.answer_start = end;
  consume(end);
}

void RtuFramer::emit_piece(uint64_t begin, uint64_t end, uint32_t findings, bool glitch_after) {
  const uint64_t size = end - begin;
  const uint8_t* p = at_ptr(begin);
  if (const std::optional<EdgeByte> first = first_edge(begin, end); first && first->glitch()) {
    emit_piece(begin, begin + 1);
    return emit_piece(begin + 1, end, findings);
  }
  if (const std::optional<EdgeByte> last = last_edge(begin, end, glitch_after)) {
    if (last->margin().stands()) findings |= finding_ambiguous_end;
    if (last->glitch()) {
      emit_piece(begin, end - 1, findings, true);
      return emit_piece(end - 1, end);
    }
  }
  const auto length = readings_.awaited().length(bytes(begin, end));
  if (length && *length != size) {
    if (size < *length) return emit_damaged(begin, end, Damage::cut, findings);
    emit_damaged(begin, begin + *length, Damage::collision, findings);
    return emit_run_on(begin + *length, end);
  }
  if (size >= min_adu && size <= max_rtu_adu && RtuReadings::may_start(p[1])) {
    RoleFit fit{
        options_.role != ChannelRole::slave && readings_.fits_role(Role::request, begin, size),
        options_.role != ChannelRole::master && readings_.fits_role(Role::response, begin, size)};
    if ((fit.request || fit.response) && !piece_header(begin).noise()) {
      Frame frame = frame_of(begin, end, fit);
      frame.expected_check = crc16({p, static_cast<size_t>(size - crc_size)});
      frame.check_ok = frame.expected_check == wire_crc(frame.adu);
      if (!frame.check_ok) {
        frame.findings |= finding_bad_check | findings;
        frame.damage = Damage::corrupted;
      }
      sink_.on_frame(frame);
      s_.answer_start = end;
      consume(end);
      return;
    }
  }
  NoiseReason reason = NoiseReason::junk;
  if (size == 1 && is_glitch_byte(p[0])) {
    reason = NoiseReason::glitch;
    s_.glitch_odds.glitch(p[0]);
  } else if (size >= 2 && is_public_function(p[1])) {
    reason = NoiseReason::truncated;
  }
  // Long runs of junk leave as several records so each stays printable and memory stays flat.
  for (uint64_t at = begin; at < end; at += max_rtu_adu)
    emit_noise(at, std::min<uint64_t>(end, at + max_rtu_adu), reason);
}

// What ran on past a collided answer's structure, before a silence or a good frame: the other
// talker's bytes, however they begin, so never a frame of their own (a request to a slave the
// bus never had). A lone byte there is weighed as any, a glitch or junk.
void RtuFramer::emit_run_on(uint64_t begin, uint64_t end) {
  if (end - begin == 1) return emit_piece(begin, end);
  for (uint64_t at = begin; at < end; at += max_rtu_adu)
    emit_noise(at, std::min<uint64_t>(end, at + max_rtu_adu), NoiseReason::junk);
}

// The header of a piece that may be a damaged frame: a frame's, or noise's (PieceHeader). A
// piece whose check fails has neither a CRC nor, with a vendor's code, a length to say it is a
// frame: only its header does.
PieceHeader RtuFramer::piece_header(uint64_t at) const {
  const uint8_t* p = at_ptr(at);
  const PieceHeader header{at, readings_.standard_frame(at), p[0] > max_unicast_slave};
  if (options_.observer && header.noise_features)
    options_.observer->on_piece_header(channel_, header);
  return header;
}

// The first byte of a piece, a 0x00 or 0xFF, where the bytes after it begin as the awaited
// answer: the answering driver's glitch, or the piece's own (EdgeByte). Elsewhere the byte and
// what follows it are noise either way, and nothing is weighed.
std::optional<EdgeByte> RtuFramer::first_edge(uint64_t begin, uint64_t end) const {
  if (end - begin < 2 || !is_glitch_byte(*at_ptr(begin)) ||
      !readings_.awaited().starts(bytes(begin + 1, end)))
    return std::nullopt;
  EdgeByte edge{EdgeSide::first, begin, *at_ptr(begin), s_.glitch_odds.habit()};
  edge.weigh(Feature::awaited_header, true, true);
  edge.weigh(Feature::awaited_header, readings_.awaited().starts(bytes(begin, end)), false);
  observe_edge(edge);
  return edge;
}

// The last byte of a damaged answer cut short, a 0x00 or 0xFF with bytes after it: the next
// sender's glitch, or the answer's own (EdgeByte). What its request tells of the byte, a
// silence after it, a clock per byte that saw it sent straight on, and a glitch already taken
// right after it (one driver turning on puts one on the line) weigh; the bus's habit ranks the
// two where they tie. `glitch_after`: the byte after the piece was just taken for a glitch.
std::optional<EdgeByte> RtuFramer::last_edge(uint64_t begin, uint64_t end,
                                             bool glitch_after) const {
  const uint64_t size = end - begin;
  const auto length = readings_.awaited().length(bytes(begin, end));
  const bool cut_short =
      (length && size <= *length) || (!length && readings_.awaited().length(bytes(begin, end - 1)));
  if (!cut_short || size <= 3 || !is_glitch_byte(*at_ptr(end - 1)) || end >= s_.end)
    return std::nullopt;
  EdgeByte edge{EdgeSide::last, end - 1, *at_ptr(end - 1), s_.glitch_odds.habit()};
  const std::optional<bool> told = readings_.awaited().byte(bytes(begin, end), size - 1);
  edge.weigh(Feature::byte_ruled_out, told == false, true);
  edge.weigh(Feature::predicted_byte, told == true, false);
  edge.weigh(Feature::silence_after, s_.timeline.gap_at(end), false);
  edge.weigh(Feature::sent_straight_on, !s_.timeline.after_quiet_line(end - 1), false);
  edge.weigh(Feature::second_glitch, glitch_after, false);
  observe_edge(edge);
  return edge;
}

void RtuFramer::observe_edge(const EdgeByte& edge) const {
  if (options_.observer) options_.observer->on_edge_byte(channel_, edge);
}

void RtuFramer::emit_noise(uint64_t begin, uint64_t end, NoiseReason reason) {
  Noise noise;
  noise.channel = channel_;
  noise.mode = Mode::rtu;
  noise.offset = begin;
  noise.raw = {at_ptr(begin), static_cast<size_t>(end - begin)};
  noise.t_ns = s_.timeline.start_time(begin);
  noise.end_ns = s_.timeline.end_time(end - 1);
  noise.untimed_start = s_.timeline.starts_untimed(begin);
  noise.reason = reason;
  sink_.on_noise(noise);
  if (reason == NoiseReason::glitch && begin == s_.answer_start) s_.answer_start = end;
  consume(end);
}

void RtuFramer::consume(uint64_t to) {
  s_.head = to;
  s_.timeline.drop_before(s_.head);
  if (s_.head == s_.end) {
    s_.buf.clear();
    readings_.drop_before(s_.head);
    s_.base = s_.head;
  } else if (s_.head - s_.base >= compact_after) {
    s_.buf.erase(s_.buf.begin(), s_.buf.begin() + static_cast<ptrdiff_t>(s_.head - s_.base));
    readings_.drop_before(s_.head);
    s_.base = s_.head;
  }
}

}  // namespace modtap
