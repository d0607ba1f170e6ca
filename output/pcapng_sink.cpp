#include "output/pcapng_sink.hpp"

#include <algorithm>
#include <array>
#include <stdexcept>

#include <fmt/compile.h>
#include <fmt/format.h>

#include "captures/pcapng_format.hpp"
#include "decoder/models/record_fields.hpp"
#include "decoder/models/register_meaning.hpp"
#include "decoder/protocol/buffer_put.hpp"

namespace modtap::output {

namespace {

// Exported PDU tags (Wireshark's epan/exported_pdu.h).
constexpr uint16_t tag_end_of_options = 0;
constexpr uint16_t tag_protocol_name = 12;
constexpr uint16_t tag_port_type = 24;
constexpr uint16_t tag_source_port = 25;
constexpr uint16_t tag_destination_port = 26;
constexpr uint32_t port_type_tcp = 2;

void put16(std::vector<uint8_t>& out, uint16_t v) {
  out.push_back(static_cast<uint8_t>(v >> 8));
  out.push_back(static_cast<uint8_t>(v));
}

void put_tlv(std::vector<uint8_t>& out, uint16_t tag, std::span<const uint8_t> value) {
  const size_t padded = (value.size() + 3) / 4 * 4;  // the length counts the padding
  put16(out, tag);
  put16(out, static_cast<uint16_t>(padded));
  out.insert(out.end(), value.begin(), value.end());
  out.resize(out.size() + padded - value.size(), 0);
}

void put_tlv32(std::vector<uint8_t>& out, uint16_t tag, uint32_t v) {
  const uint8_t be[4] = {static_cast<uint8_t>(v >> 24), static_cast<uint8_t>(v >> 16),
                         static_cast<uint8_t>(v >> 8), static_cast<uint8_t>(v)};
  put_tlv(out, tag, be);
}

captures::PacketDirection direction_of(Role role, ChannelRole channel) {
  if (role == Role::request || channel == ChannelRole::master)
    return captures::PacketDirection::outbound;
  if (role == Role::response || channel == ChannelRole::slave)
    return captures::PacketDirection::inbound;
  return captures::PacketDirection::unknown;
}

// The role a reader takes a packet's direction for: a request goes out from the master.
Role role_of(captures::PacketDirection direction) {
  switch (direction) {
    case captures::PacketDirection::outbound:
      return Role::request;
    case captures::PacketDirection::inbound:
      return Role::response;
    case captures::PacketDirection::unknown:
      break;
  }
  return Role::unknown;
}

// The device model's reading, one line each after the verdicts, for the plugin and for people:
// "register 2502H frequency_command = 60.00 Hz" and "note read_only_write: ... is read-only".
// Only the registers the model names: Wireshark's Modbus dissector shows every raw value, and
// repeating them made a packet's comment kilobytes long (a read of 125 registers).
void append_register_lines(fmt::memory_buffer& out, std::span<const RegisterValue> registers) {
  for (const RegisterValue& reg : registers) {
    if (reg.name.empty()) continue;
    put(out, "\nregister ");
    put_hex4(out, reg.address);
    put(out, "H ");
    put(out, reg.name);
    put(out, " = ");
    append_value_text(out, reg);
  }
}

void append_note_lines(fmt::memory_buffer& out, std::span<const RuleFinding> notes) {
  for (const RuleFinding& finding : notes)
    fmt::format_to(fmt::appender(out), FMT_COMPILE("\nnote {}: {}"), to_string(finding.kind),
                   finding.text);
}

// Microseconds with three decimals: the nanoseconds, exactly.
void put_microseconds(fmt::memory_buffer& out, int64_t ns) {
  put_int(out, ns / 1000);
  const auto rest = static_cast<int>(ns % 1000);
  const char decimals[4] = {'.', static_cast<char>('0' + rest / 100),
                            static_cast<char>('0' + rest / 10 % 10),
                            static_cast<char>('0' + rest % 10)};
  put(out, {decimals, 4});
}

// What the comment carries beside the record's fields: where its first byte's time is
// unknown (a reread places it by its duration), and the name a device model gives its
// exception code.
struct CommentExtras {
  bool untimed_start = false;
  std::string_view exception_meaning;
};

// A record's comment rendered from its field walk (decoder/models/record_fields.hpp): each key is a
// field's registry name, written only where its value differs from what the reader assumes
// (docs/pcapng.md); the walk says which fields the record has. Where the walk has a field the
// reader can tell from the packet itself (its bytes, the slave, the function), no key.
class CommentFields {
 public:
  CommentFields(fmt::memory_buffer& out, const CommentDefaults& defaults, CommentExtras extras)
      : out_(out), defaults_(defaults), extras_(extras) {}

