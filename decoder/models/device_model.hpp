// A device model: what a slave's registers mean and which rules its manual sets. Models are
// data (plugins/models/*.yaml, read by model_yaml); nothing here knows a model by name.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "decoder/protocol/function_codes.hpp"
#include "decoder/protocol/records.hpp"

namespace modtap {

// `code`: a 16-bit value the manual writes in hex (an identifying code, 0106H), shown so.
enum class ValueType : uint8_t { u16, s16, u32, s32, f32, u64, s64, bcd, string, code, raw };
template <>
struct EnumNames<ValueType> {  // as a model file writes them
  static constexpr std::array<std::string_view, 11> names{
      "u16", "s16", "u32", "s32", "f32", "u64", "s64", "bcd", "string", "code", "raw"};
};

// The registers a number of the type spans, where the type fixes them (0: the model's `words`).
constexpr uint16_t words_of_type(ValueType type) {
  switch (type) {
    case ValueType::u32:
    case ValueType::s32:
    case ValueType::f32:
      return 2;
    case ValueType::u64:
    case ValueType::s64:
      return 4;
    default:
      return 0;
  }
}
enum class Access : uint8_t { read, write, read_write };
enum class WordOrder : uint8_t { high_first, low_first };
template <>
struct EnumNames<WordOrder> {
  static constexpr std::array<std::string_view, 2> names{"high_first", "low_first"};
};

using EnumTable = std::map<int64_t, std::string>;

// One bit (width 1) or a run of bits inside a register, and what its values mean.
struct BitField {
  uint8_t lsb = 0;
  uint8_t width = 1;
  std::string name;
  std::map<uint32_t, std::string> values;  // for a one-bit flag, often just {1: "run"}
};

struct RegisterDef {
  uint16_t address = 0;
  Table table = Table::holding;
  std::string name;   // identifier-like: frequency_command, F01.05
  std::string label;  // the manual's words
  ValueType type = ValueType::u16;
  WordOrder order = WordOrder::high_first;
  uint16_t words = 1;
  double scale = 1.0;
  double offset = 0.0;
  std::string unit;
  Access access = Access::read_write;
  std::optional<double> min;
  std::optional<double> max;
  std::shared_ptr<const EnumTable> values;  // named values, often shared between registers
  std::vector<BitField> bits;
  bool reserved = false;  // "do not write"
  bool fault = false;     // the device's fault register: any value but 0 is a fault it reports
};

// Parameters numbered by rule: name PREFIX GG.nn at address GGnnH (GG and nn in hex).
struct ParameterGroups {
  std::string prefix = "P";
  std::map<unsigned, unsigned> counts;  // group -> parameters in it; empty: any up to the maxima
  unsigned max_group = 99;
  unsigned max_index = 99;
  std::set<unsigned> closed;  // groups that cannot be read or written (factory groups)
  Access access = Access::read_write;
  Table table = Table::holding;
};

// An address with `flag` set reaches the same parameter, but writes RAM only and cannot be read.
struct WriteOnlyAlias {
  uint16_t flag = 0x8000;
  std::string label;
};

struct WordLimits {
  uint16_t read = 125;
  uint16_t write = 123;
};

// A register value that names the device (GD20 answers 0x0106 at 2103H).
struct Identification {
  uint16_t address = 0;
  uint16_t value = 0;
};

struct DeviceModel {
  std::string name;
  std::string title;
  std::string source;  // the manual it was transcribed from
  uint8_t station_min = 1;
  uint8_t station_max = 247;
  std::map<uint8_t, std::string> exceptions;
  bool vendor_exceptions = false;  // the codes mean what the vendor says, not what Modbus says
  WordLimits rtu_limits;
  WordLimits ascii_limits;
  // How long the master waits for a response, and how often it then asks again (N3: 400 ms,
  // 2 retries): modtap's time-out for these slaves unless --timeout is given.
  std::optional<int64_t> response_timeout_ns;
  std::optional<uint8_t> retries;
  // The least time between a request and the device's answer, where the manual sets one
  // (NTA5000, N3: 10 ms).
  std::optional<int64_t> min_turnaround_ns;
  bool same_group_only = false;  // a multi-register access must stay inside one GGxxH block
  std::optional<ParameterGroups> groups;
  std::optional<WriteOnlyAlias> alias;
  std::optional<Identification> identification;
  std::map<std::pair<Table, uint16_t>, RegisterDef> registers;

  const WordLimits& limits(Mode mode) const {
    return mode == Mode::rtu ? rtu_limits : ascii_limits;
  }
};

// What a model says about one address: its definition, or nothing, and how it was reached.
struct RegisterLookup {
  const RegisterDef* listed = nullptr;  // a register the model lists
  std::optional<RegisterDef> made;      // or a parameter made by the group rule
  bool via_alias = false;               // reached through the write-only alias
  bool closed_group = false;            // a parameter group the device keeps to itself

  const RegisterDef* def() const { return listed ? listed : made ? &*made : nullptr; }
};

RegisterLookup find_register(const DeviceModel& model, Table table, uint16_t address);
// The generic model: every lookup finds nothing, so a loop of them can be skipped.
inline bool maps_no_register(const DeviceModel& model) {
  return model.registers.empty() && !model.groups;
}

// Whether the model calls a register so: a listed one, or a parameter its group rule names.
bool names_register(const DeviceModel& model, std::string_view name);

// The model's meaning of an exception code (GD20's 04H: "Operation failed ..."), empty where the
// model gives the code none and the standard's name stands.
std::string_view exception_meaning(const DeviceModel& model, uint8_t code);

}  // namespace modtap
