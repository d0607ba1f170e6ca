#include "decoder/models/register_meaning.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <string_view>

#include <fmt/compile.h>
#include <fmt/format.h>

#include "decoder/protocol/buffer_put.hpp"
#include "decoder/protocol/bytes.hpp"
#include "decoder/protocol/function_codes.hpp"

namespace modtap {
namespace {

// The 16-bit words in `bytes`, big-endian, into `buffer` (an ADU holds at most 126 words).
using WordBuffer = std::array<uint16_t, max_rtu_adu / 2>;
std::span<const uint16_t> words_of(std::span<const uint8_t> bytes, WordBuffer& buffer) {
  const size_t n = std::min(bytes.size() / 2, buffer.size());
  for (size_t i = 0; i < n; ++i) buffer[i] = be16(bytes, 2 * i);
  return {buffer.data(), n};
}

int decimals_of(double scale) {
  if (scale <= 0 || scale >= 1) return 0;
  return std::clamp(static_cast<int>(std::lround(-std::log10(scale))), 0, 9);
}

// The digits after the point of the shortest text that reads back as the same float: a float
// register holds about seven significant digits, whatever its scale (12.53 A, a power factor of
// 0.952), and shows them, not one more (12.529999732971191).
int float_decimals(float value) {
  if (!std::isfinite(value)) return 0;
  std::array<char, 32> buffer;
  const auto end = fmt::format_to(buffer.data(), "{}", value);
  std::string_view text(buffer.data(), static_cast<size_t>(end - buffer.data()));
  int exponent = 0;  // fmt writes 1.2e-07 for the smallest and largest
  if (const size_t e = text.find('e'); e != std::string_view::npos) {
    exponent = std::atoi(text.data() + e + 1);
    text = text.substr(0, e);
  }
  const size_t point = text.find('.');
  const int digits =
      point == std::string_view::npos ? 0 : static_cast<int>(text.size() - point - 1);
  return std::clamp(digits - exponent, 0, 15);
}

// Digits after the point a value shows: those its scale implies for a whole number; a float's
// own for a float, scaled.
int decimals_of(const RegisterDef& def, double value) {
  return def.type == ValueType::f32 ? float_decimals(static_cast<float>(value))
                                    : decimals_of(def.scale);
}

double bcd_value(uint64_t raw) {
  double value = 0;
  for (int shift = 28; shift >= 0; shift -= 4) value = value * 10 + ((raw >> shift) & 0xF);
  return value;
}

double typed_value(const RegisterDef& def, uint64_t raw) {
  switch (def.type) {
    case ValueType::s16:
      return static_cast<int16_t>(raw);
    case ValueType::s32:
      return static_cast<int32_t>(raw);
    case ValueType::f32:
      return std::bit_cast<float>(static_cast<uint32_t>(raw));
    case ValueType::s64:
      return static_cast<double>(static_cast<int64_t>(raw));
    case ValueType::u64:
      return static_cast<double>(raw);
    case ValueType::bcd:
      return bcd_value(raw);
    default:
      return raw;
  }
}

std::string string_text(std::span<const uint16_t> words) {
  std::string text;
  for (uint16_t w : words)
    for (uint8_t c : {static_cast<uint8_t>(w >> 8), static_cast<uint8_t>(w)})
      if (c >= 0x20 && c < 0x7F) text.push_back(static_cast<char>(c));
  return text;
}

// "Run, Reverse, S1": each field's meaning for its current value, or its name when set.
std::string bits_text(const RegisterDef& def, uint64_t raw) {
  std::string text;
  for (const BitField& field : def.bits) {
    const uint64_t mask = field.width >= 64 ? ~uint64_t{0} : (uint64_t{1} << field.width) - 1;
    const auto value = static_cast<uint32_t>((raw >> field.lsb) & mask);
    std::string part;
    if (auto it = field.values.find(value); it != field.values.end()) {
      part = it->second;
    } else if (field.width == 1 && value) {
      part = field.name;
    } else if (field.width > 1) {
      part = fmt::format("{}={}", field.name, value);
    }
    if (part.empty()) continue;
    if (!text.empty()) text += ", ";
    text += part;
  }
  return text;
}

// Named values are written as the manual does, signed for signed registers (-1: "no fault").
int64_t enum_key(const RegisterDef& def, uint64_t raw) {
  return static_cast<int64_t>(typed_value(def, raw));
}

// The words of a value that spans several, as one number: the first the highest, or the lowest.
uint64_t combine(const RegisterDef& def, std::span<const uint16_t> words) {
  uint64_t raw = 0;
  for (size_t k = 0; k < words.size(); ++k)
    raw = raw << 16 | words[def.order == WordOrder::high_first ? k : words.size() - 1 - k];
  return raw;
}

// `reported`: the device says the value (a read's answer), the master did not write it.
void check_value(const RegisterDef& def, const RegisterValue& v, bool reported,
                 RuleFindings* found) {
  if (!found) return;
  if (def.fault && reported && v.raw != 0)
    found->add(RuleKind::device_fault, v.address, "the device reports a fault: {} ({} = {})",
               v.text.empty() ? std::string_view("not one the model names") : v.text, v.name,
               v.raw);
  // The range as the manual gives it: both ends, or the one it gives (3001H's maximum is a
  // parameter, P00.03).
  const bool below = def.min && v.value < *def.min;
  const bool above = def.max && v.value > *def.max;
  if ((below || above) && def.min && def.max)
    found->add(RuleKind::out_of_range, v.address, "{} = {:.{}f} is outside {:g}..{:g}", v.name,
               v.value, v.decimals, *def.min, *def.max);
  else if (below || above)
    found->add(RuleKind::out_of_range, v.address, "{} = {:.{}f} is {} its {} {:g}", v.name, v.value,
               v.decimals, below ? "below" : "above", below ? "minimum" : "maximum",
               below ? *def.min : *def.max);
  if (def.values && !def.values->count(enum_key(def, v.raw)))
    found->add(RuleKind::not_in_enum, v.address, "{} = {} is not one of its named values", v.name,
               v.raw);
}

void decode_span(const DeviceModel& model, Table table, uint16_t start,
                 std::span<const uint16_t> words, bool reported, Meaning& meaning,
                 RuleFindings* found) {
  std::vector<RegisterValue>& out = meaning.registers;
  if (maps_no_register(model)) {  // every word unnamed: nothing to look up
    if (!meaning.lists_unnamed) return;
    for (size_t i = 0; i < words.size(); ++i) {
      RegisterValue& v = out.emplace_back();
      v.table = table;
      v.address = static_cast<uint16_t>(start + i);
      v.raw = words[i];
      v.value = words[i];
    }
    return;
  }
  for (size_t i = 0; i < words.size(); ++i) {
    const auto address = static_cast<uint16_t>(start + i);
    const RegisterLookup lookup = find_register(model, table, address);
    const RegisterDef* def = lookup.def();
    // A parameter the group rule made lives only as long as its lookup: its texts are kept.
    auto model_text = [&](const std::string& text) {
      return lookup.listed || text.empty() ? std::string_view(text) : meaning.keep(text);
    };
    RegisterValue v;
    v.table = table;
    v.address = address;
    v.raw = words[i];
    v.value = words[i];
    if (!def) {
      if (meaning.lists_unnamed) out.push_back(v);
      continue;
    }
    if (def->type == ValueType::raw) {
      v.name = model_text(def->name), v.label = model_text(def->label);
      out.push_back(v);
      continue;
    }
    v.name = lookup.via_alias ? meaning.keep(def->name + " (RAM)") : model_text(def->name);
    v.label = model_text(def->label);
    if (lookup.via_alias)  // say what the alias does: "RAM only, not stored in EEPROM"
      v.label = v.label.empty() ? std::string_view(model.alias->label)
                                : meaning.keep(fmt::format("{} ({})", v.label, model.alias->label));
    v.unit = model_text(def->unit);
    if (def->type == ValueType::string) {
      const size_t n = std::min<size_t>(def->words, words.size() - i);
      v.text = meaning.keep(string_text(words.subspan(i, n)));
      i += n - 1;
      out.push_back(v);
      continue;
    }
    if (def->words > 1 && i + def->words <= words.size()) {
      v.raw = combine(*def, words.subspan(i, def->words));
      i += def->words - 1u;
    }
    v.value = typed_value(*def, v.raw) * def->scale + def->offset;
    v.decimals = decimals_of(*def, v.value);
    v.code = def->type == ValueType::code;
    if (def->values) {
      if (auto it = def->values->find(enum_key(*def, v.raw)); it != def->values->end())
        v.text = it->second;
    } else if (!def->bits.empty()) {
      v.text = meaning.keep(bits_text(*def, v.raw));
    }
    check_value(*def, v, reported, found);
    out.push_back(v);
  }
}

std::string hex_address(uint16_t address) {
  return fmt::format("{:04X}H", address);
}

// The address of the last parameter in the group `address` is in, when the model counts them.
std::optional<uint16_t> group_end(const DeviceModel& model, Table table, uint16_t address) {
  if (!model.groups || model.groups->table != table) return std::nullopt;
  const auto it = model.groups->counts.find(address >> 8);
  if (it == model.groups->counts.end() || it->second == 0 || (address & 0xFF) >= it->second)
    return std::nullopt;
  return static_cast<uint16_t>((address & 0xFF00) | (it->second - 1));
}

void check_limits(const DeviceModel& model, Mode mode, const RegisterAccess& access,
                  RuleFindings& found) {
  if (access.table == Table::coil || access.table == Table::discrete) return;
  const WordLimits& limits = model.limits(mode);
  const uint16_t limit = access.write ? limits.write : limits.read;
  // Beyond the standard's own limit is the function-code table's quantity-out-of-spec; a model
  // speaks only of the tighter limits its device sets.
  const uint16_t standard = access.write ? WordLimits{}.write : WordLimits{}.read;
  if (access.count > limit && limit < standard)
    found.add(RuleKind::too_many_words, access.start, "{} {} registers; {} allows at most {} in {}",
              access.write ? "writes" : "reads", access.count, model.name, limit, to_string(mode));
  const unsigned last = access.start + std::max<unsigned>(access.count, 1) - 1;
  if (!model.same_group_only) return;
  if ((access.start >> 8) != (last >> 8)) {
    found.add(RuleKind::crosses_group, access.start,
              "{}..{} crosses a parameter group; {} allows one group per access",
              hex_address(access.start), hex_address(last & 0xFFFF), model.name);
  } else if (const auto end = group_end(model, access.table, access.start); end && last > *end) {
    // A group ends at its last parameter, not at the next high byte: F03.48 is NTA5000's last.
    found.add(RuleKind::crosses_group, access.start,
              "{}..{} runs past {}, the last of its group; {} allows one "
              "group per access",
              hex_address(access.start), hex_address(last & 0xFFFF), hex_address(*end), model.name);
  }
}

// Whether the model describes `table` at all: the generic model maps nothing, so nothing is
// unmapped there.
bool maps_table(const DeviceModel& model, Table table) {
  if (model.groups && model.groups->table == table) return true;
  const auto it = model.registers.lower_bound({table, 0});
  return it != model.registers.end() && it->first.first == table;
}

void check_registers(const DeviceModel& model, const RegisterAccess& access, RuleFindings& found) {
  if (maps_no_register(model)) return;
  bool closed_reported = false;
  unsigned mapped = 0;
  // A request beyond the standard's limits (2000 coils, 125 registers) is still read, but
  // only as far as the standard goes: a quantity of 65535 must not cost 65535 lookups.
  constexpr unsigned most_checked = 2000;
  const unsigned count = std::min<unsigned>(access.count, most_checked);
  for (unsigned i = 0; i < count && access.start + i <= 0xFFFF; ++i) {
    const auto address = static_cast<uint16_t>(access.start + i);
    const RegisterLookup lookup = find_register(model, access.table, address);
    const RegisterDef* def = lookup.def();
    if (!def) continue;
    ++mapped;
    if (lookup.closed_group && !closed_reported) {
      found.add(RuleKind::closed_group, address,
                "{} is in a group {} does not let a master read or write", def->name, model.name);
      closed_reported = true;
    }
    if (!access.write && (lookup.via_alias || def->access == Access::write)) {
      if (lookup.via_alias)
        found.add(RuleKind::write_only_read, address,
                  "{} is the write-only RAM alias of {}; reading it is invalid",
                  hex_address(address), def->name);
      else
        found.add(RuleKind::write_only_read, address, "{} ({}) is write-only", def->name,
                  hex_address(address));
    } else if (access.write && def->reserved) {
      found.add(RuleKind::reserved_write, address, "{} is reserved: do not write",
                hex_address(address));
    } else if (access.write && def->access == Access::read) {
      found.add(RuleKind::read_only_write, address, "{} ({}) is read-only", def->name,
                hex_address(address));
    }
  }
  // Said only when the access reaches nothing the model knows (000's FC03 example at A023H):
  // a read that runs past a group's end is the group rule's to report.
  if (mapped == 0 && access.count > 0 && maps_table(model, access.table))
    found.add(RuleKind::unmapped_register, access.start, "{} is in none of {}'s tables",
              hex_address(access.start), model.name);
}

// Addresses 248-255 are reserved by Modbus over Serial Line (2.2); a model may still allow
// them (N3: stations 1-254). Said of every frame to such an address; a station the model
// does not allow otherwise is said of the request.
void check_station(const DeviceModel& model, const Frame& frame, RuleFindings& found) {
  constexpr uint8_t first_reserved = 248;
  const uint8_t slave = frame.slave();
  if (slave == 0 || (slave >= model.station_min && slave <= model.station_max)) return;
  if (slave >= first_reserved) {
    found.add(RuleKind::reserved_address, std::nullopt,
              "address {} is reserved by Modbus (248-255); {} allows {}..{}", slave, model.name,
              model.station_min, model.station_max);
  } else if (frame.role == Role::request) {
    found.add(RuleKind::station_out_of_range, std::nullopt,
              "station {} is outside {}'s range {}..{}", slave, model.name, model.station_min,
              model.station_max);
  }
}

void explain_exception(const DeviceModel& model, const Frame& frame, RuleFindings& found) {
  const uint8_t code = frame.adu[2];
  const auto it = model.exceptions.find(code);
  if (it != model.exceptions.end())
    found.add(RuleKind::exception, std::nullopt, "{}exception {:02X}H: {} ({})",
              model.vendor_exceptions ? "vendor " : "", code, it->second, model.name);
  else if (maps_no_register(model))  // no device knowledge: the standard's table is all there is
    found.add(RuleKind::exception, std::nullopt,
              "exception {:02X}H is not a standard Modbus exception code (no model for slave {})",
              code, frame.device());
  else
    found.add(RuleKind::exception, std::nullopt,
              "exception {:02X}H is in neither the standard's table nor {}'s", code, model.name);
}

// Coils and discrete inputs, LSB of the first byte first. Only the bits the model names are
// listed: a read of 2000 coils of an unknown device would bury the line.
void decode_bits(const DeviceModel& model, Table table, uint16_t start,
                 std::span<const uint8_t> packed, size_t count, std::vector<RegisterValue>& out) {
  if (maps_no_register(model)) return;  // only named bits are listed
  for (size_t i = 0; i < count && i / 8 < packed.size(); ++i) {
    const auto address = static_cast<uint16_t>(start + i);
    const RegisterLookup lookup = find_register(model, table, address);
    const RegisterDef* def = lookup.listed;
    if (!def) continue;
    RegisterValue v;
    v.table = table;
    v.address = address;
    v.name = def->name;
    v.label = def->label;
    v.raw = (packed[i / 8] >> (i % 8)) & 1;
    v.value = v.raw;
    if (def->values)
      if (auto it = def->values->find(v.raw); it != def->values->end()) v.text = it->second;
    out.push_back(v);
  }
}

// The values an access carries, in the model's terms: words, packed bits, or FC05's state.
void decode_values(const DeviceModel& model, const RegisterAccess& access, Meaning& out,
                   RuleFindings* found) {
  switch (access.data) {
    case RegisterAccess::Data::none:
      return;
    case RegisterAccess::Data::words: {
      WordBuffer buffer;
      decode_span(model, access.table, access.start, words_of(access.values, buffer), !access.write,
                  out, found);
      return;
    }
    case RegisterAccess::Data::bits:
      decode_bits(model, access.table, access.start, access.values, access.count, out.registers);
      return;
    case RegisterAccess::Data::coil_state: {
      const uint16_t state = be16(access.values, 0);
      if (state != 0xFF00 && state != 0x0000) return;
      const uint8_t bit = state == 0xFF00 ? 1 : 0;
      decode_bits(model, access.table, access.start, {&bit, 1}, 1, out.registers);
      return;
    }
  }
}

void interpret_request(const DeviceModel& model, const Frame& frame, Meaning& meaning) {
  if (model.retries && frame.retries > *model.retries)
    meaning.findings.add(RuleKind::too_many_retries, std::nullopt,
                         "retry {} of an unanswered request; {} masters retry at most {} times",
                         frame.retries, model.name, *model.retries);
  const auto pdu = frame.pdu();
  for (const RegisterAccess& access : function_code(frame.function()).request_accesses(pdu)) {
    check_limits(model, frame.mode, access, meaning.findings);
    check_registers(model, access, meaning.findings);
    decode_values(model, access, meaning, &meaning.findings);
  }
}

// A write's good answer confirms what its request wrote: an echo says it again, other answers
// (FC15, FC16, FC17's write) only acknowledge, so the values are read from the request. They were
// checked against the model there; a read's values are checked here.
void interpret_response(const DeviceModel& model, const Frame& frame, Meaning& meaning) {
  const auto pdu = frame.pdu();
  if (pdu.empty()) return;
  const auto values = function_code(pdu[0]).response_values(pdu, frame.request_pdu);
  if (values && values->write) return decode_values(model, *values, meaning, nullptr);
  if (!frame.request_pdu.empty() && !(frame.findings & response_misfit))
    for (const RegisterAccess& access :
         function_code(frame.request_pdu[0]).request_accesses(frame.request_pdu))
      if (access.write) decode_values(model, access, meaning, nullptr);
  if (values) decode_values(model, *values, meaning, &meaning.findings);
}

}  // namespace

void decode_registers(const DeviceModel& model, Table table, uint16_t start,
                      std::span<const uint16_t> words, Meaning& out) {
  decode_span(model, table, start, words, false, out, nullptr);
}

Meaning interpret(const DeviceModel& model, const Frame& frame) {
  Meaning meaning;
  interpret(model, frame, meaning);
  return meaning;
}

void interpret(const DeviceModel& model, const Frame& frame, Meaning& meaning) {
  meaning.clear();
  meaning.model = &model;
  // A frame with a bad check may carry any byte changed: its values, exception code and
  // address are no evidence against the model's rules.
  if (frame.adu.size() < 2 + frame.check_size() || !frame.check_ok) return;
  check_station(model, frame, meaning.findings);
  if (frame.is_exception()) {
    if (frame.role != Role::request) explain_exception(model, frame, meaning.findings);
    return;
  }
  if (frame.role == Role::request) interpret_request(model, frame, meaning);
  if (frame.role == Role::response) interpret_response(model, frame, meaning);
}

void append_number(fmt::memory_buffer& out, double value, int decimals) {
  // Most registers hold whole numbers: printed as integers they skip fmt's float path.
  constexpr double exact_integers = 9007199254740992.0;  // 2^53
  if (decimals == 0 && value == std::trunc(value) && std::fabs(value) < exact_integers &&
      !std::signbit(value)) {
    put_int(out, static_cast<int64_t>(value));
  } else {
    fmt::format_to(fmt::appender(out), FMT_COMPILE("{:.{}f}"), value, decimals);
  }
}

void append_value_text(fmt::memory_buffer& out, const RegisterValue& reg) {
  auto put = fmt::appender(out);
  if (reg.code) {
    if (reg.text.empty()) {
      fmt::format_to(put, "{:04X}H", reg.raw);
    } else {
      fmt::format_to(put, "{} ({:04X}H)", reg.text, reg.raw);
    }
    return;
  }
  if (!reg.text.empty() && reg.unit.empty()) {
    fmt::format_to(put, "{} ({})", reg.text, reg.raw);
    return;
  }
  if (std::isfinite(reg.value)) {
    append_number(out, reg.value, reg.decimals);
  } else {
    fmt::format_to(put, "{}", reg.value);
  }
  if (!reg.unit.empty()) fmt::format_to(put, " {}", reg.unit);
  if (!reg.text.empty()) fmt::format_to(put, " ({})", reg.text);
}

}  // namespace modtap
