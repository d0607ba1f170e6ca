#include "decoder/analysis/register_discovery.hpp"

#include <fmt/format.h>
#include <algorithm>
#include <bit>
#include <cmath>

#include "decoder/protocol/bytes.hpp"
#include "decoder/protocol/function_codes.hpp"

namespace modtap {
namespace {

// A float a device reports: a number of everyday size, or exactly zero. An integer's bits read
// as a float are almost always tiny (a zero high word), NaN, or absurdly large.
bool plausible_float(uint32_t bits) {
  if ((bits & 0x7FFFFFFF) == 0) return true;
  const unsigned exponent = (bits >> 23) & 0xFF;
  if (exponent == 0 || exponent == 0xFF) return false;
  const double size = std::fabs(std::bit_cast<float>(bits));
  return size >= 1e-6 && size <= 1e9;
}

// The quantities a value's size and sign name on their own, the types a device stores each in,
// and the scales it stores integers at. The first that fits names the register; a value that
// fits none keeps a plain name.
enum TypeSet : uint8_t { u16_type = 1, s16_type = 2, int32_types = 4, f32_type = 8 };
struct Quantity {
  std::string_view name;
  std::string_view unit;
  double low, high;   // the values, scaled, lie inside
  double extent = 0;  // the largest size among them is at least this
  bool crosses_zero = false;
  uint8_t types = u16_type | int32_types | f32_type;
  std::array<double, 3> scales{1.0, 0.1, 0.01};  // for integers; a float's is 1
};
const std::array<Quantity, 7> quantities{{
    {"voltage", "V", 207, 253},   // 230 V, +-10 %
    {"voltage", "V", 360, 440},   // 400 V between phases
    {"frequency", "Hz", 49, 51},  // 50 Hz mains, as a meter or a drive on mains sees it
    {"frequency", "Hz", 59, 61},
    // A float within -1..1 that is mostly near 1: a power factor (a cosine phi).
    {"power_factor", "", -1, 1, 0.5, false, f32_type, {1, 1, 1}},
    // A 32-bit value across zero, in the hundreds and more: power imported and exported.
    {"power", "W", -1e7, 1e7, 100, true, int32_types | f32_type, {1, 1, 1}},
    // A signed 16-bit value across zero, in tenths between -40 and 60: a temperature.
    {"temperature", "\u00B0C", -40, 60, 0, true, s16_type, {0.1, 0.1, 0.1}},
}};

uint8_t type_set(ValueType type) {
  switch (type) {
    case ValueType::u16:
      return u16_type;
    case ValueType::s16:
      return s16_type;
    case ValueType::u32:
    case ValueType::s32:
      return int32_types;
    case ValueType::f32:
      return f32_type;
    default:
      return 0;
  }
}

bool fits(const Quantity& q, const RegisterReading& r, double scale) {
  const double low = r.low * scale, high = r.high * scale;
  return (q.types & type_set(r.type)) && low >= q.low && high <= q.high &&
         std::max(std::fabs(low), std::fabs(high)) >= q.extent &&
         (!q.crosses_zero || (low < 0 && high > 0));
}

// Names the quantity the values [low, high] of a moving number fit, if one does.
void name_quantity(RegisterReading& r) {
  const bool integer = r.type != ValueType::f32;
  for (const Quantity& q : quantities)
    for (const double scale : integer ? std::span(q.scales) : std::span(q.scales).first(1)) {
      if (!fits(q, r, scale)) continue;
      r.quantity = q.name;
      r.unit = q.unit;
      r.scale = scale;
      r.low *= scale;
      r.high *= scale;
      return;
    }
}

std::string times(uint64_t n) {
  return n == 1 ? "once" : fmt::format("{} times", n);
}

std::string values_list(const WordHistory& h) {
  std::vector<uint16_t> values(h.distinct.begin(), h.distinct.begin() + h.distinct_count);
  std::sort(values.begin(), values.end());
  std::string text;
  for (const uint16_t v : values) text += fmt::format("{}{}", text.empty() ? "" : ", ", v);
  return text;
}

bool contiguous(const WordHistory& h) {
  return !h.many_values && h.max - h.min + 1u == h.distinct_count;
}

RegisterReading reading(ValueType type, ReadingKind kind, Confidence confidence, std::string why,
                        std::string runner_up = {}) {
  RegisterReading r;
  r.type = type;
  r.kind = kind;
  r.confidence = confidence;
  r.why = std::move(why);
  r.runner_up = std::move(runner_up);
  return r;
}

// A register that never moved: unused where it reads 0, else a constant.
RegisterReading read_constant(const WordHistory& h) {
  RegisterReading r = h.first == 0
                          ? reading(ValueType::u16, ReadingKind::unused, Confidence::medium,
                                    fmt::format("0 in all {} values", h.samples),
                                    "a value that did not move while captured")
                          : reading(ValueType::u16, ReadingKind::constant, Confidence::medium,
                                    fmt::format("{} in all {} values", h.first, h.samples),
                                    "a setting or an identifier");
  r.low = r.high = h.first;
  return r;
}

// Small numbers of both signs: FFxxH beside 00xxH.
bool signed_small(const WordHistory& h) {
  return h.max >= 0xF000 && (h.min < 0x1000 || h.min >= 0x8000);
}

RegisterReading read_moving(const WordHistory& h) {
  if (signed_small(h)) {
    RegisterReading r = reading(
        ValueType::s16, ReadingKind::number, h.min < 0x1000 ? Confidence::high : Confidence::medium,
        h.min < 0x1000 ? "values near 0 on both sides (FFxxH and 00xxH): a signed number"
                       : "values just below 0 as a signed number (FxxxH)",
        "u16");
    r.low = h.signed_min;
    r.high = h.signed_max;
    return r;
  }
  const uint16_t changing = h.changing_bits();
  const bool low_bits = (changing & (changing + 1)) == 0;  // bits 0..n, as a number's change
  RegisterReading r;
  // Bits of a status word change each on its own, so the values seen cover most combinations of
  // the bits that change; an enum's few values cover few of them.
  const int changing_count = std::popcount(changing);
  const size_t seen = h.many_values ? WordHistory::max_distinct + 1 : h.distinct_count;
  const bool independent = 2 * seen > (size_t{1} << std::min(changing_count, 5));
  if (!low_bits && !contiguous(h) && independent) {
    r = reading(ValueType::code, ReadingKind::bit_field, Confidence::medium,
                fmt::format("bits that change on their own (mask {:04X}H), not as a number's "
                            "lowest bits",
                            changing),
                "an enum");
  } else if (h.falls == 0 && h.rises >= 3) {
    r = reading(ValueType::u16, ReadingKind::counter,
                h.rises >= 8 ? Confidence::high : Confidence::medium,
                fmt::format("it only grew, {} in {} values", times(h.rises), h.samples), "u16");
  } else if (!h.many_values && h.distinct_count <= 6 && !contiguous(h)) {
    r = reading(ValueType::u16, ReadingKind::enumerated, Confidence::medium,
                fmt::format("{} values, apart: {}", h.distinct_count, values_list(h)), "u16");
  } else {
    const bool few = !h.many_values && h.distinct_count <= 4;
    r = reading(ValueType::u16, ReadingKind::number, few ? Confidence::low : Confidence::medium,
                few ? fmt::format("{} values in a row: {}", h.distinct_count, values_list(h))
                    : fmt::format("values that move from {} to {}", h.min, h.max),
                few ? "an enum" : (h.max >= 0x8000 ? "s16" : ""));
  }
  r.low = h.min;
  r.high = h.max;
  return r;
}

// Which of two orders reads the pair as the likelier float, if either does.
std::optional<RegisterReading> read_float(const std::array<PairHistory, 2>& pair) {
  auto fits = [](const PairHistory& p) {
    return p.samples && p.floats == p.samples && p.samples - p.zeros >= 3;
  };
  // A pair that never moves is a constant, whatever it reads as: a float's evidence is its
  // values over time.
  const bool high = fits(pair[0]) && pair[0].rises + pair[0].falls > 0;
  const bool low = fits(pair[1]) && pair[1].rises + pair[1].falls > 0;
  if (!high && !low) return std::nullopt;
  auto smoothness = [](const PairHistory& p) { return p.float_jumps / double(p.samples); };
  const size_t o =
      high && low ? (smoothness(pair[1]) < smoothness(pair[0]) ? 1 : 0) : (low ? 1 : 0);
  const PairHistory& p = pair[o];
  // A measured quantity moves by small steps against its size; an integer's bits read as a
  // float jump. As it moves, its mantissa's low word moves too: where that word never did, the
  // pair is likelier a value beside a constant (or a float of whole numbers).
  const bool smooth = smoothness(p) < 0.2;
  const bool mantissa_moves = p.low_changes > 0;
  const Confidence confidence = (high && low) || !mantissa_moves ? Confidence::low
                                : smooth                         ? Confidence::high
                                                                 : Confidence::medium;
  const std::string runner_up = high && low ? fmt::format("f32 {} word first", o ? "high" : "low")
                                : mantissa_moves ? "two u16"
                                                 : "a 16-bit value beside a constant";
  RegisterReading r =
      reading(ValueType::f32, ReadingKind::number, confidence,
              fmt::format("every read is a float of everyday size ({:g} to {:g}){}", p.float_min,
                          p.float_max, smooth ? ", moving smoothly" : ""),
              runner_up);
  r.order = o ? WordOrder::low_first : WordOrder::high_first;
  r.words = 2;
  r.low = p.float_min;
  r.high = p.float_max;
  name_quantity(r);
  return r;
}

// A 32-bit integer in one word order: its high word is not always 0, and moves only as the low
// word's carry or borrow moves it (the boundary and the order show in how often each word
// changes). A high word that never moves leaves two 16-bit values as likely.
std::optional<RegisterReading> read_integer(const std::array<PairHistory, 2>& pair) {
  for (size_t o = 0; o < pair.size(); ++o) {
    const PairHistory& p = pair[o];
    if ((p.max >> 16) == 0 || p.rises + p.falls == 0 || p.high_changes != p.carries) continue;
    // A high word that never moved beside a measurement moving up and down is two values; beside
    // one that only grows, a counter that has not carried yet.
    if (p.high_changes == 0 && p.falls > 0) continue;
    const bool negative = p.signed_min < 0 && (p.max >> 16) == 0xFFFF &&
                          ((p.min >> 16) == 0xFFFF || (p.min >> 16) == 0);
    const bool counter = !negative && p.falls == 0 && p.rises >= 3;
    const bool carried = p.high_changes > 0;
    const std::string grew = counter ? "it only grew; " : "";
    // One carry may be chance; two that each came with the low word's wrap are the number's.
    const Confidence confidence = p.high_changes >= 2 ? Confidence::high
                                  : carried           ? Confidence::medium
                                                      : Confidence::low;
    RegisterReading r =
        reading(negative ? ValueType::s32 : ValueType::u32,
                counter ? ReadingKind::counter : ReadingKind::number, confidence,
                carried ? fmt::format("{}its high word moved {}, each time as its low word wrapped",
                                      grew, times(p.high_changes))
                        : grew + "a counter whose high word has not moved yet",
                carried ? "" : "two u16, a constant beside a value");
    r.order = o ? WordOrder::low_first : WordOrder::high_first;
    r.words = 2;
    r.low = negative ? static_cast<double>(p.signed_min) : static_cast<double>(p.min);
    r.high = negative ? static_cast<double>(p.signed_max) : static_cast<double>(p.max);
    return r;
  }
  return std::nullopt;
}

// Printable ASCII in both bytes, or a NUL that pads a string.
bool text_word(uint16_t word) {
  auto text = [](uint8_t c) { return c == 0 || (c >= 0x20 && c < 0x7F); };
  return word != 0 && text(static_cast<uint8_t>(word >> 8)) && text(static_cast<uint8_t>(word));
}

}  // namespace

void WordHistory::add(uint16_t value) {
  if (samples == 0) first = value;
  if (samples > 0 && value != last) {
    ++changes;
    ++(value > last ? rises : falls);
    for (unsigned flipped = value ^ last; flipped; flipped &= flipped - 1)
      ++bit_changes[static_cast<size_t>(std::countr_zero(flipped))];
  }
  ++samples;
  last = value;
  min = std::min(min, value);
  max = std::max(max, value);
  signed_min = std::min(signed_min, static_cast<int16_t>(value));
  signed_max = std::max(signed_max, static_cast<int16_t>(value));
  if (many_values) return;
  if (std::find(distinct.begin(), distinct.begin() + distinct_count, value) !=
      distinct.begin() + distinct_count)
    return;
  if (distinct_count == max_distinct)
    many_values = true;
  else
    distinct[distinct_count++] = value;
}

uint16_t WordHistory::changing_bits() const {
  uint16_t mask = 0;
  for (unsigned bit = 0; bit < 16; ++bit)
    if (bit_changes[bit]) mask = static_cast<uint16_t>(mask | 1u << bit);
  return mask;
}

void PairHistory::add(uint32_t value) {
  if (plausible_float(value)) {
    const double v = std::bit_cast<float>(value);
    if (floats == 0) float_min = float_max = v;
    float_min = std::min(float_min, v);
    float_max = std::max(float_max, v);
    if (samples) {
      const double before = std::bit_cast<float>(last);
      const double larger = std::max(std::fabs(v), std::fabs(before));
      if (larger > 0 && plausible_float(last)) float_jumps += std::fabs(v - before) / larger;
    }
    ++floats;
  }
  if ((value & 0x7FFFFFFF) == 0) ++zeros;
  if (samples && value != last) ++(value > last ? rises : falls);
  const auto high = static_cast<uint16_t>(value >> 16), low = static_cast<uint16_t>(value);
  const auto high_before = static_cast<uint16_t>(last >> 16),
             low_before = static_cast<uint16_t>(last);
  if (samples && low != low_before) ++low_changes;
  if (samples && high != high_before) {
    ++high_changes;
    // The low word wrapped: it went the other way by more than half its range.
    const bool carry = static_cast<uint16_t>(high - high_before) == 1 && low_before - low >= 0x8000;
    const bool borrow =
        static_cast<uint16_t>(high_before - high) == 1 && low - low_before >= 0x8000;
    carries += carry || borrow;
  }
  min = std::min(min, value);
  max = std::max(max, value);
  signed_min = std::min(signed_min, static_cast<int32_t>(value));
  signed_max = std::max(signed_max, static_cast<int32_t>(value));
  ++samples;
  last = value;
}

std::optional<int64_t> BlockTimes::period_ns() const {
  if (requests < 2) return std::nullopt;
  return (last_ns - first_ns) / static_cast<int64_t>(requests - 1);
}

RegisterReading read_word(const WordHistory& h) {
  RegisterReading r = h.changes == 0 ? read_constant(h) : read_moving(h);
  r.samples = h.samples;
  if (r.kind == ReadingKind::number) name_quantity(r);
  return r;
}

// A register the master writes and does not read (often): read from the values it writes, which
// say less than a device's answers over time.
RegisterReading read_written(uint16_t address, Table table, const WordHistory& written) {
  // Too few to draw a reading from: what was written, as a plain number.
  RegisterReading r =
      written.samples >= RegisterDiscovery::min_samples
          ? read_word(written)
          : reading(ValueType::u16, ReadingKind::number, Confidence::low, values_list(written));
  if (written.samples < RegisterDiscovery::min_samples) {
    r.low = written.min;
    r.high = written.max;
    r.samples = written.samples;
  }
  r.address = address;
  r.table = table;
  r.writes = written.samples;
  r.why = fmt::format("written {}: {}", times(written.samples), r.why);
  return r;
}

std::optional<RegisterReading> read_pair(const std::array<PairHistory, 2>& pair) {
  std::optional<RegisterReading> r = read_float(pair);
  if (!r) r = read_integer(pair);
  // A 32-bit counter that only grows is most often an energy: named so, its unit and scale
  // (Wh, 0.1 kWh...) left to the manual, as no value tells them.
  if (r && r->kind == ReadingKind::counter) r->quantity = "energy";
  if (r && r->kind == ReadingKind::number && r->type != ValueType::f32) name_quantity(*r);
  if (r) r->samples = pair[0].samples;
  return r;
}

// The block a request reads or writes: its function code and its first access's registers (or
// bits), as the function code's table places them.
BlockKey RegisterDiscovery::block_of(uint8_t slave, std::span<const uint8_t> pdu) {
  if (pdu.empty()) return {slave, 0, 0, 0};
  const RegisterAccesses accesses = function_code(pdu[0]).request_accesses(pdu);
  if (accesses.size == 0) return {slave, pdu[0], 0, 0};
  return {slave, pdu[0], accesses.list[0].start, accesses.list[0].count};
}

// The values a good answer confirms, as the model stage reads them (register_meaning.cpp): a
// write's from its echo, or from its request where the answer only acknowledges; a read's from
// the answer.
void RegisterDiscovery::on_frame(const Frame& frame) {
  if (!frame.check_ok || frame.is_exception()) return;
  if (frame.role == Role::request) return on_request(frame);
  if (frame.role != Role::response || frame.request_pdu.empty()) return;
  const uint8_t slave = frame.device();
  if (const auto block = blocks_.find(block_of(slave, frame.request_pdu)); block != blocks_.end())
    ++block->second.answered;
  const std::span<const uint8_t> pdu = frame.pdu();
  if (pdu.empty() || (frame.findings & response_misfit)) return;
  const std::optional<RegisterAccess> values =
      function_code(pdu[0]).response_values(pdu, frame.request_pdu);
  if (!values || !values->write)
    for (const RegisterAccess& access :
         function_code(frame.request_pdu[0]).request_accesses(frame.request_pdu))
      if (access.write) on_access(slave, access);
  if (values) on_access(slave, *values);
}

void RegisterDiscovery::on_access(uint8_t slave, const RegisterAccess& access) {
  if (access.data == RegisterAccess::Data::words)
    on_values(slave, access.table, access.start, access.values, access.write);
}

// The block a request reads or writes, with its time: the blocks' periods, the polling program.
void RegisterDiscovery::on_request(const Frame& frame) {
  const BlockKey key = block_of(frame.slave(), frame.pdu());
  BlockTimes& times = blocks_[key];
  if (times.requests == 0) {
    times.first_ns = frame.t_ns;
  } else {
    const int64_t gap = frame.t_ns - times.last_ns;
    times.min_gap_ns = std::min(times.min_gap_ns, gap);
    times.max_gap_ns = std::max(times.max_gap_ns, gap);
  }
  times.last_ns = frame.t_ns;
  ++times.requests;
  if (requests_.size() < program_window) requests_.emplace_back(key, frame.t_ns);
}

void RegisterDiscovery::on_values(uint8_t slave, Table table, uint16_t first,
                                  std::span<const uint8_t> data, bool written) {
  const size_t count = data.size() / 2;
  auto at = words_.lower_bound({slave, table, first});
  for (size_t i = 0; i < count; ++i) {
    const WordKey key{slave, table, static_cast<uint16_t>(first + i)};
    // A block's registers are neighbours in the map: each found from the one before.
    if (at == words_.end() || !(at->first == key)) {
      if (words_.size() >= max_registers) {
        ++registers_not_followed_;
        continue;
      }
      at = words_.try_emplace(at, key);
    }
    Words& words = at->second;
    ++at;
    const uint16_t value = be16(data, 2 * i);
    if (written) {
      words.written.add(value);
      continue;
    }
    words.history.add(value);
    if (i + 1 == count) continue;
    const uint16_t next = be16(data, 2 * i + 2);
    words.pairs[0].add(uint32_t{value} << 16 | next);
    words.pairs[1].add(uint32_t{next} << 16 | value);
    ++words.pair_samples;
  }
}

std::vector<SlaveDraft> RegisterDiscovery::drafts() const {
  std::vector<SlaveDraft> drafts;
  for (auto it = words_.begin(); it != words_.end();) {
    const uint8_t slave = it->first.slave;
    drafts.push_back(draft_of(slave));
    if (slave == UINT8_MAX) break;
    it = words_.lower_bound({static_cast<uint8_t>(slave + 1), Table::coil, 0});
  }
  return drafts;
}

SlaveDraft RegisterDiscovery::draft_of(uint8_t slave) const {
  SlaveDraft draft;
  draft.slave = slave;
  for (auto it = blocks_.lower_bound({slave, 0, 0, 0});
       it != blocks_.end() && it->first.slave == slave; ++it)
    draft.blocks.push_back({it->first, it->second});
  for (const Table table : {Table::holding, Table::input}) {
    std::vector<RegisterReading> readings = readings_of(slave, table);
    draft.registers.insert(draft.registers.end(), readings.begin(), readings.end());
  }
  for (auto it = words_.lower_bound({slave, Table::coil, 0});
       it != words_.end() && it->first.slave == slave; ++it)
    if (it->second.history.samples < min_samples && it->second.written.samples == 0)
      draft.too_few_samples.emplace_back(it->first.table, it->first.address);
  return draft;
}

std::vector<RegisterReading> RegisterDiscovery::readings_of(uint8_t slave, Table table) const {
  std::vector<RegisterReading> readings;
  auto it = words_.lower_bound({slave, table, 0});
  auto in_table = [&](auto at) {
    return at != words_.end() && at->first.slave == slave && at->first.table == table;
  };
  // The register at `at` and the next read as one number, where both were read together every
  // time and often enough.
  auto pair_at = [&](auto at) -> std::optional<RegisterReading> {
    if (!in_table(at)) return std::nullopt;
    const auto after = std::next(at);
    const Words& words = at->second;
    if (!in_table(after) || after->first.address != at->first.address + 1 ||
        words.history.samples < min_samples || words.pair_samples != words.history.samples ||
        after->second.history.samples != words.history.samples)
      return std::nullopt;
    return read_pair(words.pairs);
  };
  for (; in_table(it); ++it) {
    const auto& [key, words] = *it;
    if (words.history.samples < min_samples) {
      if (words.written.samples) {
        readings.push_back(read_written(key.address, table, words.written));
        readings.back().write_only = words.history.samples == 0;
      }
      continue;
    }
    const auto next = std::next(it);
    // A run of constant registers of text: a name, a serial number.
    uint16_t run = 0;
    for (auto at = it; in_table(at) && at->first.address == key.address + run &&
                       at->second.history.changes == 0 && text_word(at->second.history.first);
         ++at)
      ++run;
    std::optional<RegisterReading> r;
    if (run >= 2) {
      r = reading(ValueType::string, ReadingKind::text, Confidence::high,
                  fmt::format("{} registers of printable text that never changed", run));
      r->words = run;
      r->samples = words.history.samples;
    } else if (std::optional<RegisterReading> pair = pair_at(it)) {
      // The register after may begin a likelier pair: this one is then read alone.
      const std::optional<RegisterReading> after = pair_at(next);
      if (!after || after->confidence <= pair->confidence) r = pair;
    }
    if (!r) r = read_word(words.history);
    r->address = key.address;
    r->table = table;
    r->writes = words.written.samples;
    readings.push_back(*r);
    for (uint16_t claimed = 1; claimed < r->words && in_table(std::next(it)); ++claimed) ++it;
  }
  return readings;
}

// The requests of one cycle: what the master sends from its first request to the next time it
// sends it, most often (a retry, a broadcast between, a slave skipped change a few cycles).
PollingProgram RegisterDiscovery::polling_program() const {
  const std::vector<std::pair<BlockKey, int64_t>>& sent = requests_;
  PollingProgram program;
  std::vector<size_t> starts;
  for (size_t i = 0; i < sent.size(); ++i)
    if (sent[i].first == sent.front().first) starts.push_back(i);
  std::map<std::vector<BlockKey>, size_t> cycles;
  for (size_t c = 1; c < starts.size(); ++c) {
    std::vector<BlockKey> cycle;
    for (size_t i = starts[c - 1]; i < starts[c]; ++i) cycle.push_back(sent[i].first);
    ++cycles[cycle];
  }
  const auto most =
      std::max_element(cycles.begin(), cycles.end(),
                       [](const auto& a, const auto& b) { return a.second < b.second; });
  if (most == cycles.end() || most->second < 2) return program;
  program.cycle = most->first;
  program.cycles_seen = most->second;
  program.cycles_all = starts.size() - 1;
  program.period_ns = (sent[starts.back()].second - sent[starts.front()].second) /
                      static_cast<int64_t>(starts.size() - 1);
  int64_t narrowest = INT64_MAX, widest = 0;
  for (size_t c = 1; c < starts.size(); ++c) {
    const int64_t gap = sent[starts[c]].second - sent[starts[c - 1]].second;
    narrowest = std::min(narrowest, gap);
    widest = std::max(widest, gap);
  }
  program.jitter_ns = widest - narrowest;
  return program;
}

}  // namespace modtap
