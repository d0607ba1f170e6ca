// The evidence the RTU framer weighs where a reading's length rules and CRC agree on a span of
// bytes. Each row is evidence that the span is not one frame, in whichever role it is read;
// each is made of features weighed in bits: log2 of how many times likelier the bytes are if
// the span is not one frame than if it is. The span's own CRC is worth 16 bits to it, and
// every row carries a coincidence as unlikely (another span whose CRC holds, two bytes the
// pending request predicts) and a feature more: one row outweighs the CRC, and a span that
// scores below nothing (junk, or a damaged frame's bytes) is refuted. `--explain` prints the
// score of each reading weighed and the features of the row that refuted it.
#pragma once

#include <array>
#include <cstdint>
#include <initializer_list>
#include <optional>
#include <span>
#include <string_view>

#include "decoder/protocol/glitch_odds.hpp"
#include "decoder/protocol/records.hpp"

namespace modtap {

enum class Feature : uint8_t {
  crc_holds,
  another_crc,
  silence_inside,
  awaited_header,
  too_soon_for_retry,
  glitch_odds,
  request_again,
  no_answer_after,
  answer_after,
  leaves_junk,
  bus_code,
  unexpected_sender,
  silence_after,
  sent_straight_on,
  second_glitch,
  byte_ruled_out,
  late_as_a_retry,
  pause_after,
  frame_after,
  copy_after,
  glitch_then_frame,
  predicted_bytes,
  vendor_code,
  predicted_byte,
  broken_off_copy,
  public_header,  // last: feature_table asserts a row for each
};

struct FeatureInfo {
  std::string_view name;
  int bits;
  std::string_view why;
};

inline constexpr auto feature_table = std::to_array<FeatureInfo>({
    {"crc-holds", 16, "bytes that are no frame pass a CRC 1 time in 65,536"},
    {"another-crc", 16,
     "another span over these bytes passes its own length rules and CRC, as unlikely by "
     "chance as this span's"},
    {"silence-inside", 8,
     "the clock saw a silence of t3.5 and its slack inside the span: no sender pauses so "
     "mid-frame (the standard ends a frame at t1.5), and a clock's false silence is taken as 1 "
     "in 256, a USB adapter's reads at worst"},
    {"awaited-header", 16,
     "the span starts as the awaited answer: the pending request's slave and function code "
     "where its answer is due, 2 bytes, by chance 1 time in 65,536"},
    {"too-soon-for-retry", 4,
     "it came before the master's retry could (twice the slave's longest turnaround, or the "
     "middle of the slaves' for one not heard yet, plus 20 ms; where told, the master's "
     "time-out less the clock's lag, however slowly the slave answers; a copy of the request as "
     "late as the master's own retries "
     "have come never is): taken as 1 in 16, a master with a shorter time-out"},
    {"glitch-odds", 4,
     "the bus shows 0x00 glitches at least 16 times as often as a CRC ends in 0x00 "
     "(GlitchOdds)"},
    {"request-again", 4,
     "the longer span is the pending request again, byte for byte, late enough to be its "
     "retry: taken as 1 in 16 for an answer one byte shorter its request did not ask for"},
    {"no-answer-after", 4,
     "no answer of its own (its slave and function code) after it, where a slave answers "
     "nearly every request: taken as 1 in 16"},
    {"answer-after", 16,
     "a frame of its own slave and function code next, its answer (or the master's retry): 2 "
     "bytes, by chance 1 time in 65,536"},
    {"leaves-junk", 4,
     "the reading leaves bytes next to it to no frame: nothing starts where it ends, or no "
     "frame holds the bytes before it, from where the last frame ended; a bus carries junk "
     "rarely, and a frame follows nearly every frame: taken as 1 in 16"},
    {"bus-code", 2,
     "a public function code, and for an exception a code the standard names: the codes a bus "
     "carries; junk's codes are such about 1 time in 6"},
    {"unexpected-sender", 4,
     "a reserved address (248-255, most often a turnaround's 0xFF) or an answer nobody "
     "awaits: taken as 1 in 16"},
    {"silence-after", 8,
     "the clock saw a silence of t3.5 and its slack right after it: a frame ends there (and a "
     "glitch comes before the next frame, not before a silence); a clock's false silence taken "
     "as 1 in 256"},
    {"sent-straight-on", 8,
     "a clock per byte saw the byte sent right after the one before it: a glitch is a driver "
     "turning on after a quiet line; the clock's error taken as 1 in 256"},
    {"second-glitch", 4,
     "the reading needs a second glitch at one turnaround, where one driver turning on puts "
     "one on the line: taken as 1 in 16"},
    {"byte-ruled-out", 16,
     "the pending request says what the answer's byte is, and it is not this one: by the "
     "standard's rules, no chance at all; weighed as the CRC is"},
    {"late-as-a-retry", 4,
     "it came as late as the master's retries do: past twice the slave's longest turnaround "
     "plus 20 ms and the clock's lag, or as late as the master's own retries have come; taken "
     "as 1 in 16, a slave that answered that late"},
    {"pause-after", 8,
     "a clock per byte saw a pause over t1.5 right after it: no frame goes on across one (the "
     "standard ends a frame there); the clock's error taken as 1 in 256"},
    {"frame-after", 16,
     "a frame whose length rules and CRC agree starts right after it: by chance 1 time in "
     "65,536"},
    {"copy-after", 16,
     "its exact copy right after it, as FC08's echo follows its query: four bytes or more the "
     "same by chance, weighed as a CRC"},
    {"glitch-then-frame", 8,
     "a turnaround's 0x00 or 0xFF right after it, then a silence or a good frame: the weaker "
     "of the two, the silence's"},
    {"predicted-bytes", 16,
     "every byte of the span, its CRC's too, is the one the pending request tells its answer "
     "has there (an echo repeats the request): four bytes or more, by chance 1 time in 65,536 "
     "at least"},
    {"vendor-code", 2,
     "a function code no public function has, or an exception code the standard does not name: "
     "junk's codes are such 5 times in 6, and a bus carries a device's own codes seldom: taken "
     "as 1 in 4"},
    {"predicted-byte", 1,
     "the pending request tells the answer's byte here, and it is this one; a glitch is this "
     "value too about 1 time in 2"},
    {"broken-off-copy", 16,
     "the bytes before it are its own first bytes, two or more: a frame broken off and sent "
     "again; by chance 1 time in 65,536 at most"},
    {"public-header", 16,
     "it begins as FC08 Return Query Data (sub-function 0000) or FC2B/0D CANopen General "
     "Reference, public functions whose length only their CRC tells: junk begins so 1 time in "
     "65,536 at most; it says where a frame starts, not where it ends"},
});

static_assert(feature_table.size() == size_t(Feature::public_header) + 1, "a row for each feature");

inline const FeatureInfo& feature_info(Feature f) {
  return feature_table[static_cast<size_t>(f)];
}

// What a reading's features weigh together.
constexpr int feature_bits(std::span<const Feature> features) {
  int sum = 0;
  for (const Feature f : features) sum += feature_table[static_cast<size_t>(f)].bits;
  return sum;
}

// Features as bits of a mask: the ones a row needs, and the ones found to hold for a span.
class FeatureSet {
 public:
  constexpr FeatureSet() = default;
  constexpr FeatureSet(std::initializer_list<Feature> features) {
    for (const Feature f : features) add(f);
  }
  // Adds `feature` where it holds; whether it does, so that a row stops at the first that fails.
  constexpr bool add(Feature feature, bool holds = true) {
    if (holds) mask_ |= bit(feature);
    return holds;
  }
  constexpr bool has(Feature feature) const { return (mask_ & bit(feature)) != 0; }
  constexpr bool contains(FeatureSet other) const { return (mask_ & other.mask_) == other.mask_; }
  constexpr bool operator==(const FeatureSet&) const = default;
  constexpr uint32_t mask() const { return mask_; }
  static constexpr FeatureSet of_mask(uint32_t mask) {
    FeatureSet set;
    set.mask_ = mask;
    return set;
  }

