#include "decoder/protocol/byte_timeline.hpp"

#include <algorithm>

namespace modtap {

ByteTimeline::ByteTimeline(const SerialFormat& format, ClockQuality clock, int64_t chunk_jitter_ns)
    : clock_(clock),
      char_ns_(format.char_time_ns()),
      t15_ns_(format.t15_ns()),
      gap_threshold_ns_(format.t35_ns() +
                        (clock == ClockQuality::per_chunk ? chunk_jitter_ns : 0)) {}

void ByteTimeline::add(size_t size, int64_t t_ns, bool continues_read) {
  int64_t t_end = t_ns;
  if (clock_ == ClockQuality::none) {
    t_end = static_cast<int64_t>(end_ + size) * char_ns_;
  } else if (have_time_) {
    const int64_t first_start = t_end - static_cast<int64_t>(size) * char_ns_;
    if (first_start - last_end_ns_ >= gap_threshold_ns_) gaps_.push_back(end_);
  }
  have_time_ = true;
  last_end_ns_ = std::max(last_end_ns_, t_end);
  if (!continues_read || marks_.empty()) ++reads_;
  marks_.push_back({end_, end_ + size, t_end, continues_read, reads_});
  end_ += size;
}

void ByteTimeline::drop_before(uint64_t offset) {
  while (!gaps_.empty() && gaps_.front() <= offset) gaps_.pop_front();
  while (marks_.size() > 1 && marks_.front().end <= offset) marks_.pop_front();
}

// The framer asks most often of its first unplaced byte, in the oldest mark it keeps.
const ByteTimeline::Mark* ByteTimeline::find(uint64_t offset) const {
  if (!marks_.empty() && offset < marks_.front().end) return &marks_.front();
  const Mark* it = std::upper_bound(marks_.begin(), marks_.end(), offset,
                                    [](uint64_t o, const Mark& m) { return o < m.end; });
  return it == marks_.end() ? nullptr : it;
}

int64_t ByteTimeline::end_time(uint64_t offset) const {
  if (clock_ == ClockQuality::none) return static_cast<int64_t>(offset + 1) * char_ns_;
  return end_time_in(locate(offset), offset);
}

ByteTimeline::SpanTimes ByteTimeline::span_times(uint64_t begin, uint64_t end) const {
  const Mark* first = locate(begin);
  const Mark* last = first && end - 1 < first->end ? first : locate(end - 1);
  const Mark& newest = marks_.back();
  const Mark& first_mark = first ? *first : newest;
  return {
      end_time_in(first, begin) - char_ns_, end_time_in(last, end - 1),
      clock_ == ClockQuality::per_chunk && (first_mark.first < begin || first_mark.continues_read),
      first_mark.read, (last ? *last : newest).read};
}

const ByteTimeline::Mark& ByteTimeline::mark_of(uint64_t offset) const {
  const Mark& newest = marks_.back();
  if (offset >= newest.first) return newest;
  const Mark* mark = find(offset);
  return mark ? *mark : newest;
}

bool ByteTimeline::starts_untimed(uint64_t offset) const {
  const Mark& mark = mark_of(offset);
  return clock_ == ClockQuality::per_chunk && (mark.first < offset || mark.continues_read);
}

bool ByteTimeline::gap_at(uint64_t offset) const {
  return std::binary_search(gaps_.begin(), gaps_.end(), offset);
}

uint64_t ByteTimeline::first_gap_after(uint64_t offset) const {
  const uint64_t* it = std::upper_bound(gaps_.begin(), gaps_.end(), offset);
  return it == gaps_.end() ? end_ : *it;
}

bool ByteTimeline::paused_before(uint64_t offset) const {
  return clock_ == ClockQuality::per_byte && start_time(offset) - end_time(offset - 1) > t15_ns_;
}

bool ByteTimeline::paused_inside(uint64_t begin, uint64_t end) const {
  if (clock_ != ClockQuality::per_byte) return false;
  for (const Mark* it = find(begin); it && it != marks_.end(); ++it) {
    const Mark* next = it + 1;
    if (next == marks_.end() || next->first >= end) return false;
    const int64_t next_start =
        next->end_ns - static_cast<int64_t>(next->end - next->first) * char_ns_;
    if (next_start - it->end_ns > t15_ns_) return true;
  }
  return false;
}

bool ByteTimeline::after_quiet_line(uint64_t offset) const {
  if (clock_ != ClockQuality::per_byte || offset == 0) return true;
  return end_time(offset) - end_time(offset - 1) >= 2 * char_ns_;
}

// Reads that do not follow the frames (a timer's, every 16 ms) end wherever the bytes did, as
// likely right after the next frame's first byte as after a frame; reads that follow them (a
// packet a frame, an adapter's read a frame) begin with the frame.
bool ByteTimeline::read_starts_inside(uint64_t at) const {
  for (auto mark = marks_.rbegin(); mark != marks_.rend(); ++mark)
    if (mark->first <= at) return mark->first < at && at < mark->end;
  return false;
}

bool ByteTimeline::reads_several(uint64_t begin, uint64_t end) const {
  for (auto mark = marks_.rbegin(); mark != marks_.rend() && mark->end > begin; ++mark)
    if (mark->first < end && (mark->end - mark->first > 1 || mark->continues_read)) return true;
  return false;
}

}  // namespace modtap
