#include "decoder/pdu_fields.hpp"

#include <gtest/gtest.h>

#include "tests/support/collector.hpp"

namespace modtap::decoder {
namespace {

using testing::hex;

const Field* find(const DecodedPdu& d, std::string_view key) {
  for (const auto& f : d.fields)
    if (f.key == key) return &f;
  return nullptr;
}

TEST(PduFields, ReadHoldingRegistersResponseTakesItsAddressFromTheRequest) {
  const auto d = decode_pdu(Role::response, hex("03 04 13 88 00 00"), hex("03 00 04 00 02"));
  ASSERT_NE(find(d, "address"), nullptr);
  EXPECT_EQ(find(d, "address")->number, 4);
  EXPECT_EQ(find(d, "values")->numbers, (std::vector<int64_t>{5000, 0}));
  EXPECT_FALSE(d.truncated);
}

TEST(PduFields, CoilsAreCountedByTheRequestedQuantity) {
  const auto d = decode_pdu(Role::response, hex("01 02 cd 01"), hex("01 00 13 00 0a"));
  EXPECT_EQ(find(d, "values")->numbers, (std::vector<int64_t>{1, 0, 1, 1, 0, 0, 1, 1, 1, 0}));
}

TEST(PduFields, ExceptionsCarryTheirStandardName) {
  const auto d = decode_pdu(Role::response, hex("83 02"), {});
  EXPECT_EQ(find(d, "exception_code")->number, 2);
  EXPECT_EQ(find(d, "exception_name")->text, "Illegal Data Address");
}

TEST(PduFields, DiagnosticsNameTheSubFunction) {
  const auto d = decode_pdu(Role::request, hex("08 00 00 a5 37"), {});
  EXPECT_EQ(find(d, "sub_function_name")->text, "Return Query Data");
  EXPECT_EQ(find(d, "data")->bytes, hex("a5 37"));
}

TEST(PduFields, DeviceIdentificationListsItsObjects) {
  const auto d = decode_pdu(Role::response, hex("2b 0e 01 01 00 00 02 00 02 61 62 01 01 63"), {});
  const Field* objects = find(d, "objects");
  ASSERT_NE(objects, nullptr);
  ASSERT_EQ(objects->items.size(), 2u);
  EXPECT_EQ(objects->items[0][1].text, "VendorName");
  EXPECT_EQ(objects->items[0][2].text, "ab");
}

TEST(PduFields, ReadFileRecordSubRequests) {
  const auto d =
      decode_pdu(Role::request, hex("14 0e 06 00 04 00 01 00 02 06 00 03 00 09 00 02"), {});
  ASSERT_EQ(find(d, "sub_requests")->items.size(), 2u);
  EXPECT_EQ(find(d, "sub_requests")->items[1][1].number, 3);
}

TEST(PduFields, ADamagedPduIsMarkedTruncatedNotReadPastItsEnd) {
  const auto d = decode_pdu(Role::request, hex("10 00 01"), {});
  EXPECT_TRUE(d.truncated);
}

}  // namespace
}  // namespace modtap::decoder
