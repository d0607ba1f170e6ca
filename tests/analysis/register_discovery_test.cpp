#include "decoder/analysis/register_discovery.hpp"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <functional>

namespace modtap {
namespace {

// A master reading `count` registers from `first` of slave 1 every second, and the answers
// `values(n)` gives for read n: what RegisterDiscovery hears on such a bus.
class Reads {
 public:
  using Values = std::function<std::vector<uint16_t>(int)>;
  Reads(uint16_t first, uint16_t count, uint8_t function = 0x03)
      : first_(first), count_(count), function_(function) {}

  void run(int reads, const Values& values) {
    for (int n = 0; n < reads; ++n) read(n * 1'000'000'000LL, values(n));
  }
  const RegisterDiscovery& found() const { return discovery_; }
  std::vector<RegisterReading> registers() const {
    const auto drafts = discovery_.drafts();
    return drafts.empty() ? std::vector<RegisterReading>{} : drafts.front().registers;
  }

 private:
  void read(int64_t t_ns, const std::vector<uint16_t>& values) {
    request_ = {1,
                function_,
                static_cast<uint8_t>(first_ >> 8),
                static_cast<uint8_t>(first_),
                static_cast<uint8_t>(count_ >> 8),
                static_cast<uint8_t>(count_),
                0,
                0};
    Frame request;
    request.role = Role::request;
    request.check_ok = true;
    request.t_ns = t_ns;
    request.adu = request.raw = request_;
    discovery_.on_frame(request);
    answer_ = {1, function_, static_cast<uint8_t>(2 * values.size())};
    for (const uint16_t v : values) {
      answer_.push_back(static_cast<uint8_t>(v >> 8));
      answer_.push_back(static_cast<uint8_t>(v));
    }
    answer_.insert(answer_.end(), {0, 0});
    Frame answer;
    answer.role = Role::response;
    answer.check_ok = true;
    answer.t_ns = t_ns + 10'000'000;
    answer.adu = answer.raw = answer_;
    answer.request = 1;
    answer.request_slave = 1;
    answer.request_pdu = std::span(request_).subspan(1, 5);
    discovery_.on_frame(answer);
  }

  uint16_t first_, count_;
  uint8_t function_;
  std::vector<uint8_t> request_, answer_;
  RegisterDiscovery discovery_;
};

std::array<uint16_t, 2> float_words(float value, WordOrder order) {
  const uint32_t bits = std::bit_cast<uint32_t>(value);
  const auto high = static_cast<uint16_t>(bits >> 16), low = static_cast<uint16_t>(bits);
  return order == WordOrder::high_first ? std::array{high, low} : std::array{low, high};
}

// A mains voltage in f32, in either word order, beside a frequency: the order that reads every
// value as a float of everyday size wins, and the sizes name the quantities.
TEST(RegisterDiscovery, AFloatIsReadInTheWordOrderItsValuesMakeSenseIn) {
  for (const WordOrder order : {WordOrder::high_first, WordOrder::low_first}) {
    Reads bus(0x0000, 4, 0x04);
    bus.run(60, [&](int n) {
      const auto volts = float_words(230.0f + 1.3f * std::sin(n * 0.3f), order);
      const auto hertz = float_words(50.0f + 0.04f * std::cos(n * 0.2f), order);
      return std::vector<uint16_t>{volts[0], volts[1], hertz[0], hertz[1]};
    });
    const auto registers = bus.registers();
    ASSERT_EQ(registers.size(), 2u);
    EXPECT_EQ(registers[0].type, ValueType::f32);
    EXPECT_EQ(registers[0].order, order);
    EXPECT_EQ(registers[0].table, Table::input);
    EXPECT_EQ(registers[0].confidence, Confidence::high);
    EXPECT_EQ(registers[0].quantity, "voltage");
    EXPECT_EQ(registers[0].unit, "V");
    EXPECT_EQ(registers[1].address, 2);
    EXPECT_EQ(registers[1].type, ValueType::f32);
    EXPECT_EQ(registers[1].quantity, "frequency");
  }
}

// An energy counter over two registers: the high word moves only with the low word's carry,
// which tells the boundary and the order; it only grows.
TEST(RegisterDiscovery, ACounterOverTwoRegistersIsReadByItsCarry) {
  for (const WordOrder order : {WordOrder::high_first, WordOrder::low_first}) {
    Reads bus(0x0100, 2);
    bus.run(40, [&](int n) {
      const uint32_t energy = 0x0001FF00u + 97u * static_cast<uint32_t>(n * n);
      const auto high = static_cast<uint16_t>(energy >> 16), low = static_cast<uint16_t>(energy);
      return order == WordOrder::high_first ? std::vector<uint16_t>{high, low}
                                            : std::vector<uint16_t>{low, high};
    });
    const auto registers = bus.registers();
    ASSERT_EQ(registers.size(), 1u);
    EXPECT_EQ(registers[0].type, ValueType::u32);
    EXPECT_EQ(registers[0].order, order);
    EXPECT_EQ(registers[0].kind, ReadingKind::counter);
    EXPECT_EQ(registers[0].confidence, Confidence::high);
  }
}

// Two 16-bit values that move on their own are no 32-bit number, however often both change:
// no carry moves the one.
TEST(RegisterDiscovery, TwoValuesThatMoveApartStaySixteenBits) {
  Reads bus(0x0000, 2);
  bus.run(50, [](int n) {
    return std::vector<uint16_t>{static_cast<uint16_t>(500 + (n * 37) % 90),
                                 static_cast<uint16_t>(200 + (n * 53) % 80)};
  });
  const auto registers = bus.registers();
  ASSERT_EQ(registers.size(), 2u);
  for (const RegisterReading& r : registers) {
    EXPECT_EQ(r.type, ValueType::u16);
    EXPECT_EQ(r.words, 1);
  }
}

// A temperature around freezing: FFxxH beside 00xxH is a signed number, in tenths a
// temperature.
TEST(RegisterDiscovery, ValuesOnBothSidesOfZeroAreSigned) {
  Reads bus(0x0010, 1);
  bus.run(30, [](int n) {
    return std::vector<uint16_t>{static_cast<uint16_t>(static_cast<int16_t>(-50 + 4 * n))};
  });
  const auto registers = bus.registers();
  ASSERT_EQ(registers.size(), 1u);
  EXPECT_EQ(registers[0].type, ValueType::s16);
  EXPECT_EQ(registers[0].confidence, Confidence::high);
  EXPECT_EQ(registers[0].quantity, "temperature");  // tenths between -40 and 60, across zero
  EXPECT_EQ(registers[0].scale, 0.1);
  EXPECT_DOUBLE_EQ(registers[0].low, -5.0);
  EXPECT_DOUBLE_EQ(registers[0].high, 6.6);
}

// A status word whose bits 0, 3 and 9 change on their own, one at a time (running, at speed,
// remote), beside an enum of three commands whose changes flip two bits as often as one, a
// register never used, a constant, and a device name in text, inside one block.
TEST(RegisterDiscovery, StatusBitsEnumsUnusedWordsConstantsAndTextAreToldApart) {
  Reads bus(0x0000, 6);
  bus.run(40, [](int n) {
    const uint16_t status =
        static_cast<uint16_t>((n / 2) % 2 | ((n + 1) / 3) % 2 << 3 | ((n + 2) / 7) % 2 << 9);
    const uint16_t command = std::array<uint16_t, 3>{1, 6, 5}[(n / 4) % 3];
    return std::vector<uint16_t>{status, command, 0, 0x0106, 0x4D54 /* MT */, 0x3230 /* 20 */};
  });
  const auto registers = bus.registers();
  ASSERT_EQ(registers.size(), 5u);
  EXPECT_EQ(registers[0].kind, ReadingKind::bit_field);
  EXPECT_EQ(registers[1].kind, ReadingKind::enumerated);
  EXPECT_EQ(registers[2].kind, ReadingKind::unused);
  EXPECT_EQ(registers[3].kind, ReadingKind::constant);
  EXPECT_EQ(registers[4].kind, ReadingKind::text);
  EXPECT_EQ(registers[4].words, 2);
}

// A register read fewer times than a reading needs is named, not guessed at.
TEST(RegisterDiscovery, ARegisterReadTooFewTimesIsNamedNotRead) {
  Reads bus(0x0020, 2);
  bus.run(RegisterDiscovery::min_samples - 1, [](int n) {
    return std::vector<uint16_t>{static_cast<uint16_t>(n), 7};
  });
  const auto drafts = bus.found().drafts();
  ASSERT_EQ(drafts.size(), 1u);
  EXPECT_TRUE(drafts[0].registers.empty());
  using Sampled = std::pair<Table, uint16_t>;
  EXPECT_EQ(drafts[0].too_few_samples,
            (std::vector<Sampled>{{Table::holding, 0x20}, {Table::holding, 0x21}}));
}

// The master's program: the blocks of one cycle in order, and its period.
TEST(RegisterDiscovery, ThePollingProgramIsTheCycleTheMasterRepeats) {
  Reads bus(0x0000, 1);
  bus.run(12, [](int n) { return std::vector<uint16_t>{static_cast<uint16_t>(n)}; });
  const PollingProgram program = bus.found().polling_program();
  ASSERT_EQ(program.cycle.size(), 1u);
  EXPECT_EQ(program.cycle[0].function, 0x03);
  EXPECT_EQ(program.period_ns, 1'000'000'000);
  EXPECT_EQ(program.jitter_ns, 0);
}

}  // namespace
}  // namespace modtap
