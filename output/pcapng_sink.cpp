#include "output/pcapng_sink.hpp"

#include <algorithm>
#include <array>
#include <stdexcept>

#include <fmt/compile.h>
#include <fmt/format.h>

#include "captures/pcapng_format.hpp"
#include "models/record_fields.hpp"
#include "models/register_meaning.hpp"
#include "protocol/buffer_put.hpp"

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

// " finding=NAME" for each finding in `bits`, as the Wireshark plugin reads them.
void append_findings(fmt::memory_buffer& out, uint32_t bits) {
  for_each_frame_finding(bits, [&](size_t slot) {
    put(out, " finding=");
    put(out, frame_findings()[slot].name);
  });
}

// The device model's reading, one line each after the verdicts, for the plugin and for people:
// "register 2502H frequency_command = 60.00 Hz" and "note read_only_write: ... is read-only".
// Only the registers the model names: Wireshark's Modbus dissector shows every raw value, and
// repeating them made a packet's comment kilobytes long (a read of 125 registers).
void append_meaning(fmt::memory_buffer& out, const Meaning& meaning) {
  for (const RegisterValue& reg : meaning.registers) {
    if (reg.name.empty()) continue;
    put(out, "\nregister ");
    put_hex4(out, reg.address);
    put(out, "H ");
    put(out, reg.name);
    put(out, " = ");
    append_value_text(out, reg);
  }
  for (const RuleFinding& finding : meaning.findings)
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

// The keys every record may carry, each only where it differs from what the reader assumes:
// "modtap", the index and the mode first, the timing after the record's own keys.
void append_head(fmt::memory_buffer& out, uint64_t index, Mode mode,
                 const CommentDefaults& defaults) {
  put(out, "modtap");
  if (index != defaults.index + 1 || defaults.index == 0) {
    put(out, " index=");
    put_uint(out, index);
  }
  if (mode != Mode::rtu) {
    put(out, " mode=");
    put(out, to_string(mode));
  }
}

void append_timing(fmt::memory_buffer& out, int64_t duration_ns, size_t bytes, bool untimed_start,
                   const CommentDefaults& defaults) {
  if (defaults.char_ns == 0 || duration_ns != static_cast<int64_t>(bytes) * defaults.char_ns) {
    put(out, " duration_ns=");
    put_int(out, duration_ns);
  }
  if (untimed_start) put(out, " untimed_start=1");
}

}  // namespace

void append_frame_comment(fmt::memory_buffer& out, const Frame& f,
                          const CommentDefaults& defaults) {
  append_head(out, f.index, f.mode, defaults);
  if (f.role != defaults.role) {
    put(out, " role=");
    put(out, to_string(f.role));
  }
  if (!f.check_ok) put(out, " check=bad");
  append_timing(out, f.end_ns - f.t_ns, f.raw.size(), f.untimed_start, defaults);
  if (!f.check_ok && f.damage != Damage::cut)
    fmt::format_to(fmt::appender(out), FMT_COMPILE(" expected_check=0x{:0{}x}"), f.expected_check,
                   f.mode == Mode::rtu ? 4 : 2);
  if (f.damage != Damage::none) {
    put(out, " damage=");
    put(out, to_string(f.damage));
  }
  if (f.is_exception()) {
    put(out, " exception=");
    put_uint(out, f.adu[2]);
    if (const auto name = model_exception_meaning(f); !name.empty()) {
      put(out, " exception_name=\"");
      put(out, name);
      out.push_back('"');
    }
  }
  // A response's request is the record before it unless this says otherwise.
  if (f.request && (f.role != Role::response || *f.request + 1 != f.index)) {
    put(out, " request=");
    put_uint(out, *f.request);
  } else if (!f.request && f.role == Role::response) {
    put(out, " request=none");
  }
  if (f.latency_ns) {
    put(out, " latency_us=");
    put_microseconds(out, *f.latency_ns);
  }
  append_findings(out, f.findings);
  // The model a slave's frames are read with changes seldom: said where it does.
  const DeviceModel* model = f.meaning ? f.meaning->model : nullptr;
  if (model != defaults.model) {
    put(out, " model=");
    put(out, model ? std::string_view(model->name) : "none");
  }
  if (f.meaning) append_meaning(out, *f.meaning);
}

std::string frame_comment(const Frame& f, const CommentDefaults& defaults) {
  fmt::memory_buffer out;
  append_frame_comment(out, f, defaults);
  return fmt::to_string(out);
}

void append_noise_comment(fmt::memory_buffer& out, const Noise& n,
                          const CommentDefaults& defaults) {
  append_head(out, n.index, n.mode, defaults);
  put(out, " noise=");
  put(out, to_string(n.reason));
  append_timing(out, n.end_ns - n.t_ns, n.raw.size(), n.untimed_start, defaults);
  if (n.request) fmt::format_to(fmt::appender(out), FMT_COMPILE(" request={}"), *n.request);
  append_findings(out, n.findings);
}

std::string noise_comment(const Noise& n, const CommentDefaults& defaults) {
  fmt::memory_buffer out;
  append_noise_comment(out, n, defaults);
  return fmt::to_string(out);
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
  append_frame_comment(comment_, frame, {last_index_, role_of(direction), options_.char_ns, model});
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
  append_noise_comment(comment_, noise, {last_index_, Role::unknown, options_.char_ns});
  last_index_ = noise.index;
  writer_.write_packet(interface, noise.t_ns, data, captures::PacketDirection::unknown,
                       {comment_.data(), comment_.size()});
}

void PcapngSink::on_timeout(const Timeout& timeout) {
  if (timeout.timed_out()) {  // not when the capture merely ended first
    comment_.clear();
    fmt::format_to(fmt::appender(comment_), FMT_COMPILE(" timeout={} waited_us={}.{:03}"),
                   to_string(timeout.reason), timeout.waited_ns / 1000, timeout.waited_ns % 1000);
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
