// Listening on one or two serial ports: reads as bytes arrive, time stamps each read, feeds
// the analyzer, and resolves frames when the line goes quiet. Shared by modtap -i and the
// Wireshark extcap.
#pragma once

#include <atomic>
#include <string>
#include <vector>

#include "decoder/analyzer.hpp"

namespace modtap::live {

struct PortSpec {
  std::string name;  // "master", "slave", or the path
  std::string path;
  decoder::ChannelRole role = decoder::ChannelRole::bus;
};

// Parses "PATH" or "master=PATH" / "slave=PATH"; throws std::invalid_argument.
PortSpec parse_port(const std::string& spec);

struct LiveOptions {
  decoder::AnalyzerOptions analyzer;  // its clock is set to per_chunk
  bool reconnect = false;             // wait for an unplugged port instead of ending
  bool status_line = false;           // a rate/frames/errors line on stderr, once a second
  bool announce = true;               // say on stderr what is being listened to
};

// Runs until `stop` is set (a signal) or a port disappears without --reconnect; then
// finishes the analyzer so every sink can close its files. Returns the exit status.
int run_live(const std::vector<PortSpec>& ports, const LiveOptions& options,
             decoder::RecordSink& sink, const std::atomic<bool>& stop);

// Installs SIGINT and SIGTERM handlers that set the returned flag.
const std::atomic<bool>& stop_on_signals();

}  // namespace modtap::live
