// Devices with known register maps on one bus, their values moving as real ones do: the truth
// that modtap discover's drafts are measured against (docs/discover.md). Each device is a model
// file, and the model is the truth: the master reads every register it defines, in blocks (a
// gap of up to 4 unused registers inside a block reads as 0), every period; each register's
// value follows what the model says of it:
// - an enum steps through its named values; a register of bits toggles each bit on its own;
// - a string reads its label's text;
// - min and max given: the same, a constant; else a smooth swing across 80 % of the range;
// - a 32- or 64-bit integer with no range: a counter that grows (its low word wraps);
// - anything else: a constant.
// Registers the model marks write-only (access: W) the master writes every 5 cycles instead, as
// the same rules move their values (a setpoint, a command).
// Values are scaled back by the register's scale and offset, and stored in its type and order.
#pragma once

#include <cstdint>
#include <vector>

#include "decoder/models/device_model.hpp"
#include "decoder/protocol/serial_format.hpp"
#include "tools/busgen/bus_simulator.hpp"

namespace modtap::busgen {

struct SimulatedDevice {
  uint8_t slave = 1;
  DeviceModel model;
};

struct DeviceBusOptions {
  std::vector<SimulatedDevice> devices;
  size_t cycles = 120;
  int64_t period_ns = 1'000'000'000;
  uint64_t seed = 1;
  SerialFormat format;
};

BusCapture simulate_devices(const DeviceBusOptions& options);

// The 16-bit words `def` holds `value` as, in cycle `cycle` of the simulation (for a test).
std::vector<uint16_t> register_words(const RegisterDef& def, size_t cycle, uint64_t seed);

}  // namespace modtap::busgen
