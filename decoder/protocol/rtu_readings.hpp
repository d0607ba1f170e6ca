// How the bytes of an RTU stream read: the evaluation the framer asks at each start. A frame's
// readings (its roles, its ends by length rules and CRC), the evidence table's rows that weigh
// a span (framing_rows.cpp) and the runner-ups of its end, all on the stream the framer keeps,
// read only: what RtuReadings changes is its own caches (the CRC index over junk, the last
// search's hits, where the awaited answer ends), never the bytes, their times or the records.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "decoder/protocol/awaited_answer.hpp"
#include "decoder/protocol/byte_timeline.hpp"
#include "decoder/protocol/checksum.hpp"
#include "decoder/protocol/frame_sink.hpp"
#include "decoder/protocol/framing_evidence.hpp"
#include "decoder/protocol/function_codes.hpp"
#include "decoder/protocol/glitch_odds.hpp"
#include "decoder/protocol/records.hpp"
#include "decoder/protocol/serial_format.hpp"

namespace modtap {

struct RtuFramerOptions {
  SerialFormat format;
  ClockQuality clock = ClockQuality::per_chunk;
  ChannelRole role = ChannelRole::bus;
  // With per-chunk clocks a USB adapter holds bytes back (FTDI: 16 ms latency timer), so a
  // gap is only evidence when it is longer than t3.5 plus this.
  int64_t chunk_jitter_ns = default_read_jitter_ns;
  FramingObserver* observer = nullptr;     // told the readings weighed at each start (--explain)
  FeatureWeights weights = table_weights;  // what each feature of the evidence table weighs
};

// What the framer has read and not yet put in a record, and what it knows of the bus so far:
// the state RtuFramer changes, byte by byte and record by record.
struct RtuStream {
  explicit RtuStream(const RtuFramerOptions& options)
      : timeline(options.format, options.clock, options.chunk_jitter_ns) {}

  const uint8_t* at_ptr(uint64_t offset) const { return buf.data() + (offset - base); }
  std::span<const uint8_t> bytes(uint64_t begin, uint64_t stop) const {
    return {at_ptr(begin), static_cast<size_t>(stop - begin)};
  }
  std::span<const uint8_t> from(uint64_t at) const { return bytes(at, end); }

  std::vector<uint8_t> buf;   // bytes from stream offset `base` on
  uint64_t base = 0;          // stream offset of buf[0]
  uint64_t head = 0;          // stream offset of the first byte in no record yet
  uint64_t end = 0;           // stream offset one past the last byte
  uint64_t answer_start = 0;  // where the last frame (and a lone glitch after it) ended
  ByteTimeline timeline;
  GlitchOdds glitch_odds;  // the bus's glitches so far, against a frame's bytes by chance
};

class RtuReadings {
 public:
  RtuReadings(uint16_t channel, const RtuFramerOptions& options, const Expectation& expected,
              const RtuStream& stream);

  struct Match {
    enum class Kind : uint8_t { found, need_more, none } kind = Kind::none;
    uint16_t length = 0;
    RoleFit fit;
    // The end one byte longer or shorter, a 0x00 the frame's or a glitch, and what tells it.
    Margin end_margin{};
    SpanEnd end = SpanEnd::length_rules;
  };
  static Match need_more() { return {Match::Kind::need_more, 0, {}}; }
  // A frame found by CRC search may be confirmed by following ones found the same way (FC08
  // Return Query Data requests and their echoes, back to back); CRC hits are rare, so each
  // level costs one more bounded scan.
  static constexpr int max_search = 8;
  static constexpr uint16_t crc_size = 2;
  static constexpr uint16_t min_adu = 4;             // slave, function, CRC
  static constexpr uint8_t max_unicast_slave = 247;  // 248-255 are reserved (Serial Line 2.2)
  static bool may_start(uint8_t fc);
  static bool may_start_request(uint8_t slave, uint8_t fc);
  // What a driver turning on puts on the bus: one byte, the line's idle level or its opposite.
  static bool is_glitch_byte(uint8_t byte) { return byte == 0x00 || byte == 0xFF; }
  // The decision at a frame's start, which the observer hears (--explain).
  Match match_start(uint64_t at, bool final) { return match_at(at, final, max_search, true); }
  // Where `broke-off-at-silence` refutes every span across the first silence after `at`.
  bool blocked_by_gap(uint64_t at, bool final);
  bool fits_role(Role role, uint64_t at, uint16_t length) const;
  // What the pending request says of the bytes after it: the framer's pieces ask it too.
  const AwaitedAnswer& awaited() const { return awaited_; }
  // Whether the frame at `at` has a code a bus carries (`bus-code`).
  bool standard_frame(uint64_t at) const;
  // A step of the framer begins: a frame emitted, or a request's time-out, changes where the
  // awaited answer ends.
  void new_step() { head_awaited_end_ = end_unknown; }
  // The bytes before `head` are in records: the CRC index lets them go.
  void drop_before(uint64_t head) { crc_index_.drop_before(head); }

