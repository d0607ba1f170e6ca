// Splits a channel's byte stream into RTU frames and noise.
//
// Structure decides, timing advises: a boundary is where the function-code length rules say
// a frame ends and the CRC agrees. Gaps of t3.5 or more (beyond what the source's clock can
// blur) are marks that cut a frame which cannot complete. Every byte pushed leaves in exactly
// one Frame or Noise record, in order.
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

class RtuFramer {
 public:
  RtuFramer(uint16_t channel, const RtuFramerOptions& options, FrameSink& sink);

  void push(const Chunk& chunk);
  // Called with the current time when no bytes came: after a silence long enough to be a
  // boundary, whatever is pending is resolved.
  void flush(int64_t now_ns);
  // End of the stream: resolve everything.
  void finish();

  int64_t last_byte_ns() const { return timeline_.last_end_ns(); }
  // When the first byte not yet in a record began (INT64_MAX if none): what comes out later
  // may still be from then.
  int64_t held_since_ns() const;

 private:
  struct Match {
    enum class Kind : uint8_t { found, need_more, none } kind = Kind::none;
    uint16_t length = 0;
    RoleFit fit;
    // The end one byte longer or shorter, a 0x00 the frame's or a glitch, and what tells it.
    Margin end_margin{};
    SpanEnd end = SpanEnd::length_rules;
  };
  static Match need_more() { return {Match::Kind::need_more, 0, {}}; }
  static constexpr uint16_t crc_size = 2;
  static constexpr uint16_t min_adu = 4;             // slave, function, CRC
  static constexpr uint8_t max_unicast_slave = 247;  // 248-255 are reserved (Serial Line 2.2)
  static bool may_start(uint8_t fc);
  static bool may_start_request(uint8_t slave, uint8_t fc);
  // What a driver turning on puts on the bus: one byte, the line's idle level or its opposite.
  static bool is_glitch_byte(uint8_t byte) { return byte == 0x00 || byte == 0xFF; }
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

  void resolve(bool final);
  // The decision at a frame's start, which the observer hears (--explain).
  Match match_start(uint64_t at, bool final);
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

   private:
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
    RowFeatures (RtuFramer::*finds)(const Reading&);
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
    return awaited_.too_soon_for_retry(timeline_.start_time(at));
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
  bool fits_role(Role role, uint64_t at, uint16_t length) const;
  // What confirms a CRC search's hit at `end`, if anything does.
  std::optional<SpanEnd> confirmed_end(uint64_t begin, uint64_t end, bool final, int search,
                                       bool allow_glitch);
  bool blocked_by_gap(uint64_t at, bool final);
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
  // First position >= from that starts a good frame; `decided` false if one is still open.
  uint64_t next_start(uint64_t from, bool final, bool& decided);
  std::optional<uint64_t> awaited_start(uint64_t at) const;
  // Junk asks this at every start it weighs: the awaited end is worked out once a step.
  bool inside_awaited_span(uint64_t at) {
    if (at <= head_) return false;
    if (head_awaited_end_ == end_unknown) head_awaited_end_ = awaited_end(head_);
    return at < head_awaited_end_;
  }
  uint64_t awaited_end(uint64_t at) const;
  bool standard_frame(uint64_t at) const;
  Frame frame_of(uint64_t begin, uint64_t end, RoleFit fit) const;
  void emit_frame(uint64_t at, const Match& match);
  void emit_unframed(uint64_t begin, uint64_t end);
  // `glitch_after`: the byte after the piece was just taken for a turnaround's glitch, which
  // weighs against its own last byte being a second (last_edge).
  void emit_piece(uint64_t begin, uint64_t end, uint32_t findings = finding_none,
                  bool glitch_after = false);
  void emit_run_on(uint64_t begin, uint64_t end);
  PieceHeader piece_header(uint64_t at) const;
  std::optional<EdgeByte> first_edge(uint64_t begin, uint64_t end) const;
  std::optional<EdgeByte> last_edge(uint64_t begin, uint64_t end, bool glitch_after) const;
  void observe_edge(const EdgeByte& edge) const;
  void emit_damaged(uint64_t begin, uint64_t end, Damage damage, uint32_t findings);
  void emit_noise(uint64_t begin, uint64_t end, NoiseReason reason);
  void consume(uint64_t to);

  const uint8_t* at_ptr(uint64_t offset) const { return buf_.data() + (offset - base_); }
  std::span<const uint8_t> bytes(uint64_t begin, uint64_t end) const {
    return {at_ptr(begin), static_cast<size_t>(end - begin)};
  }
  std::span<const uint8_t> from(uint64_t at) const { return bytes(at, end_); }

  uint16_t channel_;
  RtuFramerOptions options_;
  FrameSink& sink_;
  const Expectation& expected_;
  AwaitedAnswer awaited_;
  ByteTimeline timeline_;

  std::vector<uint8_t> buf_;   // bytes from stream offset base_ on
  uint64_t base_ = 0;          // stream offset of buf_[0]
  uint64_t head_ = 0;          // stream offset of the first unresolved byte
  uint64_t end_ = 0;           // stream offset one past the last byte
  uint64_t answer_start_ = 0;  // where the last frame (and a lone glitch after it) ended
  uint64_t scanned_to_ = 0;    // positions below this are known not to start a frame
  // Where the answer awaited at head_ ends, asked at most once a step of resolve.
  static constexpr uint64_t end_unknown = UINT64_MAX;
  uint64_t head_awaited_end_ = end_unknown;
  CrcIndex crc_index_;  // over the searched part of buf_
  CrcHits last_hits_;
  GlitchOdds glitch_odds_;  // the bus's glitches so far, against a frame's bytes by chance
  RowWeights row_weights_;
};

}  // namespace modtap