 private:
  static constexpr uint32_t bit(Feature f) { return uint32_t{1} << static_cast<unsigned>(f); }
  uint32_t mask_ = 0;
};
static_assert(size_t(Feature::public_header) < 31,
              "a feature set holds every feature, and a row's one bit more");

enum class Evidence : uint8_t {
  length_and_crc,
  no_good_end,
  more_bytes_needed,
  good_frame_before_silence,
  broke_off_at_silence,
  answer_read_as_request,
  request_inside_awaited_answer,
  unawaited_answer_inside_awaited_answer,
  predicted_inside_awaited_answer,
  vendor_frame_inside_awaited_answer,
  retry_and_glitch,
  retry_read_as_answer,
  answer_copying_request,
  answer_cut_before_request,
  swallows_known_frame,
  swallows_exchange,
  resent_inside,
  swallows_request,  // last: evidence_table asserts a row for each
};

struct EvidenceInfo {
  std::string_view name;
  std::string_view why;
  std::array<Feature, 3> features{};
  size_t feature_count = 0;
  // A feature the row's reading of the bytes needs and the span's does not: it counts for the
  // span, and the row weighs that much less.
  std::optional<Feature> for_span = std::nullopt;

  constexpr int bits() const;
  // What must hold for the row's reading of the bytes: all its features.
  constexpr FeatureSet needs() const {
    FeatureSet set;
    for (size_t i = 0; i < feature_count; ++i) set.add(features[i]);
    return set;
  }
};

// The bits each feature weighs: the feature table's, unless a framer is given others (what a
// weight decides, tested by changing it). Every verdict the framer draws from a row is drawn
// from these.
struct FeatureWeights {
  std::array<int8_t, size_t(Feature::public_header) + 1> bits{};

