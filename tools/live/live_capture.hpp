// Listening on one or two serial ports: reads as bytes arrive, time stamps each read, feeds
// the analyzer, and resolves frames when the line goes quiet. Shared by modtap -i and the
// Wireshark extcap.
#pragma once

#include <atomic>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "decoder/protocol/analyzer.hpp"

namespace modtap::live {

struct PortSpec {
  std::string name;  // "master", "slave", or the path
  std::string path;
  ChannelRole role = ChannelRole::bus;
};

// Parses "PATH" or "master=PATH" / "slave=PATH"; throws std::invalid_argument.
PortSpec parse_port(const std::string& spec);

// Bytes read before the capture proper (while probing settings), to be analysed first.
struct ReadBytes {
  uint16_t channel = 0;
  int64_t t_ns = 0;
  std::vector<uint8_t> bytes;
};

// What happens to a port: a read fails (unplugged), or it comes back (--reconnect).
enum class PortEvent : uint8_t { read_failed, came_back };

struct LiveOptions {
  AnalyzerOptions analyzer;       // its clock is set to per_chunk
  bool reconnect = false;         // wait for an unplugged port instead of ending
  bool status_line = false;       // a rate/frames/errors line on stderr, once a second
  bool announce = true;           // say on stderr what is being listened to
  std::vector<ReadBytes> replay;  // analysed before the first read
  // Every read, as read (--save-raw), and whether it begins after every frame before it
  // was out (where a file of reads may turn).
  std::function<void(const Chunk&, bool between_frames)> on_read;
  // After every wake of the loop (a read, or a wait of about t3.5 with none), with the time:
  // what paces itself by the clock even on a silent bus (--mqtt).
  std::function<void(int64_t now_ns)> on_wake;
  std::function<void(PortEvent)> on_port_event;  // for the metrics
  std::function<bool(int64_t now_ns)> done;      // -a: stop when it says so
};

// Runs until `stop` is set (a signal) or a port disappears without --reconnect; then
// finishes the analyzer so every sink can close its files. Returns the exit status.
int run_live(const std::vector<PortSpec>& ports, const LiveOptions& options, RecordSink& sink,
             const std::atomic<bool>& stop);

struct ProbeResult {
  SerialFormat format;
  std::vector<ReadBytes> read;  // what was read under that format, so no byte is lost
};

// --baud auto on live ports: listens under each candidate format in turn (never transmitting)
// for up to `window_ns`, and returns the one under which the most bytes formed good frames.
// Says on stderr what it tried. A fixed baud or parity narrows the search.
ProbeResult probe_ports(const std::vector<PortSpec>& ports, const LiveOptions& options,
                        std::optional<uint32_t> baud, std::optional<Parity> parity,
                        int64_t window_ns, const std::atomic<bool>& stop);

// The wall clock the live loop stamps reads with (it never jumps, docs/live.md).
int64_t wall_clock_ns();

// Installs SIGINT and SIGTERM handlers that set the returned flag.
const std::atomic<bool>& stop_on_signals();
// Sets that flag from within the program (-c N reached).
void request_stop();

}  // namespace modtap::live
