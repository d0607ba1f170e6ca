// --explain INDEX: one record as the text output prints it, then why the RTU framer cut there:
// each reading it weighed at the record's first byte (request, response), what became of it, its
// score in bits with the features of the row that refuted it
// (decoder/protocol/framing_evidence.hpp), and the winner's margin over the runner-up; for unframed
// bytes, the spans inside them that the evidence refuted.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "decoder/protocol/framing_evidence.hpp"
#include "decoder/protocol/record_sink.hpp"
#include "output/output.hpp"
#include "output/text_sink.hpp"

namespace modtap::output {

class ExplainSink final : public RecordSink, public FramingObserver {
 public:
  ExplainSink(Output& out, const std::vector<ChannelInfo>& channels, TextOptions options,
              uint64_t index);

  void on_start(uint16_t channel, uint64_t offset) override;
  void on_reading(const FramingStep& step) override;
  void on_copy(uint16_t channel, uint64_t offset, const Margin& margin) override;
  void on_role(uint16_t channel, uint64_t offset, Role role, RoleReason why) override;
  void on_pair(uint16_t channel, uint64_t offset, PairReason how) override;
  void on_edge_byte(uint16_t channel, const EdgeByte& edge) override;
  void on_piece_header(uint16_t channel, const PieceHeader& header) override;
  void on_frame(const Frame& frame) override;
  void on_noise(const Noise& noise) override;
  void on_timeout(const Timeout& timeout) override;
  // Whether the record was in the capture: said at the end, so that a wrong index is no
  // silent empty output.
  bool found() const { return found_; }

 private:
  // A record's place in the segmentation: its bytes and what they became.
  struct Segment {
    uint64_t index = 0;
    uint16_t channel = 0;
    uint64_t offset = 0;
    size_t size = 0;
    bool noise = false;
    Role role = Role::request;
    bool check_ok = true;
    Damage damage = Damage::none;
    NoiseReason reason = NoiseReason::junk;
  };
  static Segment segment_of(const Frame& frame);
  static Segment segment_of(const Noise& noise);
  // Prints the records on either side of the one asked for, on its channel: the one before
  // with it, the one after when it comes.
  void place(const Segment& segment, bool is_picked);
  void print_segment(const Segment& segment, bool is_picked);
  void explain_frame(const Frame& frame);
  void explain_noise(const Noise& noise);
  void print_damage(const Frame& frame);
  void explain(uint16_t channel, uint64_t offset, Mode mode);
  void print_reading(const FramingStep& step);
  void print_confirmation(SpanEnd end);
  void print_end_margin(const Margin& margin);
  // A runner-up's lines: what ruled it out, or that it stands and the record says so.
  void print_runner_up(const Margin& margin, std::string_view finding);
  void print_copy(const Frame& frame);
  void print_role(const Frame& frame);
  // The 0x00s and 0xFFs at the edges of the record's bytes, each read as its own or a glitch.
  void print_edges(uint16_t channel, uint64_t offset, size_t size);
  void print_edge(const EdgeByte& edge);
  void print_two_way_reading(std::string_view reading, std::span<const Feature> features);
  // The header of the record's piece, where it spoke for noise: a damaged frame's, or noise's.
  void print_piece_header(uint16_t channel, uint64_t offset);
  void print_row(const EvidenceInfo& row, int sign);
  void print_feature(Feature feature, int sign);
  void print_margin(const std::vector<const FramingStep*>& weighed);
  static bool scored(const FramingStep& step);
  static std::string reading_name(const FramingStep& step);
  void print_weighed(const std::vector<const FramingStep*>& weighed);
  // Every record moves the time column's clock; the one asked for is shown.
  template <typename Record>
  bool picked(const Record& record) {
    clock_.see(record.t_ns);
    found_ |= record.index == index_;
    return record.index == index_;
  }

  Output& out_;
  const std::vector<ChannelInfo>& channels_;
  RecordClock clock_;
  TextSink text_;
  uint64_t index_;
  bool found_ = false;
  // The readings weighed at the starts of a channel's records still to come and the bytes
  // inside them, by start; a record is emitted right after its own. Bounded: where unframed
  // bytes run on too long, the oldest go, and `lost_through` says up to where.
  struct ChannelSteps {
    std::map<uint64_t, std::vector<FramingStep>> at;
    size_t count = 0;
    std::optional<uint64_t> lost_through;
  };
  std::map<uint16_t, ChannelSteps> steps_;
  void forget_before(ChannelSteps& channel, uint64_t offset);
  void print_inside(uint16_t channel, uint64_t offset, size_t size);
  // The matcher's judgements of the latest copies of a pending request.
  struct Copy {
    uint16_t channel;
    uint64_t offset;
    Margin margin;
  };
  std::deque<Copy> copies_;
  // The matcher's reasons for the latest frames' roles.
  struct RoleGiven {
    uint16_t channel;
    uint64_t offset;
    Role role;
    RoleReason why;
  };
  std::deque<RoleGiven> roles_;
  struct PairGiven {
    uint16_t channel;
    uint64_t offset;
    PairReason how;
  };
  std::deque<PairGiven> pairs_;
  // The latest 0x00s and 0xFFs weighed at the edges of unframed bytes.
  struct Edge {
    uint16_t channel;
    EdgeByte edge;
  };
  std::deque<Edge> edges_;
  // The latest headers of pieces weighed as a damaged frame or noise.
  struct Header {
    uint16_t channel;
    PieceHeader header;
  };
  std::deque<Header> headers_;
  std::map<uint16_t, Segment> last_on_channel_;
  std::optional<uint16_t> after_due_;  // the channel whose next record is still to show
};

}  // namespace modtap::output