  constexpr int of(Feature f) const { return bits[static_cast<size_t>(f)]; }
  // A row's weight: its features', less the one its reading needs and the span's does not.
  constexpr int of(const EvidenceInfo& row) const {
    int sum = row.for_span ? -of(*row.for_span) : 0;
    for (size_t i = 0; i < row.feature_count; ++i) sum += of(row.features[i]);
    return sum;
  }
  // What a span whose length rules and CRC agree scores for itself: its CRC.
  constexpr int span() const { return of(Feature::crc_holds); }
  constexpr FeatureWeights with(Feature f, int weight) const {
    FeatureWeights changed = *this;
    changed.bits[static_cast<size_t>(f)] = static_cast<int8_t>(weight);
    return changed;
  }
};

inline constexpr FeatureWeights table_weights = [] {
  FeatureWeights weights;
  for (size_t i = 0; i < feature_table.size(); ++i)
    weights.bits[i] = static_cast<int8_t>(feature_table[i].bits);
  return weights;
}();

constexpr int EvidenceInfo::bits() const {
  return table_weights.of(*this);
}

inline constexpr auto evidence_table = std::to_array<EvidenceInfo>({
    {"length-and-crc",
     "its function code's length rules and its CRC agree on where it ends",
     {Feature::crc_holds},
     1},
    {"no-good-end",
     "neither its function code's length rules nor a CRC search give it an end where its CRC "
     "holds"},
    {"more-bytes-needed", "its length rules need bytes that have not come yet"},
    {"good-frame-before-silence",
     "a silence falls inside it, and the bytes before the silence are a frame with a good CRC "
     "of their own (a 0x00 after a frame keeps a CRC good)",
     {Feature::another_crc, Feature::silence_inside},
     2},
    {"broke-off-at-silence",
     "a silence falls inside it and a good frame starts right after it, or after its driver's "
     "glitch: it broke off there",
     {Feature::another_crc, Feature::silence_inside},
     2},
    {"answer-read-as-request",
     "these are the first bytes after the request, beginning as the awaited answer, read as a "
     "request the standard does not allow, or a driver's 0x00 or 0xFF glitch and that answer "
     "read as a request; too soon for the master's next one",
     {Feature::awaited_header, Feature::too_soon_for_retry},
     2},
    {"request-inside-awaited-answer",
     "a request inside the span the awaited answer's structure claims, with no answer of its "
     "own after it: a collision's junk whose CRC held by chance",
     {Feature::awaited_header, Feature::no_answer_after},
     2},
    {"unawaited-answer-inside-awaited-answer",
     "an answer nobody awaits inside the span the awaited answer's structure claims, with no "
     "request of its own right before it: a collision's junk whose CRC held by chance; or one "
     "from the answering driver's glitch over the awaited answer's header (a 0xFF read as "
     "station 255)",
     {Feature::awaited_header, Feature::unexpected_sender},
     2},
    {"predicted-inside-awaited-answer",
     "inside the span the awaited answer claims, every byte of it is the one the pending "
     "request tells the answer has there (an echo's): its CRC holds because the request's "
     "bytes do; they are the answer's, not a frame of their own",
     {Feature::awaited_header, Feature::predicted_bytes},
     2},
    {"vendor-frame-inside-awaited-answer",
     "a start with a code a bus seldom carries inside the span the awaited answer's structure "
     "claims: a collision's junk; it outweighs any CRC, so its end is not sought",
     {Feature::awaited_header, Feature::vendor_code},
     2},
    {"retry-and-glitch",
     "on a bus of 0x00 glitches, a copy of the pending request and a glitch read as one byte "
     "more, late enough for the master's retry",
     {Feature::another_crc, Feature::glitch_odds},
     2},
    {"retry-read-as-answer",
     "the pending request again, byte for byte and late enough for its retry, starts an answer "
     "that ends elsewhere: shorter (the copy's CRC ends in 0x00s, which keep a CRC good) or "
     "longer (its CRC holds by chance), where a frame, a silence or the answer's header follows "
     "the copy (else the copy would leave junk, which weighs as much)",
     {Feature::another_crc, Feature::request_again},
     2},
    {"answer-copying-request",
     "a copy of the pending request too soon for a retry, where the awaited answer is longer: "
     "that answer, cut or talked over",
     {Feature::awaited_header, Feature::too_soon_for_retry},
     2},
    {"answer-cut-before-request",
     "the awaited answer cut short, the next request starting inside the span its structure "
     "claims (most often repeating its missing CRC) and running past it, nothing after it",
     {Feature::another_crc, Feature::leaves_junk},
     2},
    {"swallows-known-frame",
     "a reserved address or an answer nobody awaits would swallow a frame whose length rules "
     "and CRC agree, which leaves the bytes before it to junk",
     {Feature::another_crc, Feature::bus_code, Feature::unexpected_sender},
     3,
     Feature::leaves_junk},
    {"swallows-exchange",
     "its CRC holds by chance across a whole exchange: a request and its answer inside it, junk "
     "after it",
     {Feature::another_crc, Feature::answer_after, Feature::leaves_junk},
     3},
    {"resent-inside",
     "a request that broke off, sent again at once: inside the span a request whose length rules "
     "and CRC agree starts and runs past its end, and the span's bytes before it are its own "
     "first bytes; the span's CRC held by chance across the two (most often the broken-off "
     "request's missing last CRC byte is the slave address the request sent again begins with)",
     {Feature::another_crc, Feature::broken_off_copy},
     2},
    {"swallows-request",
     "its CRC holds across a frame cut short and a whole request after it (the cut frame's "
     "bytes took the CRC back to its start value, the request's bytes did the rest), and a "
     "frame of the request's slave and function code comes next: its answer, or its retry",
     {Feature::another_crc, Feature::answer_after},
     2},
});

static_assert(evidence_table.size() == size_t(Evidence::swallows_request) + 1,
              "a row for each piece of evidence");

constexpr const EvidenceInfo& evidence_info(Evidence e) {
  return evidence_table[static_cast<size_t>(e)];
}

template <Evidence e>
inline constexpr int row_bits = evidence_table[static_cast<size_t>(e)].bits();

// What a span whose length rules and CRC agree scores for itself: its CRC.
inline constexpr int span_bits = evidence_table[size_t(Evidence::length_and_crc)].bits();

// Each row alone outweighs the CRC: the first that holds refutes the span, and a refuted span's
// score is its CRC less that one row (FramingStep::score). The framer sums the rows that hold
// (RtuReadings::Weight), so a lighter row would need another beside it; this says there is none.
constexpr bool every_row_outweighs_the_crc() {
  for (size_t i = size_t(Evidence::good_frame_before_silence); i < evidence_table.size(); ++i)
    if (evidence_table[i].bits() <= span_bits) return false;
  return true;
}
static_assert(every_row_outweighs_the_crc());

// A reading's runner-up, where both pass every check: a frame's end one byte longer (the 0x00
// after it the frame's own) or shorter (its last 0x00 the next driver's glitch), a damaged
// answer's last byte its own or a glitch, a copy of the pending request its echo or the
// master's retry. What the bytes and their times say against the runner-up is weighed in bits
// from the feature table; below `decisive_bits` it stands, and the record is marked as
// ambiguous (`ambiguous-end`, `ambiguous-echo`). The bus's rates (its glitch odds) rank the
// two readings, but they are a habit of the bus, not evidence on these bytes: they pick the
// winner and never count here.
inline constexpr int decisive_bits = 4;  // 1 in 16: what a bus does rarely, but does

enum class RunnerUp : uint8_t { none, longer, shorter, keeps_byte, glitch_byte, retry, echo };
template <>
struct EnumNames<RunnerUp> {
  static constexpr std::array<std::string_view, 7> names{
      "none",
      "the same frame one byte longer, the 0x00 after it its own",
      "the same frame one byte shorter, its last 0x00 the next driver's glitch",
      "the answer one byte longer, its last byte its own",
      "the answer one byte shorter, its last byte the next driver's glitch",
      "the master's retry",
      "the slave's echo"};
};

struct Margin {
  RunnerUp runner_up = RunnerUp::none;
  int bits = 0;                                // what tells against the runner-up
  std::optional<Feature> told = std::nullopt;  // the first feature that did