  template <FieldId id, NamedEnum Enum>
  void choice(FieldTag<id>, Enum chosen) {
    using enum FieldId;
    if constexpr (id == type) {
      type_ = chosen;
    } else if constexpr (id == mode) {
      mode_ = chosen;
      if (chosen != Mode::rtu) key(id, to_string(chosen));
    } else if constexpr (id == role) {
      role_ = chosen;
      if (chosen != defaults_.role) key(id, to_string(chosen));
    } else if constexpr (id == check) {
      check_bad_ = chosen == CheckResult::bad;
      if (check_bad_) key(id, to_string(chosen));
    } else if constexpr (id == reason) {  // what the noise is, or why its request timed out
      key(to_string(type_), to_string(chosen));
    } else {
      key(id, to_string(chosen));
    }
  }
  template <FieldId id>
  void number(FieldTag<id>, uint64_t n) {
    using enum FieldId;
    if constexpr (id == index) {
      index_ = n;
      if (n != defaults_.index + 1 || defaults_.index == 0) key(id, n);
    } else if constexpr (id == expected_check) {
      if (check_bad_)
        fmt::format_to(fmt::appender(out_), FMT_COMPILE(" {}=0x{:0{}x}"), field_info(id).name, n,
                       mode_ == Mode::rtu ? 4 : 2);
    } else if constexpr (id == exception) {
      key(id, n);
      if (!extras_.exception_meaning.empty())
        fmt::format_to(fmt::appender(out_), FMT_COMPILE(" {}=\"{}\""),
                       field_info(exception_name).name, extras_.exception_meaning);
    } else if constexpr (id == request) {
      // A response's request is the record before it unless this says otherwise.
      if (type_ != RecordType::timeout && (role_ != Role::response || n + 1 != index_)) key(id, n);
    }
  }
  template <FieldId id>
  void absent(FieldTag<id>) {
    if constexpr (id == FieldId::request)
      if (role_ == Role::response) key(id, "none");
  }
  template <FieldId id>
  void time(FieldTag<id>, int64_t ns) {
    if constexpr (id == FieldId::t_ns) t_ns_ = ns;
    if constexpr (id == FieldId::end_ns) end_ns_ = ns;
  }
  // A record lasts its bytes times a character's time unless this says otherwise.
  template <FieldId id>
  void bytes(FieldTag<id>, std::span<const uint8_t> raw) {
    const int64_t duration = end_ns_ - t_ns_;
    if (defaults_.char_ns == 0 ||
        duration != static_cast<int64_t>(raw.size()) * defaults_.char_ns) {
      put_key("duration_ns");
      put_int(out_, duration);
    }
    if (extras_.untimed_start) put(out_, " untimed_start=1");
  }
  template <FieldId id>
  void micros(FieldTag<id>, int64_t ns) {
    put_key(field_info(id).name);
    if (defaults_.resolution_ns >= 1000) {
      put_int(out_, (ns + 500) / 1000);  // no digits the clock cannot tell
    } else {
      put_microseconds(out_, ns);
    }
  }
  // The frame's own findings, one key each; a model's come as note lines.
  template <FieldId id>
  void findings(FieldTag<id>, FindingSlots slots) {
    for_each_frame_finding(slots.bits,
                           [&](size_t slot) { key("finding", frame_findings()[slot].name); });
  }
  // The model a slave's frames are read with changes seldom: said where it does.
  template <FieldId id>
  void name(FieldTag<id>, std::string_view model) {
    model_walked_ = true;
    if (!defaults_.model || defaults_.model->name != model) key(id, model);
  }
  template <FieldId id>
  void registers(FieldTag<id>, std::span<const RegisterValue> values) {
    end_first_line();
    append_register_lines(out_, values);
  }
  template <FieldId id>
  void notes(FieldTag<id>, std::span<const RuleFinding> notes) {
    end_first_line();
    append_note_lines(out_, notes);
  }
  void end_first_line() {
    if (!model_walked_ && defaults_.model && type_ == RecordType::frame)
      key(FieldId::model, "none");
    model_walked_ = true;
  }

  template <FieldId fc, FieldId function>
  void function_code(FieldTag<fc>, FieldTag<function>, uint8_t) {}
  void channel(FieldId, uint16_t) {}
  template <FieldId id>
  void boolean(FieldTag<id>, bool) {}
  template <FieldId id>
  void flag(FieldTag<id>) {}
  void pdu(const DecodedPdu&) {}

