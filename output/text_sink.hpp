// One line per record, as tshark prints packets; -V adds each frame's field tree.
#pragma once

#include <optional>
#include <string_view>
#include <vector>

#include "decoder/models/register_meaning.hpp"
#include "decoder/protocol/pdu_fields.hpp"
#include "decoder/protocol/record_sink.hpp"
#include "decoder/protocol/register_numbering.hpp"
#include "output/output.hpp"
#include "output/render.hpp"

namespace modtap {
struct RecordFields;
}

namespace modtap::output {

// How the time column reads, as tshark's -t: since the capture's first record (r), the time of
// day (a), date and time (ad), since the record before, shown or not (d), since the line shown
// before (dd). Absolute times are local, as tshark's.
enum class TimeFormat : uint8_t { relative, absolute, absolute_date, delta, delta_displayed };

struct TextOptions {
  bool verbose = false;  // -V: each frame's field tree
  TimeFormat time = TimeFormat::relative;
  RegisterBase register_base = RegisterBase::hex;
  // The clock of every record, kept before a filter (ClockStage): -t r and -t d count
  // over the whole capture. None: the sink keeps its own, of the records it is given.
  const RecordClock* clock = nullptr;
};

class TextSink final : public RecordSink {
 public:
  TextSink(Output& out, const std::vector<ChannelInfo>& channels, TextOptions options = {});

  void on_frame(const Frame& frame) override;
  void on_noise(const Noise& noise) override;
  void on_timeout(const Timeout& timeout) override;

 private:
  void time_column(int64_t t_ns);
  const RecordClock& clock() const { return clock_.get(); }
  void seconds_column(int64_t ns);
  void absolute_time(int64_t t_ns);
  void channel_column(uint16_t channel);
  AddressNumbering numbering_of(const Frame& frame) const;
  void tree(const RecordFields& f, AddressNumbering numbering);
  void registers_line(const RecordFields& f);
  void registers_tree(const RecordFields& f);

  Output& out_;
  const std::vector<ChannelInfo>& channels_;
  TextOptions options_;
  SinkClock clock_;
  std::optional<int64_t> previous_shown_ns_;  // -t dd counts from here
  int64_t shown_second_ = -1;                 // the second whose date and time `shown_` holds
  KeptDecimal seconds_;                       // relative and delta times' whole seconds
  fmt::memory_buffer shown_;
  DecodedPdu decoded_;  // the frame's fields, its capacity kept from frame to frame
};

}  // namespace modtap::output

template <>
struct modtap::EnumNames<modtap::output::TimeFormat> {
  static constexpr std::array<std::string_view, 5> names{"r", "a", "ad", "d", "dd"};
};
