#include "output/text_sink.hpp"

#include <array>
#include <ctime>

#include <fmt/chrono.h>

#include "decoder/models/record_fields.hpp"
#include "decoder/models/register_meaning.hpp"
#include "decoder/protocol/pdu_fields.hpp"
#include "output/render.hpp"

namespace modtap::output {

namespace {

constexpr size_t line_items = 8;  // values shown on a summary line; -V shows all

const char* role_tag(Role role) {
  switch (role) {
    case Role::request:
      return "req";
    case Role::response:
      return "rsp";
    case Role::unknown:
      return "???";
  }
  return "?";
}

// " req slave " for each role, made once: one copy a line.
std::string_view role_and_slave(Role role) {
  static const auto pieces = [] {
    std::array<std::string, 3> made;
    for (const Role r : {Role::request, Role::response, Role::unknown})
      made[static_cast<size_t>(r)] = fmt::format(" {} slave ", role_tag(r));
    return made;
  }();
  return pieces[static_cast<size_t>(role)];
}

// " Read Holding Registers" for each function code byte, made once.
std::string_view spaced_function_label(uint8_t function) {
  static const auto pieces = texts_per_byte([](fmt::memory_buffer& piece, uint8_t fc) {
    piece.push_back(' ');
    put_function_label(piece, fc);
  });
  return pieces[function];
}

// A check as the manuals print it, in wire order: CRC 0xCC7E is sent, and written, "7E CC".
void append_check(fmt::memory_buffer& buf, uint16_t check, Mode mode) {
  if (mode == Mode::rtu) {
    fmt::format_to(fmt::appender(buf), "{:02X} {:02X}", check & 0xFF, check >> 8);
  } else {
    fmt::format_to(fmt::appender(buf), "{:02X}", check);
  }
}

// What a bad check says: the check it should have been (none where the frame was cut before
// its check), and how the frame was damaged.
void append_bad_check(fmt::memory_buffer& buf, const RecordFields& frame) {
  if (!frame.expected_check) {
    fmt::format_to(fmt::appender(buf), "cut");
    return;
  }
  fmt::format_to(fmt::appender(buf), "expected ");
  append_check(buf, static_cast<uint16_t>(*frame.expected_check), frame.mode);
  if (frame.damage == Damage::collision) fmt::format_to(fmt::appender(buf), ", collision");
}

}  // namespace

TextSink::TextSink(Output& out, const std::vector<ChannelInfo>& channels, TextOptions options)
    : out_(out), channels_(channels), options_(options), clock_(options.clock) {}

// The clock has seen this record already (kept before the filter), or sees it now.
void TextSink::time_column(int64_t t_ns) {
  clock_.see(t_ns);
  switch (options_.time) {
    case TimeFormat::relative:
      seconds_column(t_ns - clock().first_ns.value_or(t_ns));
      return;
    case TimeFormat::delta:
      seconds_column(t_ns - clock().previous_ns.value_or(t_ns));
      return;
    case TimeFormat::delta_displayed:
      seconds_column(t_ns - previous_shown_ns_.value_or(t_ns));
      previous_shown_ns_ = t_ns;
      return;
    case TimeFormat::absolute:
    case TimeFormat::absolute_date:
      absolute_time(t_ns);
      return;
  }
}

// " %11.6f" of the seconds, as Fixed{ns, 9, 6} gives them: the whole seconds' digits are made
// once a second, the microseconds in three digit pairs (the column is on every line).
void TextSink::seconds_column(int64_t ns) {
  auto& buf = out_.buffer();
  buf.push_back(' ');
  if (ns < 0) return put_fixed(buf, Fixed{ns, 9, 6}, 11);
  const uint64_t us = (static_cast<uint64_t>(ns) + 500) / 1000;
  const uint64_t second = us / 1'000'000;
  put_right_aligned(buf, seconds_.of(second), 4);
  buf.push_back('.');
  put_zero_padded(buf, static_cast<uint32_t>(us - second * 1'000'000), 6);
}

// The date and time are formatted once a second; the microseconds per record.
void TextSink::absolute_time(int64_t t_ns) {
  const auto [second, micros] = seconds_and_micros(t_ns);
  if (second != shown_second_) {
    shown_second_ = second;
    shown_.clear();
    std::tm local{};
    const std::time_t when = static_cast<std::time_t>(second);
    localtime_r(&when, &local);
    if (options_.time == TimeFormat::absolute_date) {
      fmt::format_to(fmt::appender(shown_), "{:%Y-%m-%d %H:%M:%S}", local);
    } else {
      fmt::format_to(fmt::appender(shown_), "{:%H:%M:%S}", local);
    }
  }
  out_.print(FMT_COMPILE(" {}.{:06}"), std::string_view(shown_.data(), shown_.size()), micros);
}

void TextSink::channel_column(uint16_t channel) {
  if (channels_.size() > 1)
    out_.print(FMT_COMPILE(" {:<10}"), channel < channels_.size() ? channels_[channel].name : "?");
}

void TextSink::on_frame(const Frame& frame) {
  const RecordFields f = gather_fields(frame, fields_of(frame, decoded_));
  auto& buf = out_.buffer();
  put_right_aligned(buf, f.index, 6);
  time_column(f.t_ns);
  channel_column(f.channel);
  put(buf, role_and_slave(f.role));
  put_left_aligned(buf, f.slave, 3);
  put(buf, spaced_function_label(f.function));
  // How registers are numbered and the model's name for an exception are not fields: the
  // frame's function code and model say them.
  const AddressNumbering numbering = numbering_of(frame);
  // Where the model gives the exception code its own meaning, the model's note after the fields
  // says it in full: the line does not say it twice.
  const bool noted_exception = !model_exception_meaning(frame).empty();
  const DecodedPdu& pdu = *f.pdu;
  for (size_t at = 0; at < pdu.fields.size();) {
    const Field& field = pdu.fields[at];
    const bool shown = field.type() != FieldType::list && field.id != FieldId::byte_count &&
                       !(noted_exception && field.id == FieldId::exception_name);
    if (!shown) {
      at = pdu.next(at);
      continue;
    }
    buf.push_back(' ');
    put(buf, field.name());
    buf.push_back('=');
    at = append_text_value(buf, pdu, at, line_items, numbering);
  }
  const bool rtu = f.mode == Mode::rtu;
  if (f.check == CheckResult::ok) {
    put(buf, rtu ? "  crc ok" : "  lrc ok");
  } else {
    put(buf, rtu ? "  crc BAD (" : "  lrc BAD (");
    append_bad_check(buf, f);
    buf.push_back(')');
  }
  if (f.request) {
    put(buf, "  req #");
    put_uint(buf, *f.request);
  }
  if (f.latency_ns) {
    buf.push_back(' ');
    put_fixed(buf, Fixed{*f.latency_ns, 6, 3});
    put(buf, " ms");
  }
  // A bad check is said in the check column already; the model's findings follow its values.
  for_each_frame_finding(f.findings.bits & ~finding_bad_check, [&](size_t slot) {
    put(buf, " [");
    put(buf, frame_findings()[slot].name);
    buf.push_back(']');
  });
  registers_line(f);
  buf.push_back('\n');
  if (options_.verbose) tree(f, numbering);
  out_.end_record();
}

// Only Modicon's numbers need the table, which takes a look at the function code's accesses.
AddressNumbering TextSink::numbering_of(const Frame& frame) const {
  if (options_.register_base != RegisterBase::modicon) return {options_.register_base};
  return {options_.register_base, addressed_table(frame)};
}

void TextSink::tree(const RecordFields& f, AddressNumbering numbering) {
  auto& buf = out_.buffer();
  out_.print(FMT_COMPILE("    Frame {}: {} bytes, {}, channel {}, offset {}\n"), f.index,
             f.raw.size(), to_string(f.mode),
             f.channel < channels_.size() ? channels_[f.channel].name : "?", f.offset);
  out_.print(FMT_COMPILE("    Raw: "));
  append_hex(buf, f.raw, true);
  out_.print(FMT_COMPILE("\n    Role: {}\n    Slave: {}\n    Function: {} ({})\n"),
             to_string(f.role), f.slave, f.function, FunctionLabel{f.function});
  const DecodedPdu& pdu = *f.pdu;
  for (size_t at = 0; at < pdu.fields.size();) {
    out_.print(FMT_COMPILE("    {}: "), pdu.fields[at].name());
    at = append_text_value(buf, pdu, at, SIZE_MAX, numbering);
    out_.print(FMT_COMPILE("\n"));
  }
  if (f.truncated) out_.print(FMT_COMPILE("    [PDU shorter than its fields]\n"));
  out_.print(FMT_COMPILE("    {}: "), f.mode == Mode::rtu ? "CRC" : "LRC");
  if (!f.check_value) {
    out_.print(FMT_COMPILE("none, the frame was cut before it\n"));
  } else {
    append_check(buf, static_cast<uint16_t>(*f.check_value), f.mode);
    out_.print(FMT_COMPILE(" ({})"), to_string(f.check));
    if (f.check == CheckResult::bad) {
      out_.print(FMT_COMPILE(", "));
      append_bad_check(buf, f);
    }
    out_.print(FMT_COMPILE("\n"));
  }
  // Titled and scaled as the field registry says, as JSON and Wireshark show them.
  if (f.request)
    out_.print(FMT_COMPILE("    {}: {}\n"), field_info(FieldId::request).title, *f.request);
  if (f.latency_ns)
    out_.print(FMT_COMPILE("    {}: {}\n"), field_info(FieldId::latency_us).title,
               Fixed{*f.latency_ns, 3, 3});
  registers_tree(f);
}

// The named registers after the summary line, then the model's findings, marked so they stand
// out: "| frequency_command=60.00 Hz  !! 2520H is read-only".
void TextSink::registers_line(const RecordFields& f) {
  auto& buf = out_.buffer();
  size_t shown = 0;
  for (const RegisterValue& reg : f.registers) {
    if (reg.name.empty()) continue;
    if (shown++ == line_items) {
      out_.print(FMT_COMPILE(" ..."));
      break;
    }
    out_.print(FMT_COMPILE("{}{}="), shown == 1 ? "  | " : " ", reg.name);
    append_value_text(buf, reg);
  }
  for (const RuleFinding& finding : f.notes) out_.print(FMT_COMPILE("  !! {}"), finding.text);
}

void TextSink::registers_tree(const RecordFields& f) {
  auto& buf = out_.buffer();
  if (!f.registers.empty()) out_.print(FMT_COMPILE("    Registers ({}):\n"), f.model);
  for (const RegisterValue& reg : f.registers) {
    out_.print(FMT_COMPILE("      {} {}"),
               RegisterNumber{reg.table, reg.address, options_.register_base},
               reg.name.empty() ? "(unknown)" : reg.name);
    if (!reg.label.empty()) out_.print(FMT_COMPILE(" \"{}\""), reg.label);
    out_.print(FMT_COMPILE(" = 0x{:04X} -> "), reg.raw);
    append_value_text(buf, reg);
    out_.print(FMT_COMPILE("\n"));
  }
  for (const RuleFinding& finding : f.notes)
    out_.print(FMT_COMPILE("    Finding ({}): {}\n"), to_string(finding.kind), finding.text);
}

void TextSink::on_noise(const Noise& noise) {
  const RecordFields f = gather_fields(noise);
  out_.print(FMT_COMPILE("{:6}"), f.index);
  time_column(f.t_ns);
  channel_column(f.channel);
  out_.print(FMT_COMPILE(" noise {} ({})"), counted(f.raw.size(), "byte", "bytes"),
             to_string(*f.noise_reason));
  if (f.request) out_.print(FMT_COMPILE(" after request #{}"), *f.request);
  // Whose answer it was is the line's to say, from the request: no field of the record.
  if (f.damaged_answer) out_.print(FMT_COMPILE(", slave {}'s answer garbled"), noise.request_slave);
  for_each_frame_finding(f.findings.bits, [&](size_t slot) {
    out_.print(FMT_COMPILE(" [{}]"), frame_findings()[slot].name);
  });
  out_.print(FMT_COMPILE(": "));
  append_hex(out_.buffer(), f.raw.first(std::min<size_t>(f.raw.size(), 32)), true);
  if (f.raw.size() > 32) out_.print(FMT_COMPILE(" ..."));
  out_.print(FMT_COMPILE("\n"));
  out_.end_record();
}

void TextSink::on_timeout(const Timeout& timeout) {
  const RecordFields f = gather_fields(timeout);
  out_.print(FMT_COMPILE("{:6}"), "-");
  time_column(f.t_ns);
  channel_column(f.channel);
  const Fixed waited_ms{f.waited_ns, 6, 3};
  if (f.type == RecordType::timeout) {
    out_.print(FMT_COMPILE(" TIMEOUT request #{} slave {} {}: no response after {} ms ({})\n"),
               *f.request, f.slave, FunctionLabel{f.function}, waited_ms,
               to_string(*f.timeout_reason));
  } else {
    out_.print(
        FMT_COMPILE(" UNANSWERED request #{} slave {} {}: the capture ends {} ms after it\n"),
        *f.request, f.slave, FunctionLabel{f.function}, waited_ms);
  }
  out_.end_record();
}

}  // namespace modtap::output