 private:
  void put_key(std::string_view name) {
    out_.push_back(' ');
    put(out_, name);
    out_.push_back('=');
  }
  void key(std::string_view name, std::string_view value) {
    put_key(name);
    put(out_, value);
  }
  void key(std::string_view name, uint64_t value) {
    put_key(name);
    put_uint(out_, value);
  }
  void key(FieldId id, std::string_view value) { key(field_info(id).name, value); }
  void key(FieldId id, uint64_t value) { key(field_info(id).name, value); }

  fmt::memory_buffer& out_;
  CommentDefaults defaults_;
  CommentExtras extras_;
  RecordType type_ = RecordType::frame;
  Mode mode_ = Mode::rtu;
  Role role_ = Role::unknown;
  uint64_t index_ = 0;
  int64_t t_ns_ = 0, end_ns_ = 0;
  bool check_bad_ = false;
  bool model_walked_ = false;
};

}  // namespace

void append_frame_comment(fmt::memory_buffer& out, const Frame& f,
                          const CommentDefaults& defaults) {
  put(out, "modtap");
  CommentFields fields(out, defaults, {f.untimed_start, model_exception_meaning(f)});
  walk_fields(f, no_pdu_fields, fields);  // the PDU is Wireshark's Modbus dissector's to show
  fields.end_first_line();
}

std::string frame_comment(const Frame& f, const CommentDefaults& defaults) {
  fmt::memory_buffer out;
  append_frame_comment(out, f, defaults);
  return fmt::to_string(out);
}

void append_noise_comment(fmt::memory_buffer& out, const Noise& n,
                          const CommentDefaults& defaults) {
  put(out, "modtap");
  CommentFields fields(out, defaults, {n.untimed_start, {}});
  walk_fields(n, fields);
}

std::string noise_comment(const Noise& n, const CommentDefaults& defaults) {
  fmt::memory_buffer out;
  append_noise_comment(out, n, defaults);
  return fmt::to_string(out);
}

void append_timeout_comment(fmt::memory_buffer& out, const Timeout& timeout,
                            const CommentDefaults& defaults) {
  if (!timeout.timed_out()) return;  // the capture ended first: nothing to say on the request
  CommentFields fields(out, defaults, {});
  walk_fields(timeout, fields);
}

std::string interface_comment(ChannelRole role, ClockQuality clock, int64_t char_ns) {
  std::string comment = fmt::format("{} role={} clock={}", captures::pcapng::interface_convention,
                                    to_string(role), to_string(clock));
  if (char_ns > 0) comment += fmt::format(" char_ns={}", char_ns);
  return comment;
}

PcapngSink::PcapngSink(captures::PcapngWriter& writer, const std::vector<ChannelInfo>& channels,
                       const PcapngOptions& options)
    : writer_(writer), channels_(channels), options_(options) {}

// Every channel's interface is written before the first packet, so a reader knows all the
// channels before it reads a packet.
uint32_t PcapngSink::interface_for(uint16_t channel) {
  const size_t count = std::max<size_t>(channels_.size(), channel + 1u);
  while (interface_of_channel_.size() < count) {
    const size_t c = interface_of_channel_.size();
    const int dlt = options_.link == PcapngLink::exported_pdu ? captures::pcapng::exported_pdu_dlt
                                                              : options_.dlt;
    const std::string name = c < channels_.size() ? channels_[c].name : "modtap";
    const ChannelRole role = c < channels_.size() ? channels_[c].role : ChannelRole::bus;
    interface_of_channel_.push_back(static_cast<int>(
        writer_.add_interface(dlt, name,
                              options_.link == PcapngLink::bare
                                  ? std::string()
                                  : interface_comment(role, options_.clock, options_.char_ns))));
  }
  return static_cast<uint32_t>(interface_of_channel_[channel]);
}

std::span<const uint8_t> PcapngSink::exported_pdu(std::string_view protocol, bool from_master,
                                                  std::span<const uint8_t> payload) {
  payload_.clear();
  put_tlv(payload_, tag_protocol_name,
          {reinterpret_cast<const uint8_t*>(protocol.data()), protocol.size()});
  put_tlv32(payload_, tag_port_type, port_type_tcp);
  put_tlv32(payload_, tag_source_port, from_master ? options_.master_port : options_.slave_port);
  put_tlv32(payload_, tag_destination_port,
            from_master ? options_.slave_port : options_.master_port);
  put16(payload_, tag_end_of_options);
  put16(payload_, 0);
  payload_.insert(payload_.end(), payload.begin(), payload.end());
  return payload_;
}

void PcapngSink::on_frame(const Frame& frame) {
  const ChannelRole channel_role =
      frame.channel < channels_.size() ? channels_[frame.channel].role : ChannelRole::bus;
  const captures::PacketDirection direction = direction_of(frame.role, channel_role);
  const uint32_t interface = interface_for(frame.channel);
  ++packets_;
  if (options_.link == PcapngLink::bare) {
    writer_.write_packet(interface, frame.t_ns, frame.raw, direction, {});
    return;
  }
  if (frame.request) writer_.release(*frame.request);  // its outcome is known now
  comment_.clear();
  const DeviceModel*& model = model_of_address_[frame.raw.empty() ? 0 : frame.raw[0]];
  append_frame_comment(comment_, frame,
                       {last_index_, role_of(direction), options_.char_ns, model, resolution_ns()});
  last_index_ = frame.index;
  model = frame.meaning ? frame.meaning->model : nullptr;
  std::span<const uint8_t> data = frame.raw;
  if (options_.link == PcapngLink::exported_pdu) {
    // mbrtu reads RTU only; ASCII frames go as data with their verdicts in the comment.
    data = exported_pdu(frame.mode == Mode::rtu ? "mbrtu" : "data",
                        direction != captures::PacketDirection::inbound, frame.raw);
  }
  // A request that awaits its answer is held, with all after it, until the answer or the
  // time-out comes, so that a request that timed out says so in its own comment.
  const bool awaits =
      frame.role == Role::request && frame.check_ok && frame.slave() != 0 && frame.index != 0;
  writer_.write_packet(interface, frame.t_ns, data, direction, {comment_.data(), comment_.size()},
                       awaits ? frame.index : 0);
}

void PcapngSink::on_noise(const Noise& noise) {
  if (options_.link == PcapngLink::bare) return;
  ++packets_;
  const uint32_t interface = interface_for(noise.channel);
  std::span<const uint8_t> data = noise.raw;
  if (options_.link == PcapngLink::exported_pdu) data = exported_pdu("data", true, noise.raw);
  comment_.clear();
  append_noise_comment(comment_, noise,
                       {last_index_, Role::unknown, options_.char_ns, nullptr, resolution_ns()});
  last_index_ = noise.index;
  writer_.write_packet(interface, noise.t_ns, data, captures::PacketDirection::unknown,
                       {comment_.data(), comment_.size()});
}

void PcapngSink::on_timeout(const Timeout& timeout) {
  if (timeout.timed_out()) {  // not when the capture merely ended first
    comment_.clear();
    append_timeout_comment(comment_, timeout, {0, Role::unknown, 0, nullptr, resolution_ns()});
    writer_.extend_comment(timeout.request, {comment_.data(), comment_.size()});
  }
  writer_.release(timeout.request);
}

void PcapngSink::finish() {
  writer_.release_all();
}

}  // namespace modtap::output

