// modtap-extcap: lets Wireshark capture from a serial port, or from a bus behind a serial
// device server (tcp://HOST:PORT, docs/live.md), through modtap's framer.
// Wireshark runs it with --extcap-interfaces, --extcap-dlts, --extcap-config, and
// --capture --fifo PATH; it writes pcapng (DLT_USER0 with modtap's verdicts) to the FIFO.
#include <dirent.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include "captures/output_file.hpp"
#include "captures/tap_port.hpp"
#include "tools/modtap/model_catalog.hpp"
#include "tools/modtap/run.hpp"

namespace {

using namespace modtap;

constexpr const char* prefix = "modtap:";
// The interface of a bus behind a device server, whose address the capture's options give.
constexpr const char* remote = "modtap:remote";

// USB and on-board serial ports, plus any listed in MODTAP_EXTCAP_PORTS (colon-free paths,
// comma-separated), e.g. a pseudo-terminal under test.
std::vector<std::string> serial_ports() {
  std::vector<std::string> ports;
  if (DIR* dev = opendir("/dev")) {
    while (dirent* e = readdir(dev)) {
      const std::string name = e->d_name;
      for (const char* kind : {"ttyUSB", "ttyACM", "ttyAMA", "rfcomm"})
        if (name.rfind(kind, 0) == 0) ports.push_back("/dev/" + name);
    }
    closedir(dev);
  }
  if (const char* extra = std::getenv("MODTAP_EXTCAP_PORTS")) {
    std::string list = extra;
    for (size_t at = 0; at <= list.size();) {
      const size_t comma = std::min(list.find(',', at), list.size());
      if (comma > at) ports.push_back(list.substr(at, comma - at));
      at = comma + 1;
    }
  }
  return ports;
}

void print_interfaces() {
  fmt::print("extcap {{version={}}}{{display=modtap serial Modbus}}\n", MODTAP_VERSION);
  for (const auto& port : serial_ports())
    fmt::print("interface {{value={}{}}}{{display=Modbus serial (modtap): {}}}\n", prefix, port,
               port);
  fmt::print("interface {{value={}}}{{display=Modbus serial behind a device server (modtap)}}\n",
             remote);
}

void print_config(const tools::ModelCatalog& catalog, bool device_server) {
  int n = 0;
  if (device_server)
    fmt::print(
        "arg {{number={}}}{{call=--server}}{{display=Device server}}{{type=string}}"
        "{{required=true}}{{validation=^(tcp|rfc2217)://.+:[0-9]+$}}{{tooltip=tcp://HOST:PORT of "
        "ser2net, an NPort or another server in TCP-server mode, baud and parity as its port "
        "has them; rfc2217://HOST:PORT of one that takes RFC 2217, its port set to them}}\n",
        n++);
  auto selector = [&](const char* call, const char* display, const char* fallback,
                      std::initializer_list<const char*> values) {
    fmt::print("arg {{number={}}}{{call=--{}}}{{display={}}}{{type=selector}}\n", n, call, display);
    for (const char* v : values)
      fmt::print("value {{arg={}}}{{value={}}}{{display={}}}{{default={}}}\n", n, v, v,
                 std::string(v) == fallback ? "true" : "false");
    ++n;
  };
  selector("baud", "Baud rate", "19200",
           {"1200", "2400", "4800", "9600", "19200", "38400", "57600", "115200"});
  selector("parity", "Parity", "even", {"none", "even", "odd"});
  selector("data-bits", "Data bits", "8", {"7", "8"});
  selector("stop-bits", "Stop bits", "1", {"1", "2"});
  selector("mode", "Mode", "auto", {"auto", "rtu", "ascii"});
  // The device model the registers are read with (a GD20 that identifies itself is found
  // whatever is chosen here).
  fmt::print("arg {{number={}}}{{call=--model}}{{display=Device model}}{{type=selector}}\n", n);
  for (const auto& entry : catalog.entries())
    fmt::print("value {{arg={}}}{{value={}}}{{display={}}}{{default={}}}\n", n, entry.model.name,
               entry.model.title, entry.model.name == "generic" ? "true" : "false");
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"modtap-extcap: modtap's serial Modbus capture for Wireshark"};
  app.allow_extras();  // Wireshark may add options of its own in later versions
  bool interfaces = false, dlts = false, config = false, capture = false;
  std::string interface, fifo, version, filter, server;
  tools::RunOptions run;
  run.models = {"generic"};
  app.add_flag("--extcap-interfaces", interfaces);
  app.add_flag("--extcap-dlts", dlts);
  app.add_flag("--extcap-config", config);
  app.add_flag("--capture", capture);
  app.add_option("--extcap-interface", interface);
  app.add_option("--extcap-version", version);
  app.add_option("--extcap-capture-filter", filter);
  app.add_option("--fifo", fifo);
  app.add_option("--server", server);
  tools::add_line_options(app, run);  // as modtap's, with the same checks
  CLI11_PARSE(app, argc, argv);

  if (interfaces) {
    print_interfaces();
    return 0;
  }
  if (interface.rfind(prefix, 0) != 0) {
    fmt::print(stderr, "modtap-extcap: unknown interface \"{}\"\n", interface);
    return 1;
  }
  if (dlts) {
    fmt::print("dlt {{number=147}}{{name=USER0}}{{display=Modbus serial with modtap verdicts}}\n");
    return 0;
  }
  if (config) {
    tools::ModelCatalog catalog;
    catalog.load_builtin();
    print_config(catalog, interface == remote);
    return 0;
  }
  if (!capture || fifo.empty()) {
    fmt::print(stderr, "modtap-extcap: nothing to do\n");
    return 1;
  }
  // Wireshark's capture is modtap's `-i PORT -w FIFO`, quietly: Wireshark reads anything on
  // standard error as an error.
  run.interfaces = {interface.substr(std::string(prefix).size())};
  if (interface == remote) {
    if (!captures::is_network_tap(server)) {
      fmt::print(stderr,
                 "modtap-extcap: the device server is tcp://HOST:PORT or rfc2217://HOST:PORT, "
                 "not \"{}\"\n",
                 server);
      return 1;
    }
    run.interfaces = {server};
    run.jitter_ms = captures::network_read_jitter_ms;
  }
  run.write_file = fifo;
  run.output = tools::OutputKind::none;
  run.announce = false;
  try {
    return tools::listen(run, {}, {});
  } catch (const captures::WriteError& e) {
    // Wireshark stops a capture by closing the FIFO: that is its end, not an error to show.
    if (e.broken_pipe()) return 0;
    fmt::print(stderr, "modtap-extcap: cannot write {}\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    fmt::print(stderr, "modtap-extcap: {}\n", e.what());
    return 1;
  }
}
