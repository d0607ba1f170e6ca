// A frame read through a device model: its registers as named, scaled values, and the model's
// rules it breaks. Pure: the model and the frame in, a Meaning out.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/format.h>

#include "decoder/device_model.hpp"
#include "decoder/records.hpp"

namespace modtap::decoder {

// Its texts point into the model, or into the Meaning that holds it where they are composed.
struct RegisterValue {
  Table table = Table::holding;
  uint16_t address = 0;
  std::string_view name;   // empty for a register the model does not know
  std::string_view label;  // the manual's words
  uint32_t raw = 0;        // the register, or both words of a 32-bit value
  double value = 0;        // raw, signed by type, scaled and offset
  int decimals = 0;        // digits after the point that the scale implies
  std::string_view unit;
  std::string_view text;  // an enum's meaning, the set bits' names, or a string register's text
  bool code = false;      // shown in hex as the manual writes it (0106H)
};

struct RuleFinding {
  RuleKind kind = RuleKind::exception;
  std::optional<uint16_t> address;
  std::string text;
};

struct Meaning {
  const DeviceModel* model = nullptr;
  std::vector<RegisterValue> registers;
  std::vector<RuleFinding> findings;
  bool echoed = false;  // the registers repeat what the request wrote (a write's echo response)
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
  // parameter name) for as long as the Meaning, so a register can point at it. The storage
  // is reused from frame to frame: once warm, keeping a text allocates nothing.
  std::string_view keep(std::string_view text) {
    while (composed_.size() <= kept_) composed_.push_back(std::make_unique<std::string>());
    return composed_[kept_++]->assign(text);
  }
  void clear() {
    model = nullptr;
    registers.clear();
    findings.clear();
    echoed = false;
    kept_ = 0;
  }

 private:
  std::vector<std::unique_ptr<std::string>> composed_;  // each text stays put through moves
  size_t kept_ = 0;                                     // how many of them this frame uses
};

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

}  // namespace modtap::decoder
