// -Y: a display filter over the names modtap's outputs use, so that what a user reads in the
// JSON is what they filter on. `slave == 3 && fc == 6`, `latency_us > 50000`, `finding`,
// `retry || fast-turnaround`, `register.name == "fault"`, `frequency_command > 50`,
// `address == 2502H`, `role == request`, `!(check == ok)`.
//
// Names: every field of the field registry (record and PDU), `finding` (any finding, or one by
// name), every finding's own name (present when the record has it), `register.name`,
// `register.addr`, `register.value`, `register.raw`, `register.unit`, `register.text`, and the
// register names of the loaded device models (the register's scaled value). A name with
// several values (a read's `values`, a frame's findings) matches when any of them does;
// `!=` is the negation of `==`. A name with no value (JSON null, or absent) is absent.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "decoder/protocol/pdu_fields.hpp"
#include "decoder/protocol/record_sink.hpp"
#include "decoder/protocol/register_numbering.hpp"

namespace modtap {

// A filter that does not parse: `column` counts from 1, as an editor does.
class FilterError : public std::runtime_error {
 public:
  FilterError(size_t column, const std::string& message);
  size_t column() const { return column_; }

 private:
  size_t column_;
};

struct FilterNode;

class DisplayFilter {
 public:
  // `is_register_name` says whether a loaded model names a register so (may be empty). A
  // decimal number compared with an address is read in `base`, as text prints addresses
  // (--register-base: 1-based, or 4xxxx's 49475). Throws FilterError.
  DisplayFilter(std::string_view text, std::function<bool(std::string_view)> is_register_name,
                RegisterBase base = RegisterBase::hex);
  ~DisplayFilter();
  DisplayFilter(DisplayFilter&&) noexcept;

  // Names the channels as the outputs do, for `channel == "master"`.
  void set_channel_names(std::vector<std::string> names) { channels_ = std::move(names); }

  // `pdu` is the frame's decoded PDU; the model's reading comes with the frame.
  bool matches(const Frame& frame, const DecodedPdu& pdu) const;
  bool matches(const Noise& noise) const;
  bool matches(const Timeout& timeout) const;

 private:
  std::vector<FilterNode> nodes_;  // nodes_[0] is the root
  std::vector<std::string> channels_;
  mutable std::string scratch_;  // hex and labels, composed per value without allocating anew
};

// Passes on the records a filter matches, each frame with its decoded PDU attached, so the
// sinks behind it do not decode again.
class FilterStage final : public RecordSink {
 public:
  FilterStage(DisplayFilter filter, RecordSink& next);
  void on_frame(const Frame& frame) override;
  void on_noise(const Noise& noise) override;
  void on_timeout(const Timeout& timeout) override;

 private:
  DisplayFilter filter_;
  RecordSink& next_;
  DecodedPdu decoded_;
};

}  // namespace modtap
