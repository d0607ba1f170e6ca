#include "tools/modtap/json_sink.hpp"

#include "decoder/pdu_fields.hpp"
#include "tools/modtap/render.hpp"

namespace modtap::tools {

using namespace decoder;

JsonSink::JsonSink(Output& out, const std::vector<ChannelInfo>& channels)
    : out_(out), channels_(channels) {}

void JsonSink::channel(uint16_t id) {
  out_.print(",\"channel\":");
  append_json_string(out_.buffer(), id < channels_.size() ? channels_[id].name : "");
}

void JsonSink::on_frame(const Frame& frame) {
  auto& buf = out_.buffer();
  out_.print("{{\"type\":\"frame\",\"index\":{},\"t_ns\":{},\"end_ns\":{}", frame.index, frame.t_ns,
             frame.end_ns);
  channel(frame.channel);
  out_.print(",\"offset\":{},\"mode\":\"{}\",\"role\":\"{}\",\"slave\":{},\"fc\":{},\"function\":",
             frame.offset, to_string(frame.mode), to_string(frame.role), frame.slave(),
             frame.function() & 0x7F);
  out_.print("\"{}\"", FunctionLabel{frame.function()});
  out_.print(",\"raw\":\"");
  append_hex(buf, frame.raw, false);
  out_.print("\",\"check\":\"{}\",\"check_value\":{}", frame.check_ok ? "ok" : "bad",
             frame.wire_check());
  if (frame.damage == Damage::cut) {
    out_.print(",\"expected_check\":null");
  } else {
    out_.print(",\"expected_check\":{}", frame.expected_check);
  }
  if (const char* damage = to_string(frame.damage)) {
    out_.print(",\"damage\":\"{}\"", damage);
  } else {
    out_.print(",\"damage\":null");
  }
  if (frame.is_exception() && frame.adu.size() > 2) {
    out_.print(",\"exception\":{}", frame.adu[2]);
  } else {
    out_.print(",\"exception\":null");
  }
  if (frame.request) {
    out_.print(",\"request\":{}", *frame.request);
  } else {
    out_.print(",\"request\":null");
  }
  if (frame.latency_ns) {
    out_.print(",\"latency_us\":{:.3f}", static_cast<double>(*frame.latency_ns) / 1e3);
  } else {
    out_.print(",\"latency_us\":null");
  }
  out_.print(",\"findings\":[");
  bool first = true;
  for (const auto& [bit, name] : finding_names()) {
    if (!(frame.findings & bit)) continue;
    out_.print("{}\"{}\"", first ? "" : ",", name);
    first = false;
  }
  if (frame.meaning) {
    for (const RuleFinding& finding : frame.meaning->findings) {
      out_.print("{}\"{}\"", first ? "" : ",", to_string(finding.kind));
      first = false;
    }
  }
  out_.print("]");
  if (frame.meaning) meaning(*frame.meaning);
  decode_pdu(frame.role, frame.pdu(), frame.request_pdu, decoded_);
  for (size_t at = 0; at < decoded_.fields.size();) {
    buf.push_back(',');
    at = append_json_field(buf, decoded_, at);
  }
  if (decoded_.truncated) out_.print(",\"truncated\":true");
  out_.print("}}\n");
  out_.end_record();
}

// "model", "registers" and "notes": each model finding's kind, address and explanation.
void JsonSink::meaning(const Meaning& meaning) {
  auto& buf = out_.buffer();
  out_.print(",\"model\":");
  append_json_string(buf, meaning.model->name);
  out_.print(",\"registers\":[");
  for (size_t i = 0; i < meaning.registers.size(); ++i) {
    if (i) out_.print(",");
    append_register_json(buf, meaning.registers[i]);
  }
  out_.print("],\"notes\":[");
  for (size_t i = 0; i < meaning.findings.size(); ++i) {
    const RuleFinding& finding = meaning.findings[i];
    out_.print("{}{{\"finding\":\"{}\",\"addr\":", i ? "," : "", to_string(finding.kind));
    if (finding.address) {
      out_.print("{}", *finding.address);
    } else {
      out_.print("null");
    }
    out_.print(",\"text\":");
    append_json_string(buf, finding.text);
    out_.print("}}");
  }
  out_.print("]");
}

void JsonSink::on_noise(const Noise& noise) {
  out_.print("{{\"type\":\"noise\",\"index\":{},\"t_ns\":{},\"end_ns\":{}", noise.index, noise.t_ns,
             noise.end_ns);
  channel(noise.channel);
  out_.print(",\"offset\":{},\"mode\":\"{}\",\"raw\":\"", noise.offset, to_string(noise.mode));
  append_hex(out_.buffer(), noise.raw, false);
  out_.print("\",\"reason\":\"{}\"}}\n", to_string(noise.reason));
  out_.end_record();
}

void JsonSink::on_timeout(const Timeout& t) {
  out_.print("{{\"type\":\"{}\",\"request\":{},\"t_ns\":{}",
             t.timed_out() ? "timeout" : "unanswered", t.request, t.t_ns);
  channel(t.channel);
  out_.print(",\"slave\":{},\"fc\":{},\"waited_us\":{:.3f},\"reason\":\"{}\"}}\n", t.slave,
             t.function, static_cast<double>(t.waited_ns) / 1e3, to_string(t.reason));
  out_.end_record();
}

}  // namespace modtap::tools
