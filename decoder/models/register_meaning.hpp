// A frame read through a device model: its registers as named, scaled values, and the model's
// rules it breaks. Pure: the model and the frame in, a Meaning out.
#pragma once

#include <cstdint>
#include <iterator>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "decoder/models/device_model.hpp"
#include "decoder/protocol/records.hpp"

namespace modtap {

// Its texts point into the model, or into the Meaning that holds it where they are composed.
struct RegisterValue {
  Table table = Table::holding;
  uint16_t address = 0;
  std::string_view name;   // empty for a register the model does not know
  std::string_view label;  // the manual's words
  uint64_t raw = 0;        // the register, or all the words of a 32- or 64-bit value
  double value = 0;        // raw, signed by type, scaled and offset
  int decimals = 0;        // digits after the point: the scale's, or a float's own
  std::string_view unit;
  std::string_view text;  // an enum's meaning, the set bits' names, or a string register's text
  bool code = false;      // shown in hex as the manual writes it (0106H)
};

// Texts composed for one frame, in storage reused from frame to frame: once warm, composing
// one allocates nothing. Each stays put, through moves too, until clear().
class ComposedTexts {
 public:
  std::string& next() {
    while (texts_.size() <= used_) texts_.push_back(std::make_unique<std::string>());
    std::string& text = *texts_[used_++];
    text.clear();
    return text;
  }
  void clear() { used_ = 0; }

 private:
  std::vector<std::unique_ptr<std::string>> texts_;
  size_t used_ = 0;  // how many of them this frame uses
};

struct RuleFinding {
  RuleKind kind = RuleKind::exception;
  std::optional<uint16_t> address;
  std::string_view text;  // composed into the RuleFindings that hold it
};

// The model's rules a frame breaks, each with its text.
class RuleFindings {
 public:
  template <typename... Args>
  void add(RuleKind kind, std::optional<uint16_t> address, fmt::format_string<Args...> format,
           Args&&... args) {
    std::string& text = texts_.next();
    fmt::format_to(std::back_inserter(text), format, std::forward<Args>(args)...);
    items_.push_back({kind, address, text});
  }
  void clear() {
    items_.clear();
    texts_.clear();
  }
  auto begin() const { return items_.begin(); }
  auto end() const { return items_.end(); }
  size_t size() const { return items_.size(); }
  bool empty() const { return items_.empty(); }
  const RuleFinding& operator[](size_t i) const { return items_[i]; }

 private:
  std::vector<RuleFinding> items_;
  ComposedTexts texts_;
};

struct Meaning {
  const DeviceModel* model = nullptr;
  std::vector<RegisterValue> registers;
  RuleFindings findings;
  // Whether words the model does not name are listed, by address and raw value: JSON, the
  // statistics, CSV, `-V` and filters show them; a text line and a pcapng comment do not, and
  // leaving them out is most of the model stage's work on a bus of unknown devices. Kept by
  // clear().
  bool lists_unnamed = true;

  Meaning() = default;
  Meaning(Meaning&&) = default;  // moving keeps the composed texts where the registers' texts point
  Meaning& operator=(Meaning&&) = default;
  Meaning(const Meaning&) = delete;
  Meaning& operator=(const Meaning&) = delete;

  // Keeps a text composed for this frame ("F01.05 (RAM)", "Run, Reverse", a group rule's
  // parameter name) for as long as the Meaning, so a register can point at it.
  std::string_view keep(std::string_view text) { return composed_.next().assign(text); }
  void clear() {
    model = nullptr;
    registers.clear();
    findings.clear();
    composed_.clear();
  }

 private:
  ComposedTexts composed_;
};

// Whether a frame's registers are the device's state: a good answer, to a read (what the
// registers hold) or to a write (what the device took, its request's values). A request only
// asks; a write refused or never answered changed nothing.
inline bool states_values(const Frame& frame) {
  return frame.meaning && frame.check_ok && frame.role == Role::response;
}

Meaning interpret(const DeviceModel& model, const Frame& frame);
// The same into `out`, whose storage is reused from frame to frame.
void interpret(const DeviceModel& model, const Frame& frame, Meaning& out);

// Appends to `out` the registers `words` hold from `start` on, in the model's terms.
void decode_registers(const DeviceModel& model, Table table, uint16_t start,
                      std::span<const uint16_t> words, Meaning& out);

// `value` with `decimals` digits after the point, as "{:.{}f}" prints it.
void append_number(fmt::memory_buffer& out, double value, int decimals);

// A register's value as people read it: "60.00 Hz", "Forward running (1)", "Run, Reverse (3)".
void append_value_text(fmt::memory_buffer& out, const RegisterValue& reg);

}  // namespace modtap
