#include "tools/live/live_capture.hpp"

#include <poll.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <memory>
#include <stdexcept>
#include <thread>

#include <fmt/format.h>

#include "captures/chunk_source.hpp"
#include "captures/tap_port.hpp"
#include "decoder/protocol/format_probe.hpp"

namespace modtap::live {
namespace {

using captures::open_tap;
using captures::TapPort;

std::atomic<bool> stop_requested{false};

void on_signal(int) {
  stop_requested = true;
}

int64_t clock_ns(clockid_t clock) {
  timespec ts{};
  clock_gettime(clock, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

// Wall-clock time that never jumps: the real-time clock read once, then advanced by the
// monotonic clock, so an NTP step cannot fold or stretch the gaps that delimit frames.
int64_t now_ns() {
  static const int64_t offset = clock_ns(CLOCK_REALTIME) - clock_ns(CLOCK_MONOTONIC);
  return clock_ns(CLOCK_MONOTONIC) + offset;
}

// Counts what went by, for the status line.
class Counting final : public RecordSink {
 public:
  explicit Counting(RecordSink& next) : next_(next) {}
  void on_frame(const Frame& f) override {
    ++frames;
    errors += !f.check_ok;
    next_.on_frame(f);
  }
  void on_noise(const Noise& n) override {
    ++noise;
    next_.on_noise(n);
  }
  void on_timeout(const Timeout& t) override {
    timeouts += t.timed_out();
    next_.on_timeout(t);
  }
  uint64_t frames = 0, errors = 0, noise = 0, timeouts = 0;

 private:
  RecordSink& next_;
};

}  // namespace

PortSpec parse_port(const std::string& spec) {
  const auto eq = spec.find('=');
  if (eq == std::string::npos) return {spec, spec, ChannelRole::bus};
  PortSpec p{spec.substr(0, eq), spec.substr(eq + 1), ChannelRole::bus};
  if (p.name == "master") {
    p.role = ChannelRole::master;
  } else if (p.name == "slave") {
    p.role = ChannelRole::slave;
  } else {
    throw std::invalid_argument("a port is PATH, master=PATH or slave=PATH, not \"" + spec + "\"");
  }
  if (p.path.empty()) throw std::invalid_argument("no path in \"" + spec + "\"");
  return p;
}

ProbeResult probe_ports(const std::vector<PortSpec>& specs, const LiveOptions& options,
                        std::optional<uint32_t> baud, std::optional<Parity> parity,
                        int64_t window_ns, const std::atomic<bool>& stop) {
  // A device server's own port sets the line's settings, and its bytes read the same whatever
  // modtap is told: nothing to listen for.
  for (const auto& spec : specs)
    if (captures::is_network_tap(spec.path) && !captures::sets_server_port(spec.path))
      throw captures::CaptureError(fmt::format(
          "{}: --baud auto and --parity auto cannot tell a device server's settings, which its "
          "own port sets: give --baud and --parity as the server has them, or reach it as "
          "rfc2217:// where it takes RFC 2217",
          spec.path));
  const auto& base = options.analyzer.format;
  std::vector<FormatTrial> trials;
  std::vector<std::vector<ReadBytes>> reads;
  std::vector<ChannelInfo> channels;
  for (const auto& spec : specs) channels.push_back({spec.name, spec.role});
  for (const auto& format : candidate_formats(baud, parity, base.data_bits, base.stop_bits)) {
    if (stop) break;
    std::vector<std::unique_ptr<TapPort>> ports;
    for (const auto& spec : specs) ports.push_back(open_tap(spec.path, format));
    AnalyzerOptions analyzer = options.analyzer;
    analyzer.format = format;
    analyzer.clock = ClockQuality::per_chunk;
    const int64_t end = now_ns() + window_ns;
    std::vector<uint8_t> buffer(4096);
    size_t turn = 0;
    std::vector<ReadBytes>& kept = reads.emplace_back();
    auto next = [&](Chunk& chunk) {
      while (!stop && now_ns() < end) {
        std::vector<pollfd> fds;
        for (const auto& p : ports) fds.push_back({p->fd(), POLLIN, 0});
        poll(fds.data(), fds.size(), 50);
        for (size_t k = 0; k < ports.size(); ++k) {
          const size_t i = (turn + k) % ports.size();
          if (!(fds[i].revents & (POLLIN | POLLHUP | POLLERR))) continue;
          const size_t n = ports[i]->read(buffer);
          if (!n) continue;
          turn = i + 1;
          kept.push_back(
              {static_cast<uint16_t>(i), now_ns(), {buffer.begin(), buffer.begin() + n}});
          chunk = {kept.back().channel, kept.back().t_ns, kept.back().bytes};
          return true;
        }
      }
      return false;
    };
    trials.push_back(try_format(analyzer, channels, next, 64 * 1024));
    fmt::print(stderr, "modtap: listened as {}\n", describe(trials.back()));
    if (trials.back().convincing()) break;
  }
  if (trials.empty()) return {base, {}};
  const auto& best = best_trial(trials);
  if (best.good_frames == 0) {
    fmt::print(stderr, "modtap: no setting gave a frame with a good check; using {}\n",
               describe(base));
    return {base, {}};
  }
  fmt::print(stderr, "modtap: using {}\n", describe(best.format));
  return {best.format, std::move(reads[static_cast<size_t>(&best - trials.data())])};
}

int64_t wall_clock_ns() {
  return now_ns();
}

const std::atomic<bool>& stop_on_signals() {
  struct sigaction action {};
  action.sa_handler = on_signal;
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
  signal(SIGPIPE, SIG_IGN);
  return stop_requested;
}

void request_stop() {
  stop_requested = true;
}

int run_live(const std::vector<PortSpec>& specs, const LiveOptions& options, RecordSink& sink,
             const std::atomic<bool>& stop) {
  std::vector<std::unique_ptr<TapPort>> ports;
  std::vector<ChannelInfo> channels;
  for (const auto& spec : specs) {
    ports.push_back(open_tap(spec.path, options.analyzer.format));
    channels.push_back({spec.name, spec.role});
    if (options.announce)
      fmt::print(stderr, "modtap: listening on {} at {}, mode {} ({})\n", spec.path,
                 describe(options.analyzer.format), to_string(options.analyzer.mode),
                 ports.back()->clock_note());
  }
  AnalyzerOptions analyzer_options = options.analyzer;
  analyzer_options.clock = ClockQuality::per_chunk;
  Counting counting(sink);
  Analyzer bus(analyzer_options, channels, counting);

  // Wake often enough to print a frame within t3.5 plus a few milliseconds of its end.
  const int wake_ms =
      static_cast<int>(std::max<int64_t>(1, analyzer_options.format.t35_ns() / 1'000'000));
  auto take = [&](const Chunk& chunk) {
    if (options.on_read) options.on_read(chunk, bus.between_frames());
    bus.push(chunk);
  };
  for (const auto& read : options.replay) take({read.channel, read.t_ns, read.bytes});
  std::vector<uint8_t> buffer(4096);
  int status = 0;
  int64_t last_status = 0;
  uint64_t last_frames = 0;
  while (!stop) {
    std::vector<pollfd> fds;
    for (const auto& p : ports) fds.push_back({p->fd(), POLLIN, 0});
    poll(fds.data(), fds.size(), wake_ms);
    try {
      for (size_t i = 0; i < ports.size(); ++i) {
        if (!(fds[i].revents & (POLLIN | POLLHUP | POLLERR))) continue;
        const size_t n = ports[i]->read(buffer);
        if (n) take({static_cast<uint16_t>(i), now_ns(), {buffer.data(), n}});
        if (const auto notice = ports[i]->take_notice(); notice && options.announce)
          fmt::print(stderr, "modtap: {}: {}\n", specs[i].path, *notice);
      }
    } catch (const captures::CaptureError& e) {
      fmt::print(stderr, "modtap: {}\n", e.what());
      if (options.on_port_event) options.on_port_event(PortEvent::read_failed);
      if (!options.reconnect) {
        status = 1;
        break;
      }
      fmt::print(stderr, "modtap: waiting for the port to come back (--reconnect)\n");
      for (size_t i = 0; i < ports.size() && !stop; ++i) {
        while (!stop) {
          try {
            ports[i] = open_tap(specs[i].path, options.analyzer.format);
            fmt::print(stderr, "modtap: {} is back\n", specs[i].path);
            if (options.on_port_event) options.on_port_event(PortEvent::came_back);
            break;
          } catch (const captures::CaptureError&) {
            std::this_thread::sleep_for(std::chrono::seconds(1));
          }
        }
      }
      continue;
    }
    const int64_t now = now_ns();
    bus.flush(now);
    if (options.on_wake) options.on_wake(now);
    if (options.done && options.done(now)) break;
    if (options.status_line && now - last_status >= 1'000'000'000) {
      fmt::print(stderr, "\r{} frames/s  frames {}  bad checks {}  noise {}  time-outs {}   ",
                 counting.frames - last_frames, counting.frames, counting.errors, counting.noise,
                 counting.timeouts);
      last_status = now;
      last_frames = counting.frames;
    }
  }
  if (options.status_line) fmt::print(stderr, "\n");
  bus.finish();
  return status;
}

}  // namespace modtap::live
