// JSON Lines: one object per record. docs/output.md lists every key.
#pragma once

#include <string>
#include <vector>

#include <fmt/format.h>

#include "decoder/models/register_meaning.hpp"
#include "decoder/protocol/buffer_put.hpp"
#include "decoder/protocol/pdu_fields.hpp"
#include "decoder/protocol/record_sink.hpp"
#include "output/output.hpp"

namespace modtap::output {

class JsonSink final : public RecordSink {
 public:
  JsonSink(Output& out, const std::vector<ChannelInfo>& channels);

  void on_frame(const Frame& frame) override;
  void on_noise(const Noise& noise) override;
  void on_timeout(const Timeout& timeout) override;

 private:
  class Fields;
  void channel(uint16_t id);
  void model_key(std::string_view name);

  Output& out_;
  const std::vector<ChannelInfo>& channels_;  // may grow and be renamed as it goes
  // Each channel's `,"channel":"NAME"` as last made, and the name it was made from.
  struct ChannelKey {
    std::string name;
    fmt::memory_buffer json;
  };
  std::vector<ChannelKey> channel_keys_;
  // `,"model":"NAME"` as last made, and the name it was made from (a model's name stays put).
  std::string_view model_name_;
  fmt::memory_buffer model_key_;
  NanosecondsText time_text_;
  DecodedPdu decoded_;  // the frame's fields, its capacity kept from frame to frame
};

}  // namespace modtap::output
