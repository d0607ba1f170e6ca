// A record's fields, walked in one place: which fields each kind of record has, in the order
// JSON writes them, and what each holds. Outputs render the walk and the display filter
// evaluates it; none of them reads a record's members for a field itself. It sits beside the
// models because a frame's fields include the model's reading.
//
// A visitor has these calls, each given the field's id as a FieldTag, which converts to a
// FieldId (the registry says its name and type) or gives it at compile time:
//   name(id, text)          a fixed name: the standard's, a model's
//   choice(id, value)       a value of an enumeration; to_string gives its name
//   function_code(fc, function, byte)
//                           the function code's byte: its number (exception bit off) and label
//   number(id, n)           an unsigned integer
//   time(id, ns)            a moment in nanoseconds
//   micros(id, ns)          a duration, shown in microseconds
//   channel(id, number)     the record's channel; its name is the visitor's to know
//   bytes(id, bytes)
//   boolean(id, value)
//   absent(id)              a field this kind of record has and this record lacks (JSON's null)
//   findings(id, findings)  a FindingSlots
//   registers(id, values)   the model's reading, span<const RegisterValue>
//   notes(id, findings)     the model's findings with their texts, span<const RuleFinding>
//   pdu(fields)             the PDU's fields, in the order the function-code table decodes them
//   flag(id)                a flag that is set; one that is not is not walked
// A field that only some records have (the model's, `truncated`) is walked only where present.
#pragma once

#include <cstdint>
#include <optional>
#include <span>

#include "decoder/models/register_meaning.hpp"
#include "decoder/protocol/field_registry.hpp"
#include "decoder/protocol/findings.hpp"
#include "decoder/protocol/function_codes.hpp"
#include "decoder/protocol/pdu_fields.hpp"
#include "decoder/protocol/records.hpp"

namespace modtap {

// What `type` says of a record, and `check` of a frame.
enum class RecordType : uint8_t { frame, noise, timeout, unanswered };
template <>
struct EnumNames<RecordType> {
  static constexpr std::array<std::string_view, 4> names{"frame", "noise", "timeout", "unanswered"};
};
enum class CheckResult : uint8_t { bad, ok };
template <>
struct EnumNames<CheckResult> {
  static constexpr std::array<std::string_view, 2> names{"bad", "ok"};
};

// A record's findings from both places they are kept (the frame's bit set, the model's rules)
// as one sequence of finding_registry() slots, the frame's first.
struct FindingSlots {
  uint32_t bits = finding_none;
  const Meaning* meaning = nullptr;