  // Adds `feature` where `holds`; whether the runner-up is ruled out now.
  bool tell(Feature feature, bool holds) {
    if (holds) {
      if (!told) told = feature;
      bits += feature_info(feature).bits;
    }
    return decided();
  }
  bool decided() const { return bits >= decisive_bits; }
  bool stands() const { return runner_up != RunnerUp::none && !decided(); }
};

// Every feature that tells a runner-up apart decides alone: one is enough to stop weighing.
constexpr bool every_tell_decides() {
  for (const Feature f : {Feature::silence_inside, Feature::too_soon_for_retry,
                          Feature::silence_after, Feature::sent_straight_on, Feature::second_glitch,
                          Feature::byte_ruled_out, Feature::late_as_a_retry})
    if (feature_table[size_t(f)].bits < decisive_bits) return false;
  return true;
}
static_assert(every_tell_decides());

template <>
struct EnumNames<GlitchHabit> {
  static constexpr std::array<std::string_view, 3> names{
      "the bus is quiet: 128 frames or more, with at most 1 glitch in 128",
      "too few frames to know the bus's glitches: none yet, in fewer than 128",
      "the bus's glitches are likelier than a byte by chance: more than 1 frame in 128 has one, "
      "where a byte is a 0x00 or 0xFF 2 times in 256"};
};

// A lone 0x00 or 0xFF at an edge of a piece (bytes no reading holds, up to the next good frame
// or silence) reads two ways: the piece's own byte, or a driver's glitch apart from it, the
// answering slave's right before its answer or the next sender's right after it (a driver
// turning on puts one on the line). Each reading has the features that hold for it, and the one
// with more bits wins. Where they tie, the bus's habit ranks them (GlitchOdds): a bus that shows
// glitches more often than a byte is one by chance takes the glitch, any other the byte. The
// habit is of the bus, not of these bytes, so it never counts in the margin: below
// decisive_bits the runner-up stands (`ambiguous-end`). Only a bus known to be quiet (128 frames
// or more, at most 1 glitch in 128) says a byte nothing speaks for is no glitch: there the glitch
// is no runner-up.
enum class EdgeSide : uint8_t { first, last };

struct EdgeByte {
  EdgeSide side = EdgeSide::last;
  uint64_t offset = 0;  // the byte's place in the channel's stream
  uint8_t value = 0;
  GlitchHabit habit = GlitchHabit::unknown;
  std::array<Feature, 4> for_glitch{};  // a reading has four features at most
  std::array<Feature, 4> for_byte{};
  uint8_t glitch_features = 0;
  uint8_t byte_features = 0;

