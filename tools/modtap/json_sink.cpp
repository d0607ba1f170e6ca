#include "tools/modtap/json_sink.hpp"

#include "decoder/pdu_fields.hpp"
#include "tools/modtap/render.hpp"

namespace modtap::tools {

using namespace decoder;

JsonSink::JsonSink(Output& out, const std::vector<ChannelInfo>& channels)
    : out_(out), channels_(channels) {}

void JsonSink::channel(uint16_t id) {
  out_.print(FMT_COMPILE(",\"channel\":"));
  append_json_string(out_.buffer(), id < channels_.size() ? channels_[id].name : "");
}

void JsonSink::on_frame(const Frame& frame) {
  auto& buf = out_.buffer();
  out_.print(FMT_COMPILE("{{\"type\":\"frame\",\"index\":{},\"t_ns\":{},\"end_ns\":{}"),
             frame.index, frame.t_ns, frame.end_ns);
  channel(frame.channel);
  out_.print(
      FMT_COMPILE(
          ",\"offset\":{},\"mode\":\"{}\",\"role\":\"{}\",\"slave\":{},\"fc\":{},\"function\":"),
      frame.offset, to_string(frame.mode), to_string(frame.role), frame.slave(),
      frame.function() & 0x7F);
  out_.print(FMT_COMPILE("\"{}\""), FunctionLabel{frame.function()});
  out_.print(FMT_COMPILE(",\"raw\":\""));
  append_hex(buf, frame.raw, false);
  out_.print(FMT_COMPILE("\",\"check\":\"{}\",\"check_value\":{}"), frame.check_ok ? "ok" : "bad",
             frame.wire_check());
  if (frame.damage == Damage::cut) {
    out_.print(FMT_COMPILE(",\"expected_check\":null"));
  } else {
    out_.print(FMT_COMPILE(",\"expected_check\":{}"), frame.expected_check);
  }
  if (const char* damage = to_string(frame.damage)) {
    out_.print(FMT_COMPILE(",\"damage\":\"{}\""), damage);
  } else {
    out_.print(FMT_COMPILE(",\"damage\":null"));
  }
  if (frame.is_exception() && frame.adu.size() > 2) {
    out_.print(FMT_COMPILE(",\"exception\":{}"), frame.adu[2]);
  } else {
    out_.print(FMT_COMPILE(",\"exception\":null"));
  }
  if (frame.request) {
    out_.print(FMT_COMPILE(",\"request\":{}"), *frame.request);
  } else {
    out_.print(FMT_COMPILE(",\"request\":null"));
  }
  if (frame.latency_ns) {
    out_.print(FMT_COMPILE(",\"latency_us\":{}"), Fixed{*frame.latency_ns, 3, 3});
  } else {
    out_.print(FMT_COMPILE(",\"latency_us\":null"));
  }
  out_.print(FMT_COMPILE(",\"findings\":["));
  bool first = finding_names(frame.findings);
  if (frame.meaning) {
    for (const RuleFinding& finding : frame.meaning->findings) {
      out_.print(FMT_COMPILE("{}\"{}\""), first ? "" : ",", to_string(finding.kind));
      first = false;
    }
  }
  out_.print(FMT_COMPILE("]"));
  if (frame.meaning) meaning(*frame.meaning);
  const DecodedPdu& pdu = fields_of(frame, decoded_);
  for (size_t at = 0; at < pdu.fields.size();) {
    buf.push_back(',');
    at = append_json_field(buf, pdu, at);
  }
  if (pdu.truncated) out_.print(FMT_COMPILE(",\"truncated\":true"));
  out_.print(FMT_COMPILE("}}\n"));
  out_.end_record();
}

// The names of the findings in `bits`, comma-separated; true if there were none.
bool JsonSink::finding_names(uint32_t bits) {
  bool none = true;
  for_each_frame_finding(bits, [&](size_t slot) {
    out_.print(FMT_COMPILE("{}\"{}\""), none ? "" : ",", frame_findings()[slot].name);
    none = false;
  });
  return none;
}

// "model", "registers" and "notes": each model finding's kind, address and explanation.
void JsonSink::meaning(const Meaning& meaning) {
  auto& buf = out_.buffer();
  out_.print(FMT_COMPILE(",\"model\":"));
  append_json_string(buf, meaning.model->name);
  out_.print(FMT_COMPILE(",\"registers\":["));
  for (size_t i = 0; i < meaning.registers.size(); ++i) {
    if (i) out_.print(FMT_COMPILE(","));
    append_register_json(buf, meaning.registers[i]);
  }
  out_.print(FMT_COMPILE("],\"notes\":["));
  for (size_t i = 0; i < meaning.findings.size(); ++i) {
    const RuleFinding& finding = meaning.findings[i];
    out_.print(FMT_COMPILE("{}{{\"finding\":\"{}\",\"addr\":"), i ? "," : "",
               to_string(finding.kind));
    if (finding.address) {
      out_.print(FMT_COMPILE("{}"), *finding.address);
    } else {
      out_.print(FMT_COMPILE("null"));
    }
    out_.print(FMT_COMPILE(",\"text\":"));
    append_json_string(buf, finding.text);
    out_.print(FMT_COMPILE("}}"));
  }
  out_.print(FMT_COMPILE("]"));
}

void JsonSink::on_noise(const Noise& noise) {
  out_.print(FMT_COMPILE("{{\"type\":\"noise\",\"index\":{},\"t_ns\":{},\"end_ns\":{}"),
             noise.index, noise.t_ns, noise.end_ns);
  channel(noise.channel);
  out_.print(FMT_COMPILE(",\"offset\":{},\"mode\":\"{}\",\"raw\":\""), noise.offset,
             to_string(noise.mode));
  append_hex(out_.buffer(), noise.raw, false);
  out_.print(FMT_COMPILE("\",\"reason\":\"{}\""), to_string(noise.reason));
  if (noise.request) {
    out_.print(FMT_COMPILE(",\"request\":{}"), *noise.request);
  } else {
    out_.print(FMT_COMPILE(",\"request\":null"));
  }
  out_.print(FMT_COMPILE(",\"findings\":["));
  finding_names(noise.findings);
  out_.print(FMT_COMPILE("]}}\n"));
  out_.end_record();
}

void JsonSink::on_timeout(const Timeout& t) {
  out_.print(FMT_COMPILE("{{\"type\":\"{}\",\"request\":{},\"t_ns\":{}"),
             t.timed_out() ? "timeout" : "unanswered", t.request, t.t_ns);
  channel(t.channel);
  out_.print(FMT_COMPILE(",\"slave\":{},\"fc\":{},\"waited_us\":{},\"reason\":\"{}\"}}\n"), t.slave,
             t.function, Fixed{t.waited_ns, 3, 3}, to_string(t.reason));
  out_.end_record();
}

}  // namespace modtap::tools
