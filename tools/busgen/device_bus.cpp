#include "tools/busgen/device_bus.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <numbers>

namespace modtap::busgen {
namespace {

constexpr uint16_t max_gap = 4;      // unused registers a block reads across
constexpr uint16_t max_block = 100;  // registers a block reads at most, or the model's limit
constexpr int64_t turnaround_ns = 6'000'000;
constexpr int64_t between_ns = 15'000'000;
constexpr size_t write_every = 5;  // cycles between the master's writes of a register

// A register's own phase, so that no two move together.
double phase_of(const RegisterDef& def, uint64_t seed) {
  return static_cast<double>((def.address * 2654435761u + seed * 40503u) % 1000) / 1000.0;
}

uint16_t words_of(const RegisterDef& def) {
  const uint16_t fixed = words_of_type(def.type);
  return fixed ? fixed : def.words;
}

// The value the register reads in `cycle`, in its own units (before scale and offset).
double value_of(const RegisterDef& def, size_t cycle, uint64_t seed) {
  const double phase = phase_of(def, seed);
  const double k = static_cast<double>(cycle);
  if (def.min && def.max) {
    if (*def.min == *def.max) return *def.min;
    const double mid = (*def.min + *def.max) / 2, swing = (*def.max - *def.min) / 2 * 0.8;
    return mid + swing * std::sin(2 * std::numbers::pi * (k / 40 + phase));
  }
  const bool wide = words_of(def) >= 2 && def.type != ValueType::f32;
  if (wide) return (65000 + 1000 * phase + 1997 * k) * def.scale + def.offset;  // a counter
  return (100 + std::floor(900 * phase)) * def.scale + def.offset;              // a constant
}

uint64_t raw_of(const RegisterDef& def, size_t cycle, uint64_t seed) {
  if (def.values && !def.values->empty()) {
    auto it = def.values->begin();
    std::advance(it, static_cast<long>((cycle / 7 + def.address) % def.values->size()));
    return static_cast<uint64_t>(it->first);
  }
  if (!def.bits.empty()) {
    uint64_t raw = 0;
    for (size_t i = 0; i < def.bits.size(); ++i)
      raw |= uint64_t{(cycle / (3 + 2 * i)) % 2} << def.bits[i].lsb;
    return raw;
  }
  const double value = value_of(def, cycle, seed);
  if (def.type == ValueType::f32)
    return std::bit_cast<uint32_t>(static_cast<float>((value - def.offset) / def.scale));
  return static_cast<uint64_t>(std::llround((value - def.offset) / def.scale));
}

// The register's blocks: its table's registers, runs with gaps of at most max_gap between.
struct Block {
  Table table;
  uint16_t first;
  uint16_t count;
};
std::vector<Block> blocks_of(const DeviceModel& model) {
  std::vector<Block> blocks;
  for (const auto& [key, def] : model.registers) {
    const auto [table, address] = key;
    if ((table != Table::holding && table != Table::input) || def.access == Access::write ||
        def.reserved)
      continue;
    const uint16_t end = static_cast<uint16_t>(address + words_of(def));
    Block* last = blocks.empty() ? nullptr : &blocks.back();
    if (last && last->table == table && address <= last->first + last->count + max_gap &&
        end - last->first <= std::min<int>(max_block, model.rtu_limits.read)) {
      last->count = static_cast<uint16_t>(std::max<int>(last->count, end - last->first));
      continue;
    }
    blocks.push_back({table, address, static_cast<uint16_t>(end - address)});
  }
  return blocks;
}

class DeviceBus {
 public:
  explicit DeviceBus(const DeviceBusOptions& o) : o_(o), char_ns_(o.format.char_time_ns()) {}

  BusCapture run() {
    for (size_t cycle = 0; cycle < o_.cycles; ++cycle) {
      t_ = std::max(t_, static_cast<int64_t>(cycle) * o_.period_ns);
      for (const SimulatedDevice& device : o_.devices) {
        for (const Block& block : blocks_of(device.model)) read(device, block, cycle);
        if (cycle % write_every == 0)
          for (const auto& [key, def] : device.model.registers)
            if (key.first == Table::holding && def.access == Access::write)
              write(device, def, cycle);
      }
    }
    return std::move(capture_);
  }