  // Counts `feature` for the glitch (`glitch`) or for the byte, where it holds.
  void weigh(Feature feature, bool holds, bool glitch) {
    if (!holds) return;
    if (glitch)
      for_glitch[glitch_features++] = feature;
    else
      for_byte[byte_features++] = feature;
  }
  static int bits(const std::array<Feature, 4>& features, uint8_t count) {
    return feature_bits(std::span(features).first(count));
  }
  int glitch_bits() const { return bits(for_glitch, glitch_features); }
  int byte_bits() const { return bits(for_byte, byte_features); }
  // Whether the byte is the glitch, apart from the piece.
  bool glitch() const {
    const int lead = glitch_bits() - byte_bits();
    return lead > 0 || (lead == 0 && habit == GlitchHabit::glitchy);
  }
  // The winner against the runner-up: by how many bits, and the first feature that tells.
  Margin margin() const {
    const bool glitch_won = glitch();
    if (!glitch_won && habit == GlitchHabit::quiet) return {};
    Margin margin{glitch_won ? RunnerUp::keeps_byte : RunnerUp::glitch_byte,
                  glitch_won ? glitch_bits() - byte_bits() : byte_bits() - glitch_bits()};
    if (margin.decided()) margin.told = glitch_won ? for_glitch[0] : for_byte[0];
    return margin;
  }
};

// A piece of unframed bytes whose header says a frame of exactly its length reads two ways: a
// damaged frame whose check failed, or noise. Neither has a check to go by, so only the header
// speaks: a code a bus carries for the frame (`bus-code`), a code a bus seldom carries
// (`vendor-code`) and a reserved address (`unexpected-sender`, most often a turnaround's 0xFF)
// for noise. A damaged frame keeps the bytes in its slave's picture, where a technician looks
// for them, so it stands unless noise leads by decisive_bits.
struct PieceHeader {
  uint64_t offset = 0;  // the piece's first byte in the channel's stream
  std::array<Feature, 2> for_frame{};
  std::array<Feature, 2> for_noise{};
  uint8_t frame_features = 0;
  uint8_t noise_features = 0;

