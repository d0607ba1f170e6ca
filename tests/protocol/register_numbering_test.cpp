#include "decoder/protocol/register_numbering.hpp"

#include <gtest/gtest.h>

namespace modtap {
namespace {

std::string shown(Table table, uint16_t address, RegisterBase base) {
  return fmt::format("{}", RegisterNumber{table, address, base});
}

TEST(RegisterNumbering, EachConventionWritesTheWiresAddressItsWay) {
  EXPECT_EQ(shown(Table::holding, 0x2502, RegisterBase::hex), "2502H");
  EXPECT_EQ(shown(Table::holding, 0x2502, RegisterBase::zero), "9474");
  EXPECT_EQ(shown(Table::holding, 0x2502, RegisterBase::one), "9475");
  EXPECT_EQ(shown(Table::holding, 0x2502, RegisterBase::modicon), "49475");
  EXPECT_EQ(shown(Table::holding, 0, RegisterBase::modicon), "40001");
  EXPECT_EQ(shown(Table::input, 0, RegisterBase::modicon), "30001");
  EXPECT_EQ(shown(Table::discrete, 0, RegisterBase::modicon), "10001");
  EXPECT_EQ(shown(Table::coil, 0, RegisterBase::modicon), "00001");
  // Past 9999 Modicon's numbers take six digits.
  EXPECT_EQ(shown(Table::holding, 9998, RegisterBase::modicon), "49999");
  EXPECT_EQ(shown(Table::holding, 9999, RegisterBase::modicon), "410000");
  EXPECT_EQ(shown(Table::holding, 0xFFFF, RegisterBase::modicon), "465536");
  EXPECT_EQ(shown(Table::holding, 0xFFFF, RegisterBase::one), "65536");
}

TEST(RegisterNumbering, ANumberReadsBackAsTheRegisterItWasWrittenFor) {
  for (RegisterBase base :
       {RegisterBase::hex, RegisterBase::zero, RegisterBase::one, RegisterBase::modicon})
    for (Table table : {Table::coil, Table::discrete, Table::holding, Table::input})
      for (uint32_t address : {0u, 1u, 9998u, 9999u, 0x2502u, 0xFFFFu}) {
        const std::string text = shown(table, static_cast<uint16_t>(address), base);
        const auto named = parse_register_number(text, base);
        ASSERT_TRUE(named) << text;
        EXPECT_EQ(named->address, address) << text;
        if (base == RegisterBase::modicon) {
          EXPECT_EQ(named->table, table) << text;
        }
      }
}

TEST(RegisterNumbering, HexIsTheWiresAddressInEveryConvention) {
  EXPECT_EQ(parse_register_number("2502H", RegisterBase::one)->address, 0x2502);
  EXPECT_EQ(parse_register_number("0x2502", RegisterBase::modicon)->address, 0x2502);
  EXPECT_FALSE(parse_register_number("0x2502", RegisterBase::modicon)->table);
}

TEST(RegisterNumbering, NumbersNoConventionGivesAreRefused) {
  EXPECT_FALSE(parse_register_number("0", RegisterBase::one));  // 1-based starts at 1
  EXPECT_FALSE(parse_register_number("65537", RegisterBase::one));
  EXPECT_FALSE(parse_register_number("65536", RegisterBase::zero));
  EXPECT_FALSE(parse_register_number("40000", RegisterBase::modicon));  // register 0
  EXPECT_FALSE(parse_register_number("20001", RegisterBase::modicon));  // no table 2
  EXPECT_FALSE(parse_register_number("4001", RegisterBase::modicon));   // too short
  EXPECT_FALSE(parse_register_number("frequency", RegisterBase::zero));
  EXPECT_EQ(enum_named<RegisterBase>("4xxxx"), RegisterBase::modicon);
  EXPECT_FALSE(enum_named<RegisterBase>("2"));
}

}  // namespace
}  // namespace modtap
