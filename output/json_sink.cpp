#include "output/json_sink.hpp"

#include <array>
#include <string>

#include "output/render.hpp"
#include "protocol/pdu_fields.hpp"

namespace modtap::output {

JsonSink::JsonSink(Output& out, const std::vector<ChannelInfo>& channels)
    : out_(out), channels_(channels) {}

// Escaped once per channel rather than for every record.
void JsonSink::channel(uint16_t id) {
  if (id >= channel_keys_.size()) channel_keys_.resize(id + 1u);
  ChannelKey& key = channel_keys_[id];
  const std::string& name = id < channels_.size() ? channels_[id].name : key.name;
  if (key.json.size() == 0 || key.name != name) {
    key.name = name;
    key.json.clear();
    put(key.json, ",\"channel\":");
    append_json_string(key.json, name);
  }
  put(out_.buffer(), {key.json.data(), key.json.size()});
}

namespace {

// `,"mode":"rtu","role":"request","slave":` for each mode and role, made once: one copy a line.
std::string_view mode_and_role(Mode mode, Role role) {
  static const auto pieces = [] {
    std::array<std::array<std::string, 3>, 2> made;
    for (const Mode m : {Mode::rtu, Mode::ascii})
      for (const Role r : {Role::request, Role::response, Role::unknown})
        made[static_cast<size_t>(m)][static_cast<size_t>(r)] =
            fmt::format(",\"mode\":\"{}\",\"role\":\"{}\",\"slave\":", to_string(m), to_string(r));
    return made;
  }();
  return pieces[static_cast<size_t>(mode)][static_cast<size_t>(role)];
}

// `,"fc":3,"function":"Read Holding Registers","raw":"` for each function code byte, made once.
std::string_view function_and_raw(uint8_t function) {
  static const auto pieces = texts_per_byte([](fmt::memory_buffer& piece, uint8_t fc) {
    put(piece, ",\"fc\":");
    put_uint(piece, fc & 0x7F);
    put(piece, ",\"function\":\"");
    put_function_label(piece, fc);
    put(piece, "\",\"raw\":\"");
  });
  return pieces[function];
}

}  // namespace

void JsonSink::on_frame(const Frame& frame) {
  auto& buf = out_.buffer();
  put(buf, "{\"type\":\"frame\",\"index\":");
  put_uint(buf, frame.index);
  put(buf, ",\"t_ns\":");
  time_text_.put(buf, frame.t_ns);
  put(buf, ",\"end_ns\":");
  time_text_.put(buf, frame.end_ns);
  channel(frame.channel);
  put(buf, ",\"offset\":");
  put_uint(buf, frame.offset);
  put(buf, mode_and_role(frame.mode, frame.role));
  put_uint(buf, frame.slave());
  put(buf, function_and_raw(frame.function()));
  append_hex(buf, frame.raw, false);
  put(buf, frame.check_ok ? "\",\"check\":\"ok\",\"check_value\":"
                          : "\",\"check\":\"bad\",\"check_value\":");
  const uint16_t check = frame.wire_check();
  const size_t check_at = buf.size();
  put_uint(buf, check);
  const size_t check_end = buf.size();
  put(buf, ",\"expected_check\":");
  if (frame.damage == Damage::cut) {
    put(buf, "null");
  } else if (frame.expected_check == check) {  // a good check: the same digits
    put_again(buf, check_at, check_end);
  } else {
    put_uint(buf, frame.expected_check);
  }
  // The usual nulls with the keys around them, in one copy each.
  if (frame.damage != Damage::none) {
    put(buf, ",\"damage\":\"");
    put(buf, to_string(frame.damage));
    put(buf, "\",\"exception\":");
  } else {
    put(buf, ",\"damage\":null,\"exception\":");
  }
  if (frame.is_exception() && frame.adu.size() > 2) {
    put_uint(buf, frame.adu[2]);
    put(buf, ",\"request\":");
  } else {
    put(buf, "null,\"request\":");
  }
  if (frame.request) {
    put_uint(buf, *frame.request);
  } else {
    put(buf, "null");
  }
  if (frame.latency_ns) {
    put(out_.buffer(), ",\"latency_us\":");
    put_fixed(out_.buffer(), Fixed{*frame.latency_ns, 3, 3});
  } else {
    put(buf, ",\"latency_us\":null");
  }
  put(buf, ",\"findings\":[");
  bool first = finding_names(frame.findings);
  if (frame.meaning) {
    for (const RuleFinding& finding : frame.meaning->findings) {
      if (!first) buf.push_back(',');
      buf.push_back('"');
      put(buf, to_string(finding.kind));
      buf.push_back('"');
      first = false;
    }
  }
  buf.push_back(']');
  if (frame.meaning) meaning(*frame.meaning);
  const DecodedPdu& pdu = fields_of(frame, decoded_);
  for (size_t at = 0; at < pdu.fields.size();) {
    buf.push_back(',');
    at = append_json_field(buf, pdu, at);
  }
  if (pdu.truncated) put(buf, ",\"truncated\":true");
  put(buf, "}\n");
  out_.end_record();
}

// The names of the findings in `bits`, comma-separated; true if there were none.
bool JsonSink::finding_names(uint32_t bits) {
  bool none = true;
  auto& buf = out_.buffer();
  for_each_frame_finding(bits, [&](size_t slot) {
    if (!none) buf.push_back(',');
    buf.push_back('"');
    put(buf, frame_findings()[slot].name);
    buf.push_back('"');
    none = false;
  });
  return none;
}

// "model", "registers" and "notes": each model finding's kind, address and explanation.
void JsonSink::meaning(const Meaning& meaning) {
  auto& buf = out_.buffer();
  if (meaning.model != model_key_for_) {  // escaped once per model, not for every record
    model_key_for_ = meaning.model;
    model_key_.clear();
    put(model_key_, ",\"model\":");
    append_json_string(model_key_, meaning.model->name);
  }
  put(buf, {model_key_.data(), model_key_.size()});
  put(buf, ",\"registers\":[");
  for (size_t i = 0; i < meaning.registers.size(); ++i) {
    if (i) buf.push_back(',');
    append_register_json(buf, meaning.registers[i]);
  }
  put(buf, "],\"notes\":[");
  for (size_t i = 0; i < meaning.findings.size(); ++i) {
    const RuleFinding& finding = meaning.findings[i];
    if (i) buf.push_back(',');
    put(buf, "{\"finding\":\"");
    put(buf, to_string(finding.kind));
    put(buf, "\",\"addr\":");
    if (finding.address) {
      put_uint(buf, *finding.address);
    } else {
      put(buf, "null");
    }
    put(buf, ",\"text\":");
    append_json_string(buf, finding.text);
    buf.push_back('}');
  }
  buf.push_back(']');
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
  out_.print(FMT_COMPILE(",\"damaged_answer\":{}"), noise.damaged_answer);
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

}  // namespace modtap::output