  constexpr PieceHeader(uint64_t at, bool bus_code, bool reserved) : offset(at) {
    if (bus_code) for_frame[frame_features++] = Feature::bus_code;
    if (!bus_code) for_noise[noise_features++] = Feature::vendor_code;
    if (reserved) for_noise[noise_features++] = Feature::unexpected_sender;
  }
  static constexpr int bits(const std::array<Feature, 2>& features, uint8_t count) {
    return feature_bits(std::span(features).first(count));
  }
  constexpr int frame_bits() const { return bits(for_frame, frame_features); }
  constexpr int noise_bits() const { return bits(for_noise, noise_features); }
  constexpr bool noise() const { return noise_bits() - frame_bits() >= decisive_bits; }
};
// A damaged frame at any address with a code a bus carries, or with a vendor's code at a
// station's address (NTA5000 and N3 answer with such codes); noise where both speak against it.
static_assert(!PieceHeader(0, true, false).noise());
static_assert(!PieceHeader(0, true, true).noise());
static_assert(!PieceHeader(0, false, false).noise());
static_assert(PieceHeader(0, false, true).noise());

// What says where a span ends. Its function code's length rules, mostly; for a code with no
// length of its own (a vendor's, FC08 Return Query Data), a CRC search, whose hit is weak
// evidence until something confirms the end: a CRC holds at one of up to 256 ends tried, and a
// 0x00 after a frame keeps it holding.
enum class SpanEnd : uint8_t {
  length_rules,
  echo_length,
  silence_after,
  pause_after,
  frame_after,
  copy_after,
  glitch_then_frame,
  input_end,
  header_alone,  // last: span_end_table asserts a row for each
};

// A CRC search tries up to 256 ends (log2 256 = 8 bits): its hit is worth that much less than
// an end the length rules give, and stands once what follows it is evidence of as much.
inline constexpr int search_bits = 8;

struct SpanEndInfo {
  std::string_view name;
  std::string_view why;
  // The evidence that confirmed a searched end; none where no search was made, or where
  // nothing more can come to confirm it and the hit stands on its own (input-end).
  std::optional<Feature> confirmed_by = std::nullopt;
};

inline constexpr auto span_end_table = std::to_array<SpanEndInfo>({
    {"length-rules", "its function code's length rules"},
    {"echo-length", "the pending FC08 request's length: its echo is as long"},
    {"silence-after", "a CRC search, its end confirmed by a silence of t3.5 right after it",
     Feature::silence_after},
    {"pause-after",
     "a CRC search, its end confirmed by a pause over t1.5 right after it (a clock per byte): "
     "no frame goes on across one",
     Feature::pause_after},
    {"frame-after", "a CRC search, its end confirmed by a good frame starting right after it",
     Feature::frame_after},
    {"copy-after", "a CRC search, its end confirmed by its exact copy right after it (FC08's echo)",
     Feature::copy_after},
    {"glitch-then-frame",
     "a CRC search, its end confirmed by a turnaround's glitch right after it, then a silence "
     "or a good frame",
     Feature::glitch_then_frame},
    {"input-end", "a CRC search, its end where the input ends"},
    {"header-alone",
     "a CRC search with nothing after its end to confirm it: a public function whose length only "
     "its CRC tells stands on its header at the first end its CRC holds (one byte on, where a "
     "0x00 there is ruled out as a glitch), once nothing more can confirm an end",
     Feature::public_header},
});

static_assert(span_end_table.size() == size_t(SpanEnd::header_alone) + 1, "a row for each end");

inline const SpanEndInfo& span_end_info(SpanEnd e) {
  return span_end_table[static_cast<size_t>(e)];
}

// Each confirmation alone makes up for the search: the first that holds confirms the end. The
// header's is about the start, where every end shares it: an end something after it confirms
// is taken first, and the header confirms the first end only once nothing more can.
constexpr bool every_confirmation_makes_up_for_the_search() {
  for (const SpanEndInfo& end : span_end_table)
    if (end.confirmed_by && feature_table[size_t(*end.confirmed_by)].bits < search_bits)
      return false;
  return true;
}
static_assert(every_confirmation_makes_up_for_the_search());

// A span against a frame a bus carries inside it (a public function code, a standard
// exception, its length rules and CRC agreeing), which reads the span's bytes another way. The
// frame inside weighs what the row `swallows-known-frame` does: `another-crc` and
// `bus-code` for it, `leaves-junk` for the span (that reading leaves the bytes before
// the frame inside to junk), and `unexpected-sender` where the span starts at a reserved
// address or as an answer nobody awaits. The span has its CRC, less the search's tries where a
// search found its end, and `copy-after` where its exact copy follows it, which no frame inside
// explains. A silence or a frame after the span counts for neither: the frame inside and what
// follows it explain them as well. The span keeps its bytes where it scores at least as much.
constexpr int frame_inside_bits(bool unexpected, const FeatureWeights& w = table_weights) {
  return w.of(evidence_info(Evidence::swallows_known_frame)) -
         (unexpected ? 0 : w.of(Feature::unexpected_sender));
}
constexpr int span_bits_against_frame_inside(bool searched, bool copy,
                                             const FeatureWeights& w = table_weights) {
  return w.span() - (searched ? search_bits : 0) + (copy ? w.of(Feature::copy_after) : 0);
}
constexpr bool keeps_frame_inside(bool searched, bool unexpected, bool copy,
                                  const FeatureWeights& w = table_weights) {
  return span_bits_against_frame_inside(searched, copy, w) >= frame_inside_bits(unexpected, w);
}
// A frame of known length from an expected sender keeps what is inside it; one at a reserved
// address, one nobody awaits and one found by search do not; an exact copy after any of them
// keeps it.
static_assert(keeps_frame_inside(false, false, false));
static_assert(!keeps_frame_inside(false, true, false));
static_assert(!keeps_frame_inside(true, false, false));
static_assert(keeps_frame_inside(true, true, true));

// What became of one reading of the bytes at a frame's start.
// `refuted_at_start`: a row that holds whatever the span's end outweighs the most its CRC could
// say, so the end is not sought.
enum class ReadingOutcome : uint8_t { kept, refuted, refuted_at_start, waiting, no_frame };
template <>
struct EnumNames<ReadingOutcome> {
  static constexpr std::array<std::string_view, 5> names{
      "kept", "refuted", "refuted whatever its end", "waiting", "no frame"};
};

struct FramingStep {
  uint16_t channel = 0;
  uint64_t offset = 0;  // where the reading starts
  Role role = Role::request;
  uint16_t length = 0;  // the frame it found, 0 if none
  SpanEnd end = SpanEnd::length_rules;
  ReadingOutcome outcome = ReadingOutcome::no_frame;
  Evidence why = Evidence::no_good_end;
  Margin end_margin{};  // a kept frame's end against its runner-up, where it has one