 private:
  struct CrcHits {
    uint64_t at = UINT64_MAX;
    size_t first = 0;
    size_t limit = 0;
    size_t count = 0;
    std::array<uint16_t, max_rtu_adu> lengths;
  };

  struct Readings {
    bool request = false, response = false;
    std::array<Role, 2> order{};
    size_t count = 0;
    bool allows(Role role) const { return role == Role::request ? request : response; }
  };
  Readings readings_at(uint64_t at) const;

  // `search` is how many variable-length frames in a row may be found by CRC search; a reading
  // nested in another's judgement is not `observed`.
  Match match_at(uint64_t at, bool final, int search, bool observed = false);
  enum class Verdict : uint8_t { keep, refuted, wait };
  // What a row of the evidence table found of a span: the features of its reading of the bytes
  // that hold (the row holds where all it needs do), and whether bytes that would tell the rest
  // have yet to come. A row stops at the first feature that fails. One word, so that a row that
  // found nothing, as nearly every row on nearly every frame, costs one test.
  class RowFeatures {
   public:
    RowFeatures() = default;
    RowFeatures(FeatureSet held, bool to_come = false)  // NOLINT: a row returns its set
        : word_(held.mask() | (to_come ? to_come_bit : 0)) {}
    FeatureSet held() const { return FeatureSet::of_mask(word_ & ~to_come_bit); }
    bool to_come() const { return (word_ & to_come_bit) != 0; }
    bool nothing() const { return word_ == 0; }
    RowFeatures with(Feature f) const {
      FeatureSet set = held();
      set.add(f);
      return {set, to_come()};
    }

