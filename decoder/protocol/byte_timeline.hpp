// When each byte of a channel's stream came, as well as its source's clock can say: a mark
// per chunk (the bytes [first, end) ended at end_ns), and the silences long enough to be frame
// boundaries. What a clock per chunk cannot time (bytes inside a read) is placed back to back
// before the chunk's time, and said to be untimed.
#pragma once

#include <cstdint>

#include "decoder/protocol/flat_queue.hpp"
#include "decoder/protocol/records.hpp"
#include "decoder/protocol/serial_format.hpp"

namespace modtap {

class ByteTimeline {
 public:
  struct Mark {
    uint64_t first;
    uint64_t end;
    int64_t end_ns;
    bool continues_read;  // Chunk::continues_read
    uint64_t read;        // its number (Frame::start_read)
  };

  // With per-chunk clocks a USB adapter holds bytes back (FTDI: 16 ms latency timer), so a
  // gap is only a boundary when it is longer than t3.5 plus `chunk_jitter_ns`.
  ByteTimeline(const SerialFormat& format, ClockQuality clock, int64_t chunk_jitter_ns);

  // The next chunk: `size` bytes from stream offset end() on.
  void add(size_t size, int64_t t_ns, bool continues_read);
  // Forgets the marks and gaps wholly before `offset`.
  void drop_before(uint64_t offset);

  ClockQuality clock() const { return clock_; }
  int64_t char_ns() const { return char_ns_; }
  uint64_t end() const { return end_; }
  int64_t last_end_ns() const { return last_end_ns_; }
  // Whether the line has been quiet at `now_ns` for as long as a boundary takes.
  bool boundary_silence_at(int64_t now_ns) const {
    return now_ns - last_end_ns_ >= gap_threshold_ns_;
  }
  // The last chunk, or whether there is none.
  bool empty() const { return marks_.empty(); }
  const Mark& last() const { return marks_.back(); }

  // What a record of the bytes [begin, end) carries of their times, each chunk looked up once:
  // every record asks all of it.
  struct SpanTimes {
    int64_t start_ns;     // start_time(begin)
    int64_t end_ns;       // end_time(end - 1)
    bool untimed_start;   // starts_untimed(begin)
    uint64_t start_read;  // mark_of(begin).read
    uint64_t end_read;    // mark_of(end - 1).read
  };
  SpanTimes span_times(uint64_t begin, uint64_t end) const;

  int64_t end_time(uint64_t offset) const;
  int64_t start_time(uint64_t offset) const { return end_time(offset) - char_ns_; }
  // The chunk that held the byte at `offset`, one not yet dropped: most often the newest.
  const Mark& mark_of(uint64_t offset) const;
  // Whether the byte at `offset` came in one read with the byte before it (Frame::untimed_start).
  bool starts_untimed(uint64_t offset) const;
  // Whether a silence of a boundary's length came right before `offset`.
  bool gap_at(uint64_t offset) const;
  uint64_t first_gap_after(uint64_t offset) const;  // end() if none
  // Whether a clock per byte saw a silence over t1.5 right before `offset`, or between two of
  // the bytes [begin, end): no frame goes on across one. Other clocks cannot time such a pause.
  bool paused_before(uint64_t offset) const;
  bool paused_inside(uint64_t begin, uint64_t end) const;
  // Whether the byte at `offset` may have been sent after a quiet line, as a driver's glitch is:
  // where the clock times each byte, one sent right behind the byte before it is not.
  bool after_quiet_line(uint64_t offset) const;
  // Whether the read that brought byte `at` began before it.
  bool read_starts_inside(uint64_t at) const;
  // Whether a read that brought bytes of [begin, end) brought several, or went on with a read
  // before it: not a source that reads a byte at a time.
  bool reads_several(uint64_t begin, uint64_t end) const;

 private:
  const Mark* find(uint64_t offset) const;
  // The chunk that held `offset`, the newest looked at first; none past the newest.
  const Mark* locate(uint64_t offset) const {
    const Mark& newest = marks_.back();
    return offset >= newest.first && offset < newest.end ? &newest : find(offset);
  }
  int64_t end_time_in(const Mark* mark, uint64_t offset) const {
    if (clock_ == ClockQuality::none) return static_cast<int64_t>(offset + 1) * char_ns_;
    if (!mark) return last_end_ns_;
    return mark->end_ns - static_cast<int64_t>(mark->end - 1 - offset) * char_ns_;
  }

  ClockQuality clock_;
  int64_t char_ns_;
  int64_t t15_ns_;
  int64_t gap_threshold_ns_;
  FlatQueue<Mark> marks_;
  FlatQueue<uint64_t> gaps_;  // stream offsets preceded by a boundary-sized silence
  uint64_t end_ = 0;
  int64_t last_end_ns_ = 0;
  bool have_time_ = false;
  uint64_t reads_ = 0;  // chunks added, those that continue a read aside
};

}  // namespace modtap
