#include "decoder/protocol/pdu_fields.hpp"

#include <gtest/gtest.h>

#include "tests/support/collector.hpp"

namespace modtap {
namespace {

using testing::hex;

const Field* find(const DecodedPdu& d, FieldId id) {
  return d.find(id);
}

std::vector<int64_t> values(const Field* f) {
  std::vector<int64_t> out;
  for (size_t i = 0; f && i < f->count; ++i)
    out.push_back(f->type() == FieldType::bits ? f->bit(i) : f->word(i));
  return out;
}

// The fields of item `k` of the list at `list`.
std::vector<Field> item(const DecodedPdu& d, const Field* list, uint8_t k) {
  std::vector<Field> out;
  for (size_t at = static_cast<size_t>(list - d.fields.data()) + 1;
       at < d.fields.size() && d.fields[at].item != 0; ++at)
    if (d.fields[at].item == k) out.push_back(d.fields[at]);
  return out;
}

TEST(PduFields, ReadHoldingRegistersResponseTakesItsAddressFromTheRequest) {
  const auto pdu = hex("03 04 13 88 00 00");
  const auto d = decode_pdu(Role::response, pdu, hex("03 00 04 00 02"));
  ASSERT_NE(find(d, FieldId::address), nullptr);
  EXPECT_EQ(find(d, FieldId::address)->number, 4);
  EXPECT_EQ(values(find(d, FieldId::register_values)), (std::vector<int64_t>{5000, 0}));
  EXPECT_FALSE(d.truncated);
}

TEST(PduFields, CoilsAreCountedByTheRequestedQuantity) {
  const auto pdu = hex("01 02 cd 01");
  const auto d = decode_pdu(Role::response, pdu, hex("01 00 13 00 0a"));
  EXPECT_EQ(values(find(d, FieldId::bit_values)),
            (std::vector<int64_t>{1, 0, 1, 1, 0, 0, 1, 1, 1, 0}));
}

TEST(PduFields, ExceptionsCarryTheirStandardName) {
  const auto pdu = hex("83 02");
  const auto d = decode_pdu(Role::response, pdu, {});
  EXPECT_EQ(find(d, FieldId::exception_code)->number, 2);
  EXPECT_EQ(find(d, FieldId::exception_name)->text, "Illegal Data Address");
}

TEST(PduFields, DiagnosticsNameTheSubFunction) {
  const auto pdu = hex("08 00 00 a5 37");
  const auto d = decode_pdu(Role::request, pdu, {});
  EXPECT_EQ(find(d, FieldId::sub_function_name)->text, "Return Query Data");
  const auto data = find(d, FieldId::data)->bytes;
  EXPECT_EQ(std::vector<uint8_t>(data.begin(), data.end()), hex("a5 37"));
}

TEST(PduFields, DeviceIdentificationListsItsObjects) {
  const auto pdu = hex("2b 0e 01 01 00 00 02 00 02 61 62 01 01 63");
  const auto d = decode_pdu(Role::response, pdu, {});
  const Field* objects = find(d, FieldId::objects);
  ASSERT_NE(objects, nullptr);
  ASSERT_EQ(objects->count, 2u);
  const auto first = item(d, objects, 1);
  ASSERT_EQ(first.size(), 3u);
  EXPECT_EQ(first[1].text, "VendorName");
  EXPECT_EQ(std::string(first[2].bytes.begin(), first[2].bytes.end()), "ab");
  EXPECT_EQ(item(d, objects, 2)[1].text, "ProductCode");
}

TEST(PduFields, ReadFileRecordSubRequests) {
  const auto pdu = hex("14 0e 06 00 04 00 01 00 02 06 00 03 00 09 00 02");
  const auto d = decode_pdu(Role::request, pdu, {});
  const Field* list = find(d, FieldId::sub_requests);
  ASSERT_EQ(list->count, 2u);
  EXPECT_EQ(item(d, list, 2)[1].number, 3);  // the second sub-request's file
}

// A write's answer cut after its address: the address came, the quantity did not, and a
// quantity of 0 would be a number the wire never carried; a read's answer cut inside its first
// value has no values, not an empty list.
TEST(PduFields, ADamagedPduIsMarkedTruncatedAndHasNoFieldPastItsEnd) {
  const auto request = decode_pdu(Role::request, hex("10 00 01"), {});
  EXPECT_TRUE(request.truncated);
  const auto answer = decode_pdu(Role::response, hex("10 00 05 00"), hex("10 00 05 00 02 04"));
  EXPECT_TRUE(answer.truncated);
  ASSERT_NE(find(answer, FieldId::address), nullptr);
  EXPECT_EQ(find(answer, FieldId::address)->number, 5);
  EXPECT_EQ(find(answer, FieldId::quantity), nullptr);
  const auto read = decode_pdu(Role::response, hex("03 04 12"), hex("03 00 00 00 02"));
  EXPECT_EQ(find(read, FieldId::register_values), nullptr) << "no value came whole";
  const auto exception = decode_pdu(Role::response, hex("83"), hex("03 00 00 00 01"));
  EXPECT_EQ(find(exception, FieldId::exception_code), nullptr);
  EXPECT_EQ(find(exception, FieldId::exception_name), nullptr);
}

}  // namespace
}  // namespace modtap