  template <typename Visit>
  void each(Visit&& visit) const {
    for_each_frame_finding(bits, visit);
    if (meaning)
      for (const RuleFinding& finding : meaning->findings) visit(finding_slot(finding.kind));
  }
  bool has(size_t slot) const {
    bool found = false;
    each([&](size_t s) { found = found || s == slot; });
    return found;
  }
};

inline FindingSlots findings_of(const Frame& frame) {
  return {frame.findings, frame.meaning};
}

// The meaning the frame's device model gives its exception code, empty where it gives none (or
// the frame is no exception read through a model).
inline std::string_view model_exception_meaning(const Frame& frame) {
  if (!frame.is_exception() || !frame.meaning || !frame.meaning->model) return {};
  return exception_meaning(*frame.meaning->model, frame.adu[2]);
}

// An exception code's name as every output gives it: the device model's meaning where the model
// gives the code one (GD20's 04H is "Operation failed", not "Server Device Failure"), else the
// standard's; empty for a code neither names.
inline std::string_view exception_name_of(const Frame& frame) {
  if (!frame.is_exception()) return {};
  const std::string_view meaning = model_exception_meaning(frame);
  return meaning.empty() ? exception_name(frame.adu[2]) : meaning;
}

// A frame's fields as every output shows them: its PDU decoded, the exception named as above.
void decode_frame(const Frame& frame, DecodedPdu& out);

// A frame's fields: as a stage before decoded them (the filter), or decoded into `kept`.
inline const DecodedPdu& fields_of(const Frame& frame, DecodedPdu& kept) {
  if (frame.decoded) return *frame.decoded;
  decode_frame(frame, kept);
  return kept;
}

// The PDU's fields for an output that shows none of them (CSV, the pcapng comment): a frame's
// walk without decoding its PDU.
inline const DecodedPdu no_pdu_fields;

// Where a frame or a noise record was: the fields both begin with.
template <typename Record, typename Visitor>
void walk_place(const Record& r, RecordType kind, Visitor& v) {
  using enum FieldId;
  v.choice(field<type>, kind);
  v.number(field<index>, r.index);
  v.time(field<t_ns>, r.t_ns);
  v.time(field<end_ns>, r.end_ns);
  v.channel(field<channel>, r.channel);
  v.number(field<offset>, r.offset);
  v.choice(field<mode>, r.mode);
}

// The request a frame answers or noise came after, where there is one.
template <typename Visitor>
void walk_request(const std::optional<uint64_t>& request, Visitor& v) {
  if (request)
    v.number(field<FieldId::request>, *request);
  else
    v.absent(field<FieldId::request>);
}

template <typename Visitor>
void walk_fields(const Frame& frame, const DecodedPdu& pdu, Visitor& v) {
  using enum FieldId;
  walk_place(frame, RecordType::frame, v);
  v.choice(field<role>, frame.role);
  v.number(field<slave>, frame.slave());
  v.function_code(field<fc>, field<function>, frame.function());
  v.bytes(field<raw>, frame.raw);
  v.choice(field<check>, frame.check_ok ? CheckResult::ok : CheckResult::bad);
  if (frame.damage == Damage::cut) {  // the frame ended before its check
    v.absent(field<check_value>);
    v.absent(field<expected_check>);
  } else {
    v.number(field<check_value>, frame.wire_check());
    v.number(field<expected_check>, frame.expected_check);
  }
  if (frame.damage != Damage::none)
    v.choice(field<damage>, frame.damage);
  else
    v.absent(field<damage>);
  if (frame.is_exception())
    v.number(field<exception>, frame.adu[2]);
  else
    v.absent(field<exception>);
  walk_request(frame.request, v);
  if (frame.latency_ns)
    v.micros(field<latency_us>, *frame.latency_ns);
  else
    v.absent(field<latency_us>);
  v.findings(field<findings>, findings_of(frame));
  if (const Meaning* meaning = frame.meaning) {
    v.name(field<model>, meaning->model->name);
    v.registers(field<registers>, std::span<const RegisterValue>(meaning->registers));
    v.notes(field<notes>, std::span<const RuleFinding>(meaning->findings));
  }
  v.pdu(pdu);
  if (pdu.truncated) v.flag(field<truncated>);
}

template <typename Visitor>
void walk_fields(const Noise& noise, Visitor& v) {
  using enum FieldId;
  walk_place(noise, RecordType::noise, v);
  v.bytes(field<raw>, noise.raw);
  v.choice(field<reason>, noise.reason);
  walk_request(noise.request, v);
  v.boolean(field<damaged_answer>, noise.damaged_answer);
  v.findings(field<findings>, FindingSlots{noise.findings, nullptr});
}

template <typename Visitor>
void walk_fields(const Timeout& timeout, Visitor& v) {
  using enum FieldId;
  v.choice(field<type>, timeout.timed_out() ? RecordType::timeout : RecordType::unanswered);
  v.number(field<request>, timeout.request);
  v.time(field<t_ns>, timeout.t_ns);
  v.channel(field<channel>, timeout.channel);
  v.number(field<slave>, timeout.slave);
  v.number(field<fc>, timeout.function);
  v.micros(field<waited_us>, timeout.waited_ns);
  v.choice(field<reason>, timeout.reason);
}

// A record's fields gathered from its walk, for an output that lays them out in an order of its
// own (the text line, -V's tree, CSV): what the walk leaves absent is empty here, so such an
// output still learns from the walk alone which fields a record has.
struct RecordFields {
  RecordType type = RecordType::frame;
  uint64_t index = 0;
  int64_t t_ns = 0, end_ns = 0;
  uint16_t channel = 0;
  uint64_t offset = 0;
  Mode mode = Mode::rtu;
  Role role = Role::unknown;
  uint8_t slave = 0;
  uint8_t function = 0;  // the function code's byte, exception bit and all
  std::span<const uint8_t> raw;
  CheckResult check = CheckResult::ok;
  std::optional<uint64_t> check_value, expected_check;  // none where the frame was cut
  std::optional<Damage> damage;
  std::optional<uint64_t> exception;
  std::optional<uint64_t> request;
  std::optional<int64_t> latency_ns;
  FindingSlots findings;
  std::string_view model;  // empty where no model read the frame
  std::span<const RegisterValue> registers;
  std::span<const RuleFinding> notes;
  const DecodedPdu* pdu = nullptr;
  bool truncated = false;
  std::optional<NoiseReason> noise_reason;
  bool damaged_answer = false;
  std::optional<TimeoutReason> timeout_reason;
  int64_t waited_ns = 0;
};

// The visitor that fills RecordFields.
class FieldGatherer {
 public:
  explicit FieldGatherer(RecordFields& out) : out_(out) {}