  // Its score in bits against no frame at all (0): its CRC, less the row that refuted it.
  int score() const {
    if (outcome == ReadingOutcome::kept) return span_bits;
    // Refuted at its start: the most it could score, had its CRC held.
    if (outcome == ReadingOutcome::refuted || outcome == ReadingOutcome::refuted_at_start)
      return span_bits - evidence_info(why).bits();
    return 0;
  }
};

// Why the matcher gave a frame its role: the first rule of its table (Matcher::role_rules) that
// holds, or where the frame's place in an exchange decided apart from the table (a bad check in
// the answer's time, a held copy the master's next move told).
enum class RoleReason : uint8_t {
  master_channel,
  slave_channel,
  exception_bit,
  fits_request_only,
  fits_response_only,
  retry,
  another_request,
  awaited_answer,
  overdue_answer,
  interrupted_answer,
  fits_request,
  fits_neither,
  garbled_answer,
  held_copy_answer,
  chained_copy_retry,
};
template <>
struct EnumNames<RoleReason> {
  static constexpr std::array<std::string_view, 15> names{
      "it came on the master's channel of a split tap",
      "it came on the slaves' channel of a split tap",
      "its function code has the exception bit, which only an answer has",
      "its structure fits a request and no answer",
      "its structure fits an answer and no request",
      "a copy of the pending request, taken for the master's retry (below)",
      "of the pending request's slave and function, it does not fit as its answer and came past "
      "the time that answer takes: the master's next request",
      "of the pending request's slave and function, where its answer is due: that answer",
      "it answers the request that timed out last, while the master sends nothing: that slave's "
      "answer, late",
      "it answers the request another master cut in on, after that master's exchange: paired, on "
      "time",
      "it reads as a request as well as an answer, and no request awaits an answer it could be",
      "it fits neither as a request nor as an answer, and no request awaits it",
      "its check fails where the pending request's answer is due: that answer, damaged, whatever "
      "its address or function code says",
      "a copy of a request held until the master's next move, which showed the master did not "
      "wait for its answer: the answer",
      "a copy of the pending request that its slave's learned turnaround read as the echo, but "
      "the same bytes came again and the master moved on at once: those were the answer, this "
      "the master's retry"};
};

// Which request the matcher paired an answer with.
enum class PairReason : uint8_t { pending, set_aside, overdue, echo_as_retry, none };
template <>
struct EnumNames<PairReason> {
  static constexpr std::array<std::string_view, 5> names{
      "the pending request",
      "the request another master's request cut in on, set aside while that exchange ran",
      "the request that timed out last: the slave answered after the master gave up",
      "the copy before it, taken for the master's retry: a slave answers once, so the copy "
      "could not be its echo",
      "none: no request waits for an answer it could be (unsolicited)"};
};

// Told each reading the framer weighs at the start of what it emits next, and how the matcher
// judged a copy of the pending request and gave each frame its role (--explain).
class FramingObserver {
 public:
  virtual ~FramingObserver() = default;
  // The framer weighs the bytes at `offset` (again, once more of them came).
  virtual void on_start(uint16_t channel, uint64_t offset) = 0;
  virtual void on_reading(const FramingStep& step) = 0;
  // The matcher's judgement of a frame that copies the pending request, at `offset`: the
  // slave's echo or the master's retry, and what told the runner-up apart.
  virtual void on_copy(uint16_t /*channel*/, uint64_t /*offset*/, const Margin& /*margin*/) {}
  // The matcher's reason for the role of the frame at `offset`.
  virtual void on_role(uint16_t /*channel*/, uint64_t /*offset*/, Role /*role*/,
                       RoleReason /*why*/) {}
  // The request an answer at `offset` was paired with, as the matcher chose it.
  virtual void on_pair(uint16_t /*channel*/, uint64_t /*offset*/, PairReason /*how*/) {}
  // How a 0x00 or 0xFF at an edge of unframed bytes was read: their own, or a glitch.
  virtual void on_edge_byte(uint16_t /*channel*/, const EdgeByte& /*edge*/) {}
  // How a piece whose header says a frame of its length was read: a damaged frame, or noise.
  virtual void on_piece_header(uint16_t /*channel*/, const PieceHeader& /*header*/) {}
};

}  // namespace modtap
