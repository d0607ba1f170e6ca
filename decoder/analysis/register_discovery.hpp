// What the traffic says of a slave's registers where no model does (modtap discover): the blocks
// the master reads and writes, each register's values over time, the reading of each register
// those values support best with its runner-up, and the master's polling program. Pure: records
// in, a draft out; its room grows with the registers read, not with the capture's length.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "decoder/models/device_model.hpp"
#include "decoder/protocol/record_sink.hpp"

namespace modtap {

// A register's values over time, in constant room: what tells its reading.
struct WordHistory {
  static constexpr size_t max_distinct = 16;
  uint64_t samples = 0;
  uint64_t changes = 0;  // samples that differ from the one before
  uint64_t rises = 0;    // ... upwards, unsigned
  uint64_t falls = 0;
  uint16_t first = 0, last = 0;
  uint16_t min = UINT16_MAX, max = 0;
  int16_t signed_min = INT16_MAX, signed_max = INT16_MIN;
  std::array<uint32_t, 16> bit_changes{};  // how often each bit changed between two samples
  std::array<uint16_t, max_distinct> distinct{};
  uint8_t distinct_count = 0;
  bool many_values = false;  // more than max_distinct

  void add(uint16_t value);
  // The bits that ever changed, as a mask.
  uint16_t changing_bits() const;
};

// Two neighbouring registers read together as one 32-bit number, in one word order.
struct PairHistory {
  uint64_t samples = 0;
  uint64_t floats = 0;  // samples that read as a plausible float (or exactly 0)
  uint64_t zeros = 0;
  uint64_t rises = 0, falls = 0;  // unsigned, between two samples
  // Samples whose high word differs from the one before, and those of them where the low word
  // wrapped the other way (a carry or a borrow): a 32-bit number's high word moves only so.
  uint64_t high_changes = 0, carries = 0;
  uint64_t low_changes = 0;
  uint32_t last = 0;
  uint32_t min = UINT32_MAX, max = 0;
  int32_t signed_min = INT32_MAX, signed_max = INT32_MIN;
  double float_min = 0, float_max = 0;
  double float_jumps = 0;  // the sum of each step's size against the larger value: smoothness

  void add(uint32_t value);
};

// A block of registers read or written in one request.
struct BlockKey {
  uint8_t slave = 0;
  uint8_t function = 0;
  uint16_t first = 0;
  uint16_t count = 0;
  auto operator<=>(const BlockKey&) const = default;
};

struct BlockTimes {
  uint64_t requests = 0;
  uint64_t answered = 0;
  int64_t first_ns = 0, last_ns = 0;
  int64_t min_gap_ns = INT64_MAX, max_gap_ns = 0;
  // The mean time between two requests of the block, where there were two.
  std::optional<int64_t> period_ns() const;
};

enum class Confidence : uint8_t { low, medium, high };
template <>
struct EnumNames<Confidence> {
  static constexpr std::array<std::string_view, 3> names{"low", "medium", "high"};
};

// What a register (or a run of them) reads as, by its values.
enum class ReadingKind : uint8_t {
  number,      // u16, s16, u32, s32, f32 by the type
  counter,     // a number that only grows (or wraps)
  enumerated,  // a few values, in steps
  bit_field,   // bits that change on their own, not as a number's low bits
  constant,
  unused,  // always 0
  text,    // ASCII in a run of registers
};
template <>
struct EnumNames<ReadingKind> {
  static constexpr std::array<std::string_view, 7> names{
      "number", "counter", "enum", "bit field", "constant", "unused", "string"};
};

struct RegisterReading {
  uint16_t address = 0;
  Table table = Table::holding;
  ReadingKind kind = ReadingKind::number;
  ValueType type = ValueType::u16;
  WordOrder order = WordOrder::high_first;
  uint16_t words = 1;
  Confidence confidence = Confidence::low;
  std::string runner_up;  // the next likeliest reading, or empty where none is close
  std::string why;        // the evidence, in words
  // A quantity the values fit, only where they fit one well: "voltage", "frequency".
  std::string quantity;
  double scale = 1.0;
  std::string unit;
  uint64_t samples = 0;      // the reads it was drawn from
  double low = 0, high = 0;  // the values seen, read so and scaled
  uint64_t writes = 0;       // values the master wrote to it (FC06, FC16, FC17, FC23)
  bool write_only = false;   // the master writes it and never reads it
};

// A request of the master's polling program: a block, in the order one cycle asks for them.
struct PolledBlock {
  BlockKey block;
  BlockTimes times;
};

struct SlaveDraft {
  uint8_t slave = 0;
  std::vector<PolledBlock> blocks;  // read and written, by first register
  std::vector<RegisterReading> registers;
  // Registers read fewer times than a reading needs: named so, to be read longer.
  std::vector<std::pair<Table, uint16_t>> too_few_samples;  // read too few times to tell
};

struct PollingProgram {
  std::vector<BlockKey> cycle;  // the requests of one cycle, in order; empty if none repeats
  size_t cycles_seen = 0;       // cycles that were so, of
  size_t cycles_all = 0;        // the cycles seen in the first requests
  std::optional<int64_t> period_ns;
  int64_t jitter_ns = 0;  // the widest gap between two cycles' starts less the narrowest
};

class RegisterDiscovery final : public RecordSink {
 public:
  // Samples a register needs before its reading is drawn.
  static constexpr uint64_t min_samples = 8;
  // The first requests, in order, that the polling program is drawn from: bounded.
  static constexpr size_t program_window = 512;
  // Registers followed at most (about 40 MB): a bus reads a few hundred; junk read as answers
  // from random stations could name millions.
  static constexpr size_t max_registers = 1 << 16;

  void on_frame(const Frame& frame) override;
  void on_noise(const Noise&) override {}
  void on_timeout(const Timeout&) override {}

  bool saw_register_reads() const { return !words_.empty(); }
  // Values of registers past max_registers, not followed.
  uint64_t registers_not_followed() const { return registers_not_followed_; }
  std::vector<SlaveDraft> drafts() const;
  PollingProgram polling_program() const;

 private:
  struct WordKey {
    uint8_t slave;
    Table table;
    uint16_t address;
    auto operator<=>(const WordKey&) const = default;
  };
  struct Words {
    WordHistory history;  // the values its answers read
    WordHistory written;  // the values the master wrote
    // This register and the next read as one number, high word first and low word first.
    std::array<PairHistory, 2> pairs;
    uint64_t pair_samples = 0;
  };
  static BlockKey block_of(uint8_t slave, std::span<const uint8_t> pdu);
  void on_request(const Frame& frame);
  void on_access(uint8_t slave, const RegisterAccess& access);
  void on_values(uint8_t slave, Table table, uint16_t first, std::span<const uint8_t> data,
                 bool written = false);
  SlaveDraft draft_of(uint8_t slave) const;
  std::vector<RegisterReading> readings_of(uint8_t slave, Table table) const;

  std::map<WordKey, Words> words_;
  std::map<BlockKey, BlockTimes> blocks_;
  std::vector<std::pair<BlockKey, int64_t>> requests_;
  uint64_t registers_not_followed_ = 0;
};

// The reading of one register alone, or of it and the next as one number (in both word orders,
// high word first and low word first), by their values: exposed for the tests of the method.
RegisterReading read_word(const WordHistory& history);
RegisterReading read_written(uint16_t address, Table table, const WordHistory& written);
std::optional<RegisterReading> read_pair(const std::array<PairHistory, 2>& pair);

}  // namespace modtap