namespace modtap::output {

PcapngFiles::PcapngFiles(const std::string& path, const captures::RingLimits& limits,
                         const std::vector<ChannelInfo>& channels, const PcapngOptions& options)
    : ring_(path, limits), channels_(channels), options_(options) {
  if (!limits.rotates()) begin_file(ring_.begin(0));
}

void PcapngFiles::on_frame(const Frame& frame) {
  sink_at(frame.t_ns).on_frame(frame);
}

void PcapngFiles::on_noise(const Noise& noise) {
  sink_at(noise.t_ns).on_noise(noise);
}

void PcapngFiles::on_timeout(const Timeout& timeout) {
  if (sink_) sink_->on_timeout(timeout);
}

uint64_t PcapngFiles::bytes_written() const {
  return closed_bytes_ + (writer_ ? writer_->bytes_written() : 0);
}

uint64_t PcapngFiles::packets() const {
  return closed_packets_ + (sink_ ? sink_->packets() : 0);
}

PcapngSink& PcapngFiles::sink_at(int64_t t_ns) {
  if (!writer_ || ring_.due(t_ns, writer_->bytes_written())) begin_file(ring_.begin(t_ns));
  return *sink_;
}

void PcapngFiles::begin_file(const std::string& path) {
  if (writer_) {
    sink_->finish();  // a request still waiting stays in its file, without its outcome
    closed_packets_ += sink_->packets();
    sink_.reset();
    writer_->close();
    closed_bytes_ += writer_->bytes_written();
  }
  writer_ = std::make_unique<captures::PcapngWriter>(path, options_.live);
  sink_ = std::make_unique<PcapngSink>(*writer_, channels_, options_);
}

void PcapngFiles::close() {
  if (!writer_) begin_file(ring_.begin_now());  // a ring that saw no record
  sink_->finish();
  writer_->close();
}

}  // namespace modtap::output
