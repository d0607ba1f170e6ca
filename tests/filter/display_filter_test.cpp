#include "decoder/filter/display_filter.hpp"

#include <random>

#include <gtest/gtest.h>

#include "decoder/models/register_meaning.hpp"

namespace modtap {
namespace {

// A read of 2523H answered with 6000 (60.00 Hz), 4 ms late, with a fast turnaround.
struct Sample {
  const uint8_t adu[7] = {0x01, 0x03, 0x02, 0x17, 0x70, 0xB6, 0x50};
  const uint8_t request[5] = {0x03, 0x25, 0x23, 0x00, 0x01};
  Frame frame;
  DecodedPdu pdu;
  DeviceModel model;
  Meaning meaning;

  Sample() {
    frame.raw = frame.adu = adu;
    frame.role = Role::response;
    frame.check_ok = true;
    frame.request = 7;
    frame.request_pdu = request;
    frame.latency_ns = 4'000'000;
    frame.findings = finding_fast_turnaround;
    pdu = decode_pdu(frame.role, frame.pdu(), frame.request_pdu);
    model.name = "nta5000";
    meaning.model = &model;
    meaning.registers.push_back(
        {Table::holding, 0x2523, "frequency_command_monitor", "", 6000, 60.0, 2, "Hz", "", false});
    frame.meaning = &meaning;
  }
};

bool is_register(std::string_view name) {
  return name == "frequency_command_monitor";
}

// Why a filter is refused, or "accepted".
std::string refusal(const std::string& text) {
  try {
    DisplayFilter filter(text, is_register);
  } catch (const FilterError& e) {
    return e.what();
  }
  return "accepted";
}

bool matches(const std::string& text) {
  static const Sample sample;
  return DisplayFilter(text, is_register).matches(sample.frame, sample.pdu);
}

TEST(DisplayFilter, ComparesTheRecordsFieldsByTheirJsonNames) {
  EXPECT_TRUE(matches("slave == 1 && fc == 3"));
  EXPECT_FALSE(matches("slave == 2"));
  EXPECT_TRUE(matches("latency_us > 3999.5 && latency_us <= 4000"));
  EXPECT_TRUE(matches("role == response"));
  EXPECT_TRUE(matches("role == \"RESPONSE\""));  // names compare regardless of case
  EXPECT_TRUE(matches("check == ok and request == 7"));
  EXPECT_TRUE(matches("function == \"Read Holding Registers\""));
  EXPECT_TRUE(matches("raw == \"0103021770b650\""));
  EXPECT_TRUE(matches("type == frame"));
}

TEST(DisplayFilter, ReadsThePduAndAnyOfSeveralValues) {
  EXPECT_TRUE(matches("address == 2523H"));
  EXPECT_TRUE(matches("address == 0x2523"));
  EXPECT_TRUE(matches("values == 6000"));
  EXPECT_FALSE(matches("values == 6001"));
  EXPECT_TRUE(matches("values != 6001"));
  EXPECT_FALSE(matches("quantity"));  // a response's byte count is there, its quantity is not
  EXPECT_TRUE(matches("byte_count == 2"));
}

TEST(DisplayFilter, AbsentValuesAreAbsent) {
  EXPECT_FALSE(matches("exception"));
  EXPECT_FALSE(matches("exception == 0"));
  EXPECT_TRUE(matches("!exception"));
  EXPECT_FALSE(matches("damage"));
  EXPECT_TRUE(matches("latency_us"));
}

TEST(DisplayFilter, FindsFindingsByNameOrAtAll) {
  EXPECT_TRUE(matches("finding"));
  EXPECT_TRUE(matches("fast-turnaround"));
  EXPECT_TRUE(matches("findings == \"fast-turnaround\""));
  EXPECT_FALSE(matches("retry"));
  EXPECT_TRUE(matches("retry || fast-turnaround"));
}

TEST(DisplayFilter, ReadsRegistersThroughTheModel) {
  EXPECT_TRUE(matches("register.name == \"frequency_command_monitor\""));
  EXPECT_TRUE(matches("frequency_command_monitor > 59.9"));
  EXPECT_TRUE(matches("register.unit == Hz && register.addr == 2523H"));
  EXPECT_TRUE(matches("register.raw == 6000 && register.value == 60"));
  EXPECT_TRUE(matches("model == nta5000"));
}

TEST(DisplayFilter, GroupsAsWrittenAndBindsAndBeforeOr) {
  EXPECT_TRUE(matches("slave == 2 && fc == 3 || slave == 1"));
  EXPECT_FALSE(matches("slave == 2 && (fc == 3 || slave == 1)"));
  EXPECT_TRUE(matches("!(slave == 2)"));
  EXPECT_TRUE(matches("not not slave == 1"));
}

// Wireshark's own operators: a part of a text or of the bytes, a set of values and ranges, a
// regular expression; case does not matter, as in Wireshark.
TEST(DisplayFilter, ContainsInAndMatchesAsWiresharkHasThem) {
  EXPECT_TRUE(matches("function contains \"holding\""));
  EXPECT_FALSE(matches("function contains \"coils\""));
  EXPECT_TRUE(matches("raw contains \"17:70\""));  // the bytes, however they are written
  EXPECT_TRUE(matches("raw contains \"02 17 70\""));
  EXPECT_TRUE(matches("raw contains 0103"));
  EXPECT_FALSE(matches("raw contains \"70:17\""));
  EXPECT_TRUE(matches("slave in {3 1 5}"));
  EXPECT_TRUE(matches("fc in {1..4, 16}"));
  EXPECT_FALSE(matches("fc in {5..16}"));
  EXPECT_TRUE(matches("role in {rsp}"));  // as the text prints it
  EXPECT_TRUE(matches("function matches \"^READ .* registers$\""));
  EXPECT_TRUE(matches("function ~ \"holding\""));
  EXPECT_FALSE(matches("function matches \"^write\""));
  EXPECT_TRUE(matches("!(slave in {2 3})"));
  EXPECT_EQ(refusal("slave in {}"), "column 11: the set is empty");
  EXPECT_EQ(refusal("slave in {1"), "column 12: the set has no closing '}'");
  EXPECT_EQ(refusal("slave in 1"), "column 10: expected '{' after in");
  EXPECT_EQ(refusal("function matches \"(\""), "column 18: \"(\" is no regular expression");
  EXPECT_EQ(refusal("raw ~ \"" + std::string(3000, '(') + "\""),
            "column 7: a regular expression of 3000 characters: at most 256 are read");
  EXPECT_TRUE(
      matches("function ~ \"" + std::string(120, '(') + "read" + std::string(120, ')') + "\""));
  EXPECT_NE(refusal("role in {req, foo}").find("not \"foo\""), std::string::npos);
}

// An address is compared as text prints it under --register-base: 49508 is holding register
// 2523H in the 4xxxx convention, 9508 in the 1-based one; hex is the wire's in any.
TEST(DisplayFilter, AddressesReadAsTheRegisterBasePrintsThem) {
  const Sample sample;
  auto matches_in = [&](const std::string& text, RegisterBase base) {
    return DisplayFilter(text, is_register, base).matches(sample.frame, sample.pdu);
  };
  EXPECT_TRUE(matches_in("address == 49508", RegisterBase::modicon));
  EXPECT_TRUE(matches_in("address in {49500..49510}", RegisterBase::modicon));
  EXPECT_TRUE(matches_in("register.addr == 49508", RegisterBase::modicon));
  EXPECT_TRUE(matches_in("address == 9508", RegisterBase::one));
  EXPECT_FALSE(matches_in("address == 9507", RegisterBase::one));
  EXPECT_TRUE(matches_in("address == 2523H", RegisterBase::one));
  EXPECT_TRUE(matches_in("address == 9507", RegisterBase::hex));
  EXPECT_TRUE(matches_in("slave == 1", RegisterBase::one));  // only addresses move
}

TEST(DisplayFilter, NoiseAndTimeOutsHaveTheirOwnFields) {
  const uint8_t junk[] = {0xFF};
  Noise noise;
  noise.raw = junk;
  noise.reason = NoiseReason::glitch;
  EXPECT_TRUE(DisplayFilter("type == noise && reason == glitch", {}).matches(noise));
  EXPECT_FALSE(DisplayFilter("slave == 0", {}).matches(noise));
  EXPECT_FALSE(DisplayFilter("damaged_answer", {}).matches(noise));  // a flag: present if true
  noise.damaged_answer = true;
  EXPECT_TRUE(DisplayFilter("damaged_answer", {}).matches(noise));
  Timeout timeout;
  timeout.slave = 9;
  timeout.waited_ns = 1'500'000;
  EXPECT_TRUE(
      DisplayFilter("type == timeout && slave == 9 && waited_us == 1500", {}).matches(timeout));
}

TEST(DisplayFilter, ChannelsByTheirNames) {
  DisplayFilter filter("channel == master", {});
  filter.set_channel_names({"master", "slave"});
  Noise noise;
  EXPECT_TRUE(filter.matches(noise));
  noise.channel = 1;
  EXPECT_FALSE(filter.matches(noise));
}

size_t error_column(const std::string& text) {
  try {
    DisplayFilter(text, is_register);
  } catch (const FilterError& e) {
    return e.column();
  }
  return 0;
}

TEST(DisplayFilter, SyntaxErrorsNameTheirColumn) {
  EXPECT_EQ(error_column("slave == 3 &&"), 14u);
  EXPECT_EQ(error_column("slavee == 3"), 1u);
  EXPECT_EQ(error_column("slave == 3 && fc =="), 20u);
  EXPECT_EQ(error_column("(slave == 3"), 12u);
  EXPECT_EQ(error_column("slave == 3 )"), 12u);
  EXPECT_EQ(error_column("slave == \"3"), 10u);
  EXPECT_EQ(error_column("slave == 12x"), 10u);
  EXPECT_EQ(error_column("slave # 3"), 7u);
  EXPECT_EQ(error_column(""), 1u);
  EXPECT_EQ(error_column("frequency_command_monitor > 1"), 0u);
}

// Nesting deeper than a person writes is refused before it can exhaust the stack; a long
// list of alternatives is fine.
// A field of a fixed set of values takes what the text output prints for them, and refuses a
// value it never has rather than match nothing.
TEST(DisplayFilter, FixedValuesAsTheOutputsWriteThemAndNoOthers) {
  EXPECT_TRUE(matches("role == rsp"));
  EXPECT_FALSE(matches("role == req"));
  EXPECT_TRUE(matches("role != req"));
  EXPECT_TRUE(matches("check == OK && mode == rtu"));
  EXPECT_EQ(refusal("role == reply"),
            "column 9: role is request, response or unknown, not \"reply\"");
  EXPECT_EQ(refusal("type == frames"),
            "column 9: type is frame, noise, timeout or unanswered, not \"frames\"");
  EXPECT_EQ(refusal("damage == none"),
            "column 11: damage is corrupted, cut or collision, not \"none\"");
}

// An unknown name says what it likely meant: Wireshark's name for it, the field it begins, or
// the nearest field or finding.
TEST(DisplayFilter, AnUnknownNameSaysWhatItMeant) {
  EXPECT_EQ(refusal("modbus.func_code == 3"),
            "column 1: unknown name \"modbus.func_code\"; modtap calls it fc");
  EXPECT_EQ(refusal("timeout"),
            "column 1: unknown name \"timeout\"; modtap calls it type == \"timeout\"");
  EXPECT_EQ(refusal("latency > 5"), "column 1: unknown name \"latency\"; did you mean latency_us?");
  EXPECT_EQ(refusal("slav == 1"), "column 1: unknown name \"slav\"; did you mean slave?");
  EXPECT_EQ(refusal("retyr"), "column 1: unknown name \"retyr\"; did you mean retry?");
  EXPECT_EQ(refusal("zzzzzzzz"),
            "column 1: unknown name \"zzzzzzzz\" (docs/output.md lists the names; register "
            "names need their --model)");
}

TEST(DisplayFilter, RefusesNestingDeeperThanAPersonWrites) {
  EXPECT_EQ(error_column(std::string(3000, '(') + "slave"), 257u);
  EXPECT_EQ(error_column(std::string(3000, '!') + "slave"), 257u);
  std::string alternatives = "slave == 0";
  for (int i = 1; i < 200; ++i) alternatives += " || slave == " + std::to_string(i);
  EXPECT_TRUE(matches(alternatives));
}

// Random texts from the filter's own alphabet: each parses or says where it went wrong.
TEST(DisplayFilter, RandomTextsParseOrFailCleanly) {
  static const char* const pieces[] = {
      "slave",      "fc",     "==",  "!=", "<",    ">=",    "&&",    "||",
      "!",          "(",      ")",   "3",  "0x1F", "2502H", "\"x\"", "finding",
      "latency_us", "values", "and", "or", "not",  "@",     "-",     "register.name",
      "1e999",      "\"",     ".5"};
  std::mt19937 random(3);
  size_t parsed = 0;
  for (int i = 0; i < 20000; ++i) {
    std::string text;
    for (int n = random() % 8; n >= 0; --n) text += std::string(pieces[random() % 27]) + " ";
    try {
      const DisplayFilter filter(text, is_register);
      static const Sample sample;
      (void)filter.matches(sample.frame, sample.pdu);
      ++parsed;
    } catch (const FilterError& e) {
      EXPECT_GE(e.column(), 1u);
      EXPECT_LE(e.column(), text.size() + 1) << text;
    }
  }
  EXPECT_GT(parsed, 100u);
}

}  // namespace
}  // namespace modtap