    static constexpr uint32_t to_come_bit = uint32_t{1} << 31;
    uint32_t word_ = 0;
  };
  static RowFeatures to_come(FeatureSet held = {}) { return {held, true}; }
  // A reading of [at, at + length) as `role` whose length rules and CRC agree; `other` is the
  // other role, where it is allowed.
  struct Reading {
    uint64_t at;
    Role role;
    uint16_t length;
    const Role* other;
    bool final;
    int search;
  };
  std::optional<Evidence> weigh_start(uint64_t at);
  RowFeatures vendor_frame_inside_awaited_answer(uint64_t at);
  Verdict weigh_span(const Reading& reading, Evidence& why);
  struct Row {  // a row of weigh_span's table: its evidence, and the features it finds
    Evidence evidence;
    RowFeatures (RtuReadings::*finds)(const Reading&);
  };
  template <Row... rows>
  Verdict weigh_rows(const Reading& reading, Evidence& why);
  // Whether the row `row` holds on `found` and outweighs a span's CRC alone.
  template <Evidence row>
  bool refutes_alone(const RowFeatures& found) const {
    constexpr FeatureSet needs = evidence_info(row).needs();
    return found.held().contains(needs) && row_weights_.of(row) > row_weights_.span;
  }
  // Each row's weight from the framer's feature weights, worked out once.
  struct RowWeights {
    explicit RowWeights(const FeatureWeights& weights);
    int of(Evidence row) const { return rows[static_cast<size_t>(row)]; }
    std::array<int16_t, evidence_table.size()> rows{};
    int span;
  };
  // A span's score as the rows are weighed: its CRC's bits, less each row that holds.
  struct Weight {
    explicit Weight(const RowWeights& w) : weights(w), score(w.span) {}
    const RowWeights& weights;
    int score;
    std::optional<Evidence> unknown;   // a row whose bytes have not come, heavy enough to refute
    std::optional<Evidence> refuting;  // the row that took the score below nothing
    template <Evidence row>
    bool refuted(const RowFeatures& found) {
      constexpr FeatureSet needs = evidence_info(row).needs();
      if (found.nothing()) return false;
      const bool holds = found.held().contains(needs);
      if (!holds && !found.to_come()) return false;
      const int bits = weights.of(row);
      if (!holds) {
        if (!unknown && score < bits) unknown = row;
        return false;
      }
      score -= bits;
      if (score >= 0) return false;
      refuting = row;
      return true;
    }
  };
  // The rows of weigh_span's table.
  RowFeatures good_frame_before_silence(const Reading& r);
  RowFeatures broke_off_at_silence(const Reading& r);
  RowFeatures frame_after_silence(uint64_t gap, bool final);
  RowFeatures answer_read_as_request(const Reading& r);
  RowFeatures request_inside_awaited_answer(const Reading& r);
  RowFeatures unawaited_answer_inside_awaited_answer(const Reading& r);
  bool request_right_before(uint64_t at, bool final);
  RowFeatures predicted_inside_awaited_answer(const Reading& r);
  RowFeatures retry_and_glitch(const Reading& r);
  RowFeatures retry_read_as_answer(const Reading& r);
  std::optional<bool> leaves_junk(uint64_t next, bool final);
  RowFeatures answer_copying_request(const Reading& r);
  std::optional<bool> copy_begins_answer(const Reading& r, size_t awaited);
  RowFeatures answer_cut_before_request(const Reading& r);
  RowFeatures swallows_known_frame_reading(const Reading& r);
  RowFeatures swallows_exchange_reading(const Reading& r);
  RowFeatures swallows_request_reading(const Reading& r);
  RowFeatures resent_inside(const Reading& r);
  std::optional<uint64_t> request_ending(uint64_t begin, uint64_t end) const;
  bool request_spans(uint64_t start, uint64_t end) const;
  bool request_before_kin(uint64_t begin, uint64_t end, uint64_t next) const;
  static uint16_t request_length_of_code(uint8_t function);
  static ReadingOutcome outcome_of(Verdict verdict);
  void observe(uint64_t at, Role role, const Match& match, ReadingOutcome outcome,
               Evidence why) const;
  std::optional<bool> cut_before_frame(uint64_t at, uint16_t length, bool final, int search);
  std::optional<bool> request_across(uint64_t first, uint64_t end, bool final, int search);
  bool checks_at(uint64_t at) const;
  bool first_after_request(uint64_t at) const;
  // A copy of the pending request starting at `at` came before the master could time out.
  bool too_soon_for_retry(uint64_t at) const {
    return awaited_.too_soon_for_retry(s_.timeline.start_time(at));
  }
  Match match_role(Role role, uint64_t at, bool final, int search);
  // The lengths in [first, limit] that give the bytes from `at` a good CRC, ascending.
  size_t good_lengths(uint64_t at, size_t first, size_t limit,
                      std::array<uint16_t, max_rtu_adu>& lengths);
  void index_span(uint64_t begin, uint64_t end);
  Match search_end(uint64_t at, size_t first, RoleFit fit, bool final, int search,
                   bool public_header);
  Match first_confirmed_end(uint64_t at, size_t first, size_t limit, RoleFit fit, bool final,
                            int search);
  // `shorter`: the margin against the frame one byte shorter (shorter_end), if it is one.
  bool glitch_appended(uint64_t begin, uint64_t end, const Margin& shorter) const;
  bool glitch_then_frame(uint64_t at, bool final, int search);
  Margin longer_end(uint64_t at, uint64_t end) const;
  Margin shorter_end(uint64_t at, uint64_t end, bool final, int search);
  bool glitch_then_kin(uint64_t at, uint64_t end) const;
  static void consider(Margin& margin, const Margin& other);
  // What confirms a CRC search's hit at `end`, if anything does.
  std::optional<SpanEnd> confirmed_end(uint64_t begin, uint64_t end, bool final, int search,
                                       bool allow_glitch);
  bool copy_follows(uint64_t begin, uint64_t end) const { return copy_follows(begin, end, end); }
  // Whether the bytes [begin, end) come again from `copy` on, with no silence inside.
  bool copy_follows(uint64_t begin, uint64_t end, uint64_t copy) const;
  // Whether a frame a bus carries (public function code, standard exception), of known length
  // and good CRC, starts inside [begin, end), wherever it ends, and outweighs the span: one
  // whose end a CRC search found (`searched`), from an `unexpected` sender; unknown while such a
  // frame may still come, unless `final`.
  RowFeatures swallows_known_frame(uint64_t begin, uint64_t end, bool searched, bool unexpected,
                                   bool final);
  bool copied_frame_at(uint64_t at);
  bool unexpected_sender(uint64_t at, bool answer) const;
  bool glitch_then_awaited(uint64_t at) const;
  RowFeatures swallows_exchange(uint64_t begin, uint64_t end, bool final);
  std::optional<bool> answer_follows(uint64_t at, uint64_t end, bool final) const;
  std::optional<uint64_t> awaited_start(uint64_t at) const;
  // Junk asks this at every start it weighs: the awaited end is worked out once a step.
  bool inside_awaited_span(uint64_t at) {
    if (at <= s_.head) return false;
    if (head_awaited_end_ == end_unknown) head_awaited_end_ = awaited_end(s_.head);
    return at < head_awaited_end_;
  }
  uint64_t awaited_end(uint64_t at) const;

  const uint8_t* at_ptr(uint64_t offset) const { return s_.at_ptr(offset); }
  std::span<const uint8_t> bytes(uint64_t begin, uint64_t end) const {
    return s_.bytes(begin, end);
  }
  std::span<const uint8_t> from(uint64_t at) const { return s_.from(at); }

  uint16_t channel_;
  RtuFramerOptions options_;
  const Expectation& expected_;
  AwaitedAnswer awaited_;
  const RtuStream& s_;
  // Where the answer awaited at the stream's head ends, asked at most once a step.
  static constexpr uint64_t end_unknown = UINT64_MAX;
  uint64_t head_awaited_end_ = end_unknown;
  CrcIndex crc_index_;  // over the searched part of the stream
  CrcHits last_hits_;
  RowWeights row_weights_;
};

}  // namespace modtap