  // A field by its id; `reason` by what it is a reason of.
  template <FieldId id, NamedEnum Enum>
  void choice(FieldTag<id>, Enum chosen) {
    using enum FieldId;
    if constexpr (id == type) out_.type = chosen;
    if constexpr (id == mode) out_.mode = chosen;
    if constexpr (id == role) out_.role = chosen;
    if constexpr (id == check) out_.check = chosen;
    if constexpr (id == damage) out_.damage = chosen;
    if constexpr (id == reason && std::is_same_v<Enum, NoiseReason>) out_.noise_reason = chosen;
    if constexpr (id == reason && std::is_same_v<Enum, TimeoutReason>) out_.timeout_reason = chosen;
  }
  template <FieldId fc, FieldId function>
  void function_code(FieldTag<fc>, FieldTag<function>, uint8_t byte) {
    out_.function = byte;
  }
  template <FieldId id>
  void number(FieldTag<id>, uint64_t n) {
    using enum FieldId;
    if constexpr (id == index) out_.index = n;
    if constexpr (id == offset) out_.offset = n;
    if constexpr (id == slave) out_.slave = static_cast<uint8_t>(n);
    if constexpr (id == fc) out_.function = static_cast<uint8_t>(n);
    if constexpr (id == check_value) out_.check_value = n;
    if constexpr (id == expected_check) out_.expected_check = n;
    if constexpr (id == exception) out_.exception = n;
    if constexpr (id == request) out_.request = n;
  }
  template <FieldId id>
  void time(FieldTag<id>, int64_t ns) {
    if constexpr (id == FieldId::t_ns) out_.t_ns = ns;
    if constexpr (id == FieldId::end_ns) out_.end_ns = ns;
  }
  template <FieldId id>
  void micros(FieldTag<id>, int64_t ns) {
    if constexpr (id == FieldId::latency_us) out_.latency_ns = ns;
    if constexpr (id == FieldId::waited_us) out_.waited_ns = ns;
  }
  void channel(FieldId, uint16_t number) { out_.channel = number; }
  template <FieldId id>
  void bytes(FieldTag<id>, std::span<const uint8_t> raw) {
    if constexpr (id == FieldId::raw) out_.raw = raw;
  }
  template <FieldId id>
  void boolean(FieldTag<id>, bool value) {
    if constexpr (id == FieldId::damaged_answer) out_.damaged_answer = value;
  }
  template <FieldId id>
  void absent(FieldTag<id>) {}
  template <FieldId id>
  void findings(FieldTag<id>, FindingSlots slots) {
    if constexpr (id == FieldId::findings) out_.findings = slots;
  }
  template <FieldId id>
  void name(FieldTag<id>, std::string_view text) {
    if constexpr (id == FieldId::model) out_.model = text;
  }
  template <FieldId id>
  void registers(FieldTag<id>, std::span<const RegisterValue> values) {
    if constexpr (id == FieldId::registers) out_.registers = values;
  }
  template <FieldId id>
  void notes(FieldTag<id>, std::span<const RuleFinding> notes) {
    if constexpr (id == FieldId::notes) out_.notes = notes;
  }
  void pdu(const DecodedPdu& fields) { out_.pdu = &fields; }
  template <FieldId id>
  void flag(FieldTag<id>) {
    if constexpr (id == FieldId::truncated) out_.truncated = true;
  }

 private:
  RecordFields& out_;
};

template <typename Record, typename... Pdu>
RecordFields gather_fields(const Record& record, const Pdu&... pdu) {
  RecordFields fields;
  FieldGatherer gatherer(fields);
  walk_fields(record, pdu..., gatherer);
  return fields;
}

}  // namespace modtap
