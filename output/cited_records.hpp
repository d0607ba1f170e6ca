// The lines of the records a problem may cite, as `modtap -r` prints them: the report shows
// them under "The records behind the problems". It passes every record to the problems'
// evidence and renders only those the evidence keeps as the first of some trouble, each after
// the request it answers or times out (kept as bytes until the next, and shown without the
// model's names), so a long capture costs a few hundred lines.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "decoder/analysis/bus_problems.hpp"
#include "decoder/protocol/record_sink.hpp"
#include "decoder/protocol/register_numbering.hpp"
#include "output/output.hpp"
#include "output/text_sink.hpp"

namespace modtap::output {

class CitedRecords final : public RecordSink {
 public:
  static constexpr size_t max_kept = 1024;

  // `clock`: every record's, kept before a filter; none: this keeps the clock of the records
  // it is given, all of them.
  CitedRecords(ProblemEvidence& evidence, const std::vector<ChannelInfo>& channels,
               RegisterBase base, const RecordClock* clock);

  void on_frame(const Frame& frame) override;
  void on_noise(const Noise& noise) override;
  void on_timeout(const Timeout& timeout) override;

  // By the index a problem cites: the record's line, after its request's (a time-out's under
  // its request's index).
  std::map<uint64_t, std::string> lines() const;

 private:
  template <typename Render>
  void keep(std::optional<uint64_t> request, Render render);
  void remember_request(const Frame& frame);

  ProblemEvidence& evidence_;
  SinkClock clock_;
  Output text_out_;
  TextSink text_;
  std::map<uint64_t, std::string> lines_;
  // The lines of time-outs that began a silence still open or counted (the evidence's may_cite).
  std::map<uint64_t, std::string> may_cite_;
  Frame request_;  // the last request, its spans into the bytes below
  std::vector<uint8_t> request_raw_, request_adu_;
};

}  // namespace modtap::output
