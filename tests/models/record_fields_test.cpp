#include "decoder/models/record_fields.hpp"

#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "decoder/models/device_model.hpp"

namespace modtap {
namespace {

// Writes down what the walk hands over: each field's name, and for the findings their names.
struct Recorder {
  std::vector<std::string> names;
  std::vector<std::string> absent_names;
  std::vector<std::string> finding_names;
  bool walked_pdu = false;

  void seen(FieldId id) { names.emplace_back(field_info(id).name); }
  void name(FieldId id, std::string_view) { seen(id); }
  template <typename Enum>
  void choice(FieldId id, Enum) {
    seen(id);
  }
  void function_code(FieldId fc, FieldId function, uint8_t) {
    seen(fc);
    seen(function);
  }
  void number(FieldId id, uint64_t) { seen(id); }
  void time(FieldId id, int64_t) { seen(id); }
  void micros(FieldId id, int64_t) { seen(id); }
  void channel(FieldId id, uint16_t) { seen(id); }
  void bytes(FieldId id, std::span<const uint8_t>) { seen(id); }
  void boolean(FieldId id, bool) { seen(id); }
  void flag(FieldId id) { seen(id); }
  void absent(FieldId id) {
    seen(id);
    absent_names.emplace_back(field_info(id).name);
  }
  void findings(FieldId id, FindingSlots slots) {
    seen(id);
    slots.each([&](size_t slot) { finding_names.emplace_back(finding_registry()[slot].name); });
  }
  void registers(FieldId id, std::span<const RegisterValue>) { seen(id); }
  void notes(FieldId id, std::span<const RuleFinding>) { seen(id); }
  void pdu(const DecodedPdu&) { walked_pdu = true; }
};

const std::vector<uint8_t> read_response{0x11, 0x03, 0x02, 0x00, 0x07, 0x79, 0x86};

Frame response_frame() {
  Frame frame;
  frame.adu = frame.raw = read_response;
  frame.role = Role::response;
  frame.check_ok = true;
  frame.request = 4;
  frame.latency_ns = 12'000'000;
  return frame;
}

TEST(RecordFields, AFrameHasEveryRecordFieldOnceInJsonsOrder) {
  Recorder walked;
  walk_fields(response_frame(), DecodedPdu{}, walked);
  EXPECT_EQ(walked.names, (std::vector<std::string>{
                              "type",     "index",     "t_ns",    "end_ns",      "channel",
                              "offset",   "mode",      "role",    "slave",       "fc",
                              "function", "raw",       "check",   "check_value", "expected_check",
                              "damage",   "exception", "request", "latency_us",  "findings"}));
  EXPECT_EQ(walked.absent_names, (std::vector<std::string>{"damage", "exception"}));
  EXPECT_TRUE(walked.walked_pdu);
}

// A frame cut before its check has none, nor one to expect; its damage and exception are there.
TEST(RecordFields, WhatARecordLacksIsAbsentNotZero) {
  Frame frame = response_frame();
  const std::vector<uint8_t> cut_exception{0x11, 0x83, 0x02};
  frame.adu = frame.raw = cut_exception;
  frame.check_ok = false;
  frame.damage = Damage::cut;
  frame.request.reset();
  frame.latency_ns.reset();
  Recorder walked;
  walk_fields(frame, DecodedPdu{}, walked);
  EXPECT_EQ(walked.absent_names,
            (std::vector<std::string>{"check_value", "expected_check", "request", "latency_us"}));
}

// Findings are kept in two places, the frame's bits and the model's rules: the walk gives one
// sequence, the frame's first, and only a frame read through a model has the model's fields.
TEST(RecordFields, FindingsFromTheFrameAndTheModelAreOneList) {
  DeviceModel model;
  model.name = "drive";
  Meaning meaning;
  meaning.model = &model;
  meaning.findings.add(RuleKind::read_only_write, 0x2100, "{} is read-only", "2100H");
  Frame frame = response_frame();
  frame.findings = finding_retry | finding_broadcast;
  frame.meaning = &meaning;
  Recorder walked;
  DecodedPdu truncated;
  truncated.truncated = true;
  walk_fields(frame, truncated, walked);
  EXPECT_EQ(walked.finding_names,
            (std::vector<std::string>{"broadcast", "retry",
                                      std::string(to_string(RuleKind::read_only_write))}));
  const std::vector<std::string> tail(walked.names.end() - 4, walked.names.end());
  EXPECT_EQ(tail, (std::vector<std::string>{"model", "registers", "notes", "truncated"}));
  EXPECT_TRUE(findings_of(frame).has(finding_slot(RuleKind::read_only_write)));
  EXPECT_FALSE(findings_of(frame).has(finding_slot(RuleKind::write_only_read)));
}

TEST(RecordFields, NoiseAndTimeOutsHaveTheirOwnFields) {
  Noise noise;
  noise.damaged_answer = true;
  Recorder noise_fields;
  walk_fields(noise, noise_fields);
  EXPECT_EQ(noise_fields.names, (std::vector<std::string>{
                                    "type", "index", "t_ns", "end_ns", "channel", "offset", "mode",
                                    "raw", "reason", "request", "damaged_answer", "findings"}));
  Timeout timeout;
  Recorder timeout_fields;
  walk_fields(timeout, timeout_fields);
  EXPECT_EQ(timeout_fields.names, (std::vector<std::string>{"type", "request", "t_ns", "channel",
                                                            "slave", "fc", "waited_us", "reason"}));
}

}  // namespace
}  // namespace modtap
