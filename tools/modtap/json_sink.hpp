// JSON Lines: one object per record. docs/output.md lists every key.
#pragma once

#include <string>
#include <vector>

#include <fmt/format.h>

#include "decoder/buffer_put.hpp"
#include "decoder/pdu_fields.hpp"
#include "decoder/record_sink.hpp"
#include "decoder/register_meaning.hpp"
#include "tools/modtap/output.hpp"

namespace modtap::tools {

class JsonSink final : public decoder::RecordSink {
 public:
  JsonSink(Output& out, const std::vector<decoder::ChannelInfo>& channels);

  void on_frame(const decoder::Frame& frame) override;
  void on_noise(const decoder::Noise& noise) override;
  void on_timeout(const decoder::Timeout& timeout) override;

 private:
  void channel(uint16_t id);
  void meaning(const decoder::Meaning& meaning);
  bool finding_names(uint32_t bits);

  Output& out_;
  const std::vector<decoder::ChannelInfo>& channels_;  // may grow and be renamed as it goes
  // Each channel's `,"channel":"NAME"` as last made, and the name it was made from.
  struct ChannelKey {
    std::string name;
    fmt::memory_buffer json;
  };
  std::vector<ChannelKey> channel_keys_;
  // `,"model":"NAME"` of the model it was last made for (models do not change in a run).
  const decoder::DeviceModel* model_key_for_ = nullptr;
  fmt::memory_buffer model_key_;
  NanosecondsText time_text_;
  decoder::DecodedPdu decoded_;  // the frame's fields, its capacity kept from frame to frame
};

}  // namespace modtap::tools
