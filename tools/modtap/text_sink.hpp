// One line per record, as tshark prints packets; -V adds each frame's field tree.
#pragma once

#include <optional>
#include <vector>

#include "decoder/record_sink.hpp"
#include "decoder/pdu_fields.hpp"
#include "decoder/register_meaning.hpp"
#include "tools/modtap/output.hpp"
#include "tools/modtap/render.hpp"

namespace modtap::tools {

class TextSink final : public decoder::RecordSink {
 public:
  TextSink(Output& out, const std::vector<decoder::ChannelInfo>& channels, bool verbose);

  void on_frame(const decoder::Frame& frame) override;
  void on_noise(const decoder::Noise& noise) override;
  void on_timeout(const decoder::Timeout& timeout) override;

 private:
  Fixed seconds(int64_t t_ns);
  void channel_column(uint16_t channel);
  void tree(const decoder::Frame& frame);
  void registers_line(const decoder::Meaning& meaning);
  void registers_tree(const decoder::Meaning& meaning);

  Output& out_;
  const std::vector<decoder::ChannelInfo>& channels_;
  bool verbose_;
  std::optional<int64_t> first_ns_;
  decoder::DecodedPdu decoded_;  // the frame's fields, its capacity kept from frame to frame
};

}  // namespace modtap::tools