 private:
  void read(const SimulatedDevice& device, const Block& block, size_t cycle) {
    const uint8_t function = block.table == Table::holding ? 0x03 : 0x04;
    std::vector<uint8_t> request{device.slave, function};
    put16(request, block.first);
    put16(request, block.count);
    const size_t asked = send(request, Role::request, device.slave, std::nullopt);
    std::vector<uint16_t> words(block.count, 0);
    for (const auto& [key, def] : device.model.registers) {
      if (key.first != block.table || key.second < block.first) continue;
      const std::vector<uint16_t> held = register_words(def, cycle, o_.seed);
      for (size_t i = 0; i < held.size() && key.second - block.first + i < block.count; ++i)
        words[key.second - block.first + i] = held[i];
    }
    std::vector<uint8_t> answer{device.slave, function, static_cast<uint8_t>(2 * block.count)};
    for (const uint16_t w : words) put16(answer, w);
    t_ += turnaround_ns;
    send(answer, Role::response, device.slave, asked);
    t_ += between_ns;
  }

  // The master sets a register it only writes (a setpoint, a command): FC06 for one word, FC16
  // for more; the device answers as the standard says.
  void write(const SimulatedDevice& device, const RegisterDef& def, size_t cycle) {
    const std::vector<uint16_t> words = register_words(def, cycle, o_.seed);
    std::vector<uint8_t> request{device.slave,
                                 static_cast<uint8_t>(words.size() == 1 ? 0x06 : 0x10)};
    put16(request, def.address);
    if (words.size() > 1) {
      put16(request, static_cast<uint16_t>(words.size()));
      request.push_back(static_cast<uint8_t>(2 * words.size()));
    }
    for (const uint16_t w : words) put16(request, w);
    const size_t asked = send(request, Role::request, device.slave, std::nullopt);
    // FC06 echoes its request; FC16 answers with its address and count: six bytes either way.
    const std::vector<uint8_t> answer(request.begin(), request.begin() + 6);
    t_ += turnaround_ns;
    send(answer, Role::response, device.slave, asked);
    t_ += between_ns;
  }

  static void put16(std::vector<uint8_t>& out, uint16_t v) {
    out.push_back(static_cast<uint8_t>(v >> 8));
    out.push_back(static_cast<uint8_t>(v));
  }

  size_t send(const std::vector<uint8_t>& body, Role role, uint8_t slave,
              std::optional<size_t> request) {
    const uint64_t offset = capture_.bytes.size();
    encode_frame(Mode::rtu, body, capture_.bytes);
    for (uint64_t i = offset; i < capture_.bytes.size(); ++i) {
      t_ += char_ns_;
      capture_.end_ns.push_back(t_);
    }
    TruthFrame frame;
    frame.offset = offset;
    frame.size = static_cast<uint32_t>(capture_.bytes.size() - offset);
    frame.role = role;
    frame.request = request;
    frame.slave = slave;
    capture_.frames.push_back(frame);
    return capture_.frames.size() - 1;
  }

  const DeviceBusOptions& o_;
  const int64_t char_ns_;
  int64_t t_ = 0;
  BusCapture capture_;
};

}  // namespace

std::vector<uint16_t> register_words(const RegisterDef& def, size_t cycle, uint64_t seed) {
  const uint16_t count = words_of(def);
  std::vector<uint16_t> words(count, 0);
  if (def.type == ValueType::string) {
    for (size_t i = 0; i < def.label.size() && i < 2u * count; ++i)
      words[i / 2] = static_cast<uint16_t>(words[i / 2] | static_cast<uint8_t>(def.label[i])
                                                              << (i % 2 ? 0 : 8));
    return words;
  }
  const uint64_t raw = raw_of(def, cycle, seed);
  for (uint16_t i = 0; i < count; ++i) {
    const auto word = static_cast<uint16_t>(raw >> (16 * (count - 1 - i)));  // high word first
    words[def.order == WordOrder::high_first ? i : count - 1 - i] = word;
  }
  return words;
}

BusCapture simulate_devices(const DeviceBusOptions& options) {
  return DeviceBus(options).run();
}

}  // namespace modtap::busgen
