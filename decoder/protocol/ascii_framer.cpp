#include "decoder/protocol/ascii_framer.hpp"

#include "decoder/protocol/checksum.hpp"
#include "decoder/protocol/function_codes.hpp"

namespace modtap {
namespace {

int hex_value(uint8_t c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

// Hex pairs between ':' and CR LF; false if any character is not hex or one is left over.
bool decode_hex(const std::vector<uint8_t>& wire, std::vector<uint8_t>& out) {
  out.clear();
  const size_t body = wire.size() - 3;  // minus ':' CR LF
  if (body % 2 != 0) return false;
  for (size_t i = 1; i < 1 + body; i += 2) {
    const int hi = hex_value(wire[i]), lo = hex_value(wire[i + 1]);
    if (hi < 0 || lo < 0) return false;
    out.push_back(static_cast<uint8_t>(hi << 4 | lo));
  }
  return true;
}

bool fits(Role role, std::span<const uint8_t> adu) {
  const auto body_bytes = adu.size() - 1;  // without the LRC
  const BodyLength body = body_length(role, adu.first(body_bytes));
  if (body.kind == BodyLength::Kind::known) return body.bytes == body_bytes;
  return body.kind == BodyLength::Kind::variable && body.bytes <= body_bytes;
}

// Whether the bytes end before their LRC could: as long as their structure or shorter, as N3's
// manual prints an exception ":028352" CR LF. Their last byte is data, not a check.
bool ends_before_check(Role role, std::span<const uint8_t> adu) {
  const BodyLength body = body_length(role, adu);
  return body.kind == BodyLength::Kind::need_more ||
         (body.kind == BodyLength::Kind::known && adu.size() <= body.bytes);
}

}  // namespace

AsciiFramer::AsciiFramer(uint16_t channel, const AsciiFramerOptions& options, FrameSink& sink)
    : channel_(channel), options_(options), sink_(sink), char_ns_(options.format.char_time_ns()) {
  pending_.reserve(max_frame_chars);
}

void AsciiFramer::push(const Chunk& chunk) {
  if (!chunk.continues_read || reads_ == 0) ++reads_;
  const auto n = static_cast<int64_t>(chunk.bytes.size());
  for (int64_t i = 0; i < n; ++i) {
    int64_t end_ns = options_.clock == ClockQuality::none
                         ? static_cast<int64_t>(offset_ + 1) * char_ns_
                         : chunk.t_ns - (n - 1 - i) * char_ns_;
    on_byte(chunk.bytes[static_cast<size_t>(i)], end_ns, i == 0 && !chunk.continues_read);
  }
}

void AsciiFramer::flush(int64_t now_ns) {
  if (options_.clock == ClockQuality::none) return;
  if (in_frame_ && now_ns - pending_end_ns_ >= options_.char_timeout_ns)
    emit_pending(NoiseReason::truncated);
  if (!held_.raw.empty() && now_ns - held_.end_ns >= options_.char_timeout_ns) release_held();
}

void AsciiFramer::finish() {
  if (!pending_.empty()) emit_pending(in_frame_ ? NoiseReason::truncated : NoiseReason::junk);
  release_held();
}

void AsciiFramer::on_byte(uint8_t byte, int64_t end_ns, bool starts_read) {
  const int64_t start_ns = end_ns - char_ns_;
  if (in_frame_ && options_.clock != ClockQuality::none &&
      start_ns - pending_end_ns_ >= options_.char_timeout_ns)
    emit_pending(NoiseReason::truncated);

  if (byte == ':') {
    // A new start: whatever came before it is junk or a frame that never ended.
    if (!pending_.empty()) emit_pending(in_frame_ ? NoiseReason::truncated : NoiseReason::junk);
    in_frame_ = true;
  }
  if (pending_.empty()) reset(offset_, start_ns, starts_read);
  pending_.push_back(byte);
  pending_end_ns_ = end_ns;
  last_end_ns_ = end_ns;
  ++offset_;

  if (in_frame_) {
    const size_t n = pending_.size();
    if (n >= 3 && pending_[n - 2] == '\r' && pending_[n - 1] == '\n') {
      emit_frame();
    } else if (n >= max_frame_chars) {
      emit_pending(NoiseReason::overlong);
    }
  } else if (pending_.size() >= max_frame_chars) {
    emit_pending(NoiseReason::junk);
  }
}

void AsciiFramer::emit_pending(NoiseReason reason) {
  emit_noise(reason);
  in_frame_ = false;
}

void AsciiFramer::emit_frame() {
  in_frame_ = false;
  // Slave, function and LRC at the least.
  if (!decode_hex(pending_, decoded_) || decoded_.size() < 3) {
    emit_noise(NoiseReason::bad_hex);
    return;
  }
  Frame frame;
  frame.channel = channel_;
  frame.mode = Mode::ascii;
  frame.offset = pending_offset_;
  frame.raw = pending_;
  frame.adu = decoded_;
  frame.t_ns = pending_start_ns_;
  frame.end_ns = pending_end_ns_;
  frame.untimed_start = pending_untimed_start_;
  frame.start_read = pending_start_read_;
  frame.end_read = reads_;
  frame.expected_check = lrc(frame.adu.first(decoded_.size() - 1));
  frame.check_ok = frame.expected_check == decoded_.back();
  const bool broadcast = decoded_[0] == 0;
  const bool may_request = options_.role != ChannelRole::slave && !(decoded_[1] & 0x80);
  const bool may_respond = options_.role != ChannelRole::master && !broadcast;
  if (!frame.check_ok) {
    frame.findings |= finding_bad_check;
    // ':' and CR LF say where it ends; its structure says whether an LRC fits before that.
    const bool cut = (may_request || may_respond) &&
                     (!may_request || ends_before_check(Role::request, frame.adu)) &&
                     (!may_respond || ends_before_check(Role::response, frame.adu));
    frame.damage = cut ? Damage::cut : Damage::corrupted;
    if (cut) frame.expected_check = 0;
  }
  frame.fit.request = may_request && fits(Role::request, frame.adu);
  frame.fit.response = may_respond && fits(Role::response, frame.adu);
  release_held();
  sink_.on_frame(frame);
  pending_.clear();
}

void AsciiFramer::emit_noise(NoiseReason reason) {
  if (reason == NoiseReason::junk || reason == NoiseReason::truncated) return hold_noise(reason);
  release_held();
  hold_noise(reason);  // alone, through the held record's kept room
  release_held();
}

// Joins the pending piece to the held run, unless a silence parts them (the inter-character
// time-out) or the run would outgrow a frame; the run is junk unless all of it is truncated.
void AsciiFramer::hold_noise(NoiseReason reason) {
  const bool silence = options_.clock != ClockQuality::none &&
                       pending_start_ns_ - held_.end_ns >= options_.char_timeout_ns;
  if (!held_.raw.empty() && (silence || held_.raw.size() + pending_.size() > max_frame_chars))
    release_held();
  if (held_.raw.empty()) {
    held_.offset = pending_offset_;
    held_.t_ns = pending_start_ns_;
    held_.untimed_start = pending_untimed_start_;
    held_.reason = reason;
  } else if (reason != held_.reason) {
    held_.reason = NoiseReason::junk;
  }
  held_.raw.insert(held_.raw.end(), pending_.begin(), pending_.end());
  held_.end_ns = pending_end_ns_;
  pending_.clear();
}

void AsciiFramer::release_held() {
  if (held_.raw.empty()) return;
  Noise noise;
  noise.channel = channel_;
  noise.mode = Mode::ascii;
  noise.offset = held_.offset;
  noise.raw = held_.raw;
  noise.t_ns = held_.t_ns;
  noise.end_ns = held_.end_ns;
  noise.untimed_start = held_.untimed_start;
  noise.reason = held_.reason;
  sink_.on_noise(noise);
  held_.raw.clear();
}

void AsciiFramer::reset(uint64_t offset, int64_t start_ns, bool starts_read) {
  pending_offset_ = offset;
  pending_start_ns_ = start_ns;
  pending_untimed_start_ = options_.clock == ClockQuality::per_chunk && !starts_read && offset > 0;
  pending_start_read_ = reads_;
}

}  // namespace modtap
