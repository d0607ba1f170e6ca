// modtap-bus-simulator: writes simulated bus traffic as a capture file, for benchmarks and demos.
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "captures/hexlog_writer.hpp"
#include "captures/pcap_chunk_writer.hpp"
#include "decoder/models/model_yaml.hpp"
#include "tools/busgen/bus_simulator.hpp"
#include "tools/busgen/device_bus.hpp"
#include "tools/help_format.hpp"

namespace {

using namespace modtap;

// Frame-per-packet pcaps start at a fixed, recent date so that tools show sensible times.
constexpr int64_t epoch_ns = 1'700'000'000'000'000'000;

int write(const busgen::BusCapture& capture, const std::string& format, busgen::Delivery delivery,
          uint64_t seed, const std::string& path) {
  const auto chunks = busgen::deliver(capture, delivery, seed);
  auto chunk = [&](const busgen::DeliveredChunk& c) {
    return Chunk{0, epoch_ns + c.t_ns, {capture.bytes.data() + c.offset, c.size}};
  };
  if (format == "pcap") {
    captures::PcapChunkWriter writer(path, 147);
    for (const auto& c : chunks) writer.write(chunk(c));
  } else if (format == "hexlog") {
    captures::HexlogWriter writer(path);
    for (const auto& c : chunks) writer.write(chunk(c));
    writer.close();
  } else {
    captures::OutputFile file(path);
    file.write(capture.bytes);
    file.close();
  }
  return 0;
}

// "SLAVE=FILE": the device at SLAVE, its model (and truth) read from FILE.
busgen::SimulatedDevice device_of(const std::string& spec) {
  const size_t eq = spec.find('=');
  if (eq == std::string::npos) throw std::invalid_argument("give SLAVE=MODEL.yaml, not " + spec);
  const int slave = std::stoi(spec.substr(0, eq));
  if (slave < 1 || slave > 247)
    throw std::invalid_argument("slave " + spec.substr(0, eq) + " is not 1-247");
  const std::string file = spec.substr(eq + 1);
  std::ifstream in(file);
  if (!in) throw std::invalid_argument("cannot read " + file);
  std::ostringstream yaml;
  yaml << in.rdbuf();
  return {static_cast<uint8_t>(slave), parse_model(yaml.str(), file)};
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"modtap-bus-simulator: simulated Modbus RTU traffic as a capture file"};
  app.formatter(std::make_shared<modtap::tools::HelpFormatter>());
  app.set_version_flag("--version", std::string("modtap-bus-simulator ") + MODTAP_VERSION);
  busgen::BusOptions o;
  std::string out = "-", format = "raw", delivery_name = "frames";
  app.add_option("-n,--transactions", o.transactions, "Request/response pairs to simulate");
  app.add_option("--seed", o.seed, "Random seed");
  app.add_flag("--back-to-back", o.back_to_back, "No idle time between frames");
  app.add_option("--format", format, "raw, pcap (DLT_USER0) or hexlog")
      ->check(CLI::IsMember({"raw", "pcap", "hexlog"}));
  app.add_option("--delivery", delivery_name,
                 "For pcap and hexlog: frames (one frame a packet), bytes, bursts (16 ms), usb "
                 "(an FTDI's packets: 62 bytes, or 16 ms), sniffer (frames, some split, some "
                 "merged)")
      ->check(CLI::IsMember({"frames", "bytes", "bursts", "usb", "sniffer"}));
  app.add_option("--slaves", o.polled_slaves,
                 "Poll slaves 1 to N in turn, as a PLC's scan list does (default: each request to "
                 "a slave picked at random from 1-247)")
      ->check(CLI::Range(1, 247));
  app.add_option("-o,--output", out, "Output file (- for stdout, raw only)")->type_name("FILE");
  bool faults = false, ascii = false;
  app.add_flag("--faults", faults,
               "What real buses add: glitches, line noise, requests broken off and sent again, "
               "retries, responses cut or collided with or garbled, pauses inside frames, "
               "out-of-spec requests, vendor codes");
  app.add_option("--bit-errors", o.corruption_rate,
                 "Line noise: this share of all frames, requests and answers, arrives with bits "
                 "flipped (a bad CRC)")
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--reflections", o.reflection_rate,
                 "A trunk not terminated: bits flip in frames with odds that grow with their "
                 "length, none at 8 bytes, this at 32 and on, from every sender alike")
      ->check(CLI::Range(0.0, 1.0));
  const auto bus_time = [](int64_t& target) {
    return [&target](const std::string& text) {
      const auto ns = busgen::bus_time_ns(text);
      if (!ns || *ns <= 0) throw CLI::ValidationError("a time, as 700ms or 2.5s: " + text);
      target = *ns;
    };
  };
  app.add_option_function<std::string>(
         "--noise-bursts", bus_time(o.noise_burst_period_ns),
         "A contactor or drive switching nearby: a burst of 2 to 6 junk bytes every TIME (as "
         "700ms), destroying the frame it falls on")
      ->type_name("TIME");
  app.add_option_function<std::string>(
         "--second-master", bus_time(o.second_master_period_ns),
         "A second master on the line: every TIME it reads slave 201 on its own program, as "
         "soon as the line is quiet, which may be right after the first master's request")
      ->type_name("TIME");
  std::vector<std::string> slave_faults;
  app.add_option("--slave-fault", slave_faults,
                 "A slave's faults, as ADDR:FAULT[,FAULT...], repeatable: absent, stops=TIME "
                 "(silent from then on), drop=RATE (misses requests), slow=TIME (its turnaround), "
                 "late (answers after the master's time-out), bit-errors=RATE (of its answers), "
                 "missing-block=START+COUNT (read every cycle, answered by exception 02), "
                 "duplicate (two devices answer at once), glitch (before every answer), "
                 "half-baud (set to half the line's baud: its answers read as junk), "
                 "restarts=TIME (silent 5 s of every TIME), slow-block=START+COUNT (read every "
                 "cycle, answered after 60 ms); "
                 "e.g. 2:slow=131ms 6:missing-block=0400H+4")
      ->type_name("ADDR:FAULT");
  app.add_flag("--ascii", ascii, "Modbus ASCII instead of RTU (7E1)");
  std::vector<std::string> device_specs;
  busgen::DeviceBusOptions devices;
  double period_s = 1.0;
  app.add_option("--device", device_specs,
                 "Instead of random traffic: a device with a known map, SLAVE=MODEL.yaml "
                 "(repeatable), whose registers the master reads every period, their values moving "
                 "as the model's types, ranges, enums and bits say (tools/busgen/device_bus.hpp)")
      ->type_name("SLAVE=FILE");
  app.add_option("--cycles", devices.cycles, "With --device: the master's polling cycles");
  app.add_option("--period", period_s, "With --device: seconds between cycles")
      ->check(CLI::PositiveNumber);
  CLI11_PARSE(app, argc, argv);
  try {
    for (const auto& spec : slave_faults) busgen::add_slave_faults(o, spec);
    for (const auto& [slave, unused] : o.slave_faults) {
      if (o.polled_slaves && slave > o.polled_slaves)
        throw std::invalid_argument("slave " + std::to_string(slave) + " is not polled (--slaves " +
                                    std::to_string(o.polled_slaves) + ")");
    }
  } catch (const std::invalid_argument& e) {
    return app.exit(CLI::ValidationError("--slave-fault", e.what()));
  }
  if (faults) {
    o.glitch_rate = o.request_glitch_rate = 0.01;
    o.noise_rate = o.truncation_rate = o.retry_rate = o.cut_rate = o.collision_rate = 0.01;
    o.out_of_spec_rate = o.unknown_function_rate = 0.01;
    o.pause_rate = o.garbled_rate = 0.01;
  }
  if (ascii) {
    o.mode = Mode::ascii;
    o.format.data_bits = 7;
  }
  const std::map<std::string, busgen::Delivery> deliveries{
      {"frames", busgen::Delivery::whole_frames},
      {"bytes", busgen::Delivery::per_byte},
      {"bursts", busgen::Delivery::bursts},
      {"usb", busgen::Delivery::usb_packets},
      {"sniffer", busgen::Delivery::per_frame}};
  busgen::BusCapture capture;
  if (device_specs.empty()) {
    capture = busgen::simulate(o);
  } else {
    try {
      for (const auto& spec : device_specs) devices.devices.push_back(device_of(spec));
    } catch (const std::exception& e) {
      std::fprintf(stderr, "modtap-bus-simulator: --device: %s\n", e.what());
      return 2;
    }
    devices.seed = o.seed;
    devices.format = o.format;
    devices.period_ns = static_cast<int64_t>(period_s * 1e9);
    capture = busgen::simulate_devices(devices);
  }
  std::fprintf(stderr, "%zu frames, %zu bytes\n", capture.frames.size(), capture.bytes.size());
  try {
    return write(capture, format, deliveries.at(delivery_name), o.seed, out);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "modtap-bus-simulator: %s\n", e.what());
    return 2;
  }
}
