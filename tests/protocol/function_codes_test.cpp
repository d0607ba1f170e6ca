#include "decoder/protocol/function_codes.hpp"

#include <gtest/gtest.h>

#include "decoder/protocol/awaited_answer.hpp"
#include "decoder/protocol/checksum.hpp"
#include "tests/support/collector.hpp"

namespace modtap {
namespace {

using testing::hex;
using K = BodyLength::Kind;

BodyLength request(const char* h) {
  return body_length(Role::request, hex(h));
}
BodyLength response(const char* h) {
  return body_length(Role::response, hex(h));
}

TEST(BodyLength, ReadRequestsAreSixBytesWhateverTheirQuantity) {
  EXPECT_EQ(request("01 03 00 00 00 0a").bytes, 6);
  EXPECT_EQ(request("01 03 00 00 00 7e").bytes, 6);  // 126 registers: out of spec, still a frame
  EXPECT_EQ(request("01 01 00 00 07 d0").kind, K::known);   // 2000 coils
  EXPECT_EQ(request("01 0f 00 00 00").kind, K::need_more);  // the byte count has not come
}

TEST(RequestSpec, QuantitiesOutsideTheStandardsLimitsAreFound) {
  auto found = [](const char* pdu) { return request_spec_findings(hex(pdu)); };
  EXPECT_EQ(found("03 00 00 00 7d"), finding_none);                  // 125
  EXPECT_EQ(found("03 00 00 00 7e"), finding_quantity_out_of_spec);  // mbpoll -c 126
  EXPECT_EQ(found("04 00 00 00 00"), finding_quantity_out_of_spec);  // 0
  EXPECT_EQ(found("01 00 00 07 d0"), finding_none);                  // 2000 coils
  EXPECT_EQ(found("02 00 00 07 d1"), finding_quantity_out_of_spec);
  EXPECT_EQ(found("10 00 00 00 7c f8"), finding_quantity_out_of_spec);                // 124 written
  EXPECT_EQ(found("10 00 00 00 02 05 00 01 00 02 00"), finding_byte_count_mismatch);  // odd
  EXPECT_EQ(found("0f 00 00 00 0a 01 ff"), finding_byte_count_mismatch);  // 10 coils, 1 byte
  EXPECT_EQ(found("0f 00 00 00 0a 02 ff 03"), finding_none);
  EXPECT_EQ(found("17 00 00 00 7e 00 10 00 01 02 00 00"), finding_quantity_out_of_spec);
  EXPECT_EQ(found("17 00 00 00 01 00 10 00 7a f4"), finding_quantity_out_of_spec);  // 122
  EXPECT_EQ(found("05 00 01 12 34"), finding_value_out_of_spec);
  EXPECT_EQ(found("05 00 01 ff 00"), finding_none);
}

// Application Protocol 6.8.1: what each diagnostic sub-function's request carries.
TEST(RequestSpec, DiagnosticsCarryTheDataTheirSubFunctionSays) {
  auto found = [](const char* pdu) { return request_spec_findings(hex(pdu)); };
  EXPECT_EQ(found("08 00 0b 00 00"), finding_none);  // Return Bus Message Count
  EXPECT_EQ(found("08 00 0b c4 6d"), finding_value_out_of_spec);
  EXPECT_EQ(found("08 00 14 00 00"), finding_none);  // Clear Overrun Counter and Flag
  EXPECT_EQ(found("08 00 01 ff 00"), finding_none);  // restart, clearing the event log
  EXPECT_EQ(found("08 00 01 00 01"), finding_value_out_of_spec);
  EXPECT_EQ(found("08 00 03 0d 00"), finding_none);  // CR as the ASCII delimiter
  EXPECT_EQ(found("08 00 03 0d 0a"), finding_value_out_of_spec);
  EXPECT_EQ(found("08 00 00 12 34"), finding_none);  // Return Query Data: any data
  EXPECT_EQ(found("08 00 13 12 34"), finding_none);  // reserved: no rule
  EXPECT_EQ(found("08 00 0b 00 00 00"), finding_none);
}

TEST(BodyLength, ResponsesCarryTheirByteCount) {
  EXPECT_EQ(response("01 03 04").bytes, 7);
  EXPECT_EQ(response("01 03 03").kind, K::invalid);  // registers come in pairs
  EXPECT_EQ(response("01 01 01").bytes, 4);
  EXPECT_EQ(response("01 83").bytes, 3);
}

TEST(BodyLength, WriteMultipleCountsMustFitTheQuantity) {
  EXPECT_EQ(request("01 10 00 00 00 02 04").bytes, 11);
  EXPECT_EQ(request("01 10 00 00 00 02 05").bytes, 12);         // the byte count says; a finding
  EXPECT_EQ(request("01 10 00 00 00 02 00").kind, K::invalid);  // nothing to write
  EXPECT_EQ(request("01 0f 00 00 00 0a 02").bytes, 9);
  EXPECT_EQ(response("01 10").bytes, 6);
}

TEST(BodyLength, EchoCodesHaveTheSameLengthBothWays) {
  for (const char* h : {"01 05 00 01 ff 00", "01 06 00 01 00 02", "01 08 00 0a 00 00"})
    EXPECT_EQ(request(h).bytes, response(h).bytes) << h;
  EXPECT_EQ(request("01 16").bytes, 8);
  EXPECT_EQ(response("01 16").bytes, 8);
}

TEST(BodyLength, ReturnQueryDataHasNoLengthOfItsOwn) {
  EXPECT_EQ(request("01 08 00 00").kind, K::variable);
  EXPECT_EQ(response("01 08 00 00").kind, K::variable);
}

TEST(BodyLength, OtherCodesFollowTheirLayout) {
  EXPECT_EQ(request("01 07").bytes, 2);
  EXPECT_EQ(response("01 07").bytes, 3);
  EXPECT_EQ(response("01 0b").bytes, 6);
  EXPECT_EQ(response("01 0c 08").bytes, 11);
  EXPECT_EQ(response("01 11 03").bytes, 6);
  EXPECT_EQ(request("01 14 0e").bytes, 17);
  EXPECT_EQ(request("01 17 00 00 00 02 00 00 00 01 02").bytes, 13);
  EXPECT_EQ(response("01 17 04").bytes, 7);
  EXPECT_EQ(request("01 18").bytes, 4);
  EXPECT_EQ(response("01 18 00 06").bytes, 10);
  EXPECT_EQ(request("01 2b 0e").bytes, 5);
}

TEST(BodyLength, DeviceIdentificationWalksItsObjects) {
  // Header 8 bytes, then {id, length, value}: "ab" and "c".
  EXPECT_EQ(response("01 2b 0e 01 01 00 00 02 00 02 61 62 01 01 63").bytes, 15);
  EXPECT_EQ(response("01 2b 0e 01 01 00 00 02 00 02 61").kind, K::need_more);
}

TEST(BodyLength, UnknownCodesAreSearchedFor) {
  EXPECT_EQ(request("01 41").kind, K::variable);
}

std::vector<uint8_t> prefix(const char* request_pdu) {
  const ResponsePrefix p = response_prefix(hex(request_pdu));
  return {p.pdu.begin(), p.pdu.begin() + p.size};
}

TEST(ResponsePrefix, IsWhatTheRequestTellsOfItsAnswer) {
  EXPECT_EQ(prefix("03 00 10 00 0a"), hex("03 14"));  // 10 registers: 20 bytes
  EXPECT_EQ(prefix("01 00 00 00 0b"), hex("01 02"));  // 11 coils: 2 bytes
  EXPECT_EQ(prefix("03 00 00 00 7e"), hex("03"));     // over the limit: no byte count to expect
  EXPECT_EQ(prefix("17 00 01 00 03 00 09 00 01 02 00 07"), hex("17 06"));  // reads 3
  EXPECT_EQ(prefix("06 00 05 12 34"), hex("06 00 05 12 34"));
  EXPECT_EQ(prefix("10 00 05 00 02 04 00 0a 01 02"), hex("10 00 05 00 02"));
  EXPECT_EQ(prefix("08 00 00 ab cd ef 01 02 03"), hex("08 00 00 ab cd ef 01 02"));  // 8 kept
  EXPECT_EQ(prefix("08 00 0b 00 00"), hex("08 00 0b"));  // a counter: its value is new
  EXPECT_EQ(prefix("07"), hex("07"));
  EXPECT_EQ(prefix("41 01 02"), hex("41"));  // a code the standard does not define
}

// Whether the answer is the request again is the table's to say, not the prefix's size: a long
// query's echo is more than the prefix keeps.
TEST(ResponsePrefix, SaysWhenTheAnswerIsTheRequestAgain) {
  EXPECT_TRUE(response_prefix(hex("08 00 00 ab cd ef 01 02 03")).echoes_request);
  // Write File Record's answer is its request again (Application Protocol 6.15).
  EXPECT_TRUE(response_prefix(hex("15 0d 06 00 04 00 07 00 03 06 af 04 be 10 0d")).echoes_request);
  EXPECT_FALSE(response_prefix(hex("08 00 0b 00 00")).echoes_request);  // a counter
  EXPECT_TRUE(response_prefix(hex("05 00 05 ff 00")).echoes_request);
  EXPECT_TRUE(response_prefix(hex("06 00 05 12 34")).echoes_request);
  EXPECT_FALSE(response_prefix(hex("10 00 05 00 02 04 00 0a 01 02")).echoes_request);
  EXPECT_FALSE(response_prefix(hex("03 00 10 00 0a")).echoes_request);
}

// The awaited answer's bytes that its request tells: an echo's, each of them and its CRC,
// however long the request (a query of FC08 Return Query Data past the prefix's 8 bytes).
TEST(AwaitedAnswer, TellsEveryByteOfAnEcho) {
  const auto pdu = hex("08 00 00 ab cd ef 01 02 03 04");
  const Expectation expected{true, 0x11, 0x08, 0, false, pdu, 0};
  const AwaitedAnswer awaited(expected, true);
  auto echo = hex("11 08 00 00 ab cd ef 01 02 03 04");
  const uint16_t crc = crc16(echo);
  echo.insert(echo.end(), {static_cast<uint8_t>(crc & 0xFF), static_cast<uint8_t>(crc >> 8)});
  for (size_t pos = 2; pos < echo.size(); ++pos) {
    EXPECT_EQ(awaited.byte(echo, pos), true) << pos;
    auto other = echo;
    other[pos] ^= 0x01;
    EXPECT_EQ(awaited.byte(other, pos), false) << pos;
  }
  const auto counter = hex("08 00 0b 00 00");  // a counter: its value is the slave's
  const Expectation counted{true, 0x11, 0x08, 0, false, counter, 0};
  EXPECT_EQ(AwaitedAnswer(counted, true).byte(hex("11 08 00 0b 00 07 00 00"), 5), std::nullopt);
}

TEST(FunctionTable, NamesThePublicCodesOnly) {
  EXPECT_EQ(function_name(0x03), "Read Holding Registers");
  EXPECT_EQ(function_name(0x83), "Read Holding Registers");
  EXPECT_EQ(function_name(0x41), "");
  EXPECT_TRUE(may_broadcast(0x10));
  EXPECT_FALSE(may_broadcast(0x03));
  EXPECT_TRUE(may_broadcast(0x41));  // a code the standard does not define: nothing forbids it
  EXPECT_EQ(exception_name(0x02), "Illegal Data Address");
  EXPECT_EQ(exception_name(0x09), "");
}

}  // namespace
}  // namespace modtap
