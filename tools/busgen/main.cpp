// modtap-busgen: writes simulated bus traffic as a raw byte file, for benchmarks and demos.
#include <cstdio>

#include <CLI/CLI.hpp>

#include "tools/busgen/bus_simulator.hpp"

int main(int argc, char** argv) {
  CLI::App app{"modtap-busgen: simulated Modbus RTU traffic as raw bytes"};
  modtap::busgen::BusOptions o;
  std::string out = "-";
  app.add_option("-n,--transactions", o.transactions, "Request/response pairs to simulate");
  app.add_option("--seed", o.seed, "Random seed");
  app.add_flag("--back-to-back", o.back_to_back, "No idle time between frames");
  app.add_option("-o,--output", out, "Output file (- for stdout)");
  CLI11_PARSE(app, argc, argv);
  const auto capture = modtap::busgen::simulate(o);
  FILE* f = out == "-" ? stdout : std::fopen(out.c_str(), "wb");
  if (!f) {
    std::perror(out.c_str());
    return 2;
  }
  std::fwrite(capture.bytes.data(), 1, capture.bytes.size(), f);
  std::fprintf(stderr, "%zu frames, %zu bytes\n", capture.frames.size(), capture.bytes.size());
  if (f != stdout) std::fclose(f);
  return 0;
}
