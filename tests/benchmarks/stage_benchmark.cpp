// Each stage of the analysis on its own: the checks per byte, the framers under each adapter's
// timing, the matcher, the model stage and the pcapng writer, each a frame (or byte) at a time.
// The whole pipeline and the outputs a user sees are in analyzer_benchmark.cpp.
#include <benchmark/benchmark.h>

#include <string>
#include <vector>

#include "captures/pcapng_writer.hpp"
#include "decoder/models/model_interpreter.hpp"
#include "decoder/protocol/ascii_framer.hpp"
#include "decoder/protocol/checksum.hpp"
#include "decoder/protocol/matcher.hpp"
#include "decoder/protocol/rtu_framer.hpp"
#include "tools/busgen/bus_simulator.hpp"
#include "tools/modtap/model_catalog.hpp"

namespace {

using namespace modtap;

// A master polling many slaves with every public function code, with the idle time, the
// exceptions, time-outs and broadcasts of a real bus, as the bus simulator makes it.
busgen::BusCapture simulated(Mode mode) {
  busgen::BusOptions o;
  o.transactions = 50'000;
  o.mode = mode;
  if (mode == Mode::ascii) o.format = {9600, 7, Parity::even, 1};
  return busgen::simulate(o);
}

const busgen::BusCapture& rtu_capture() {
  static const busgen::BusCapture c = simulated(Mode::rtu);
  return c;
}

const busgen::BusCapture& ascii_capture() {
  static const busgen::BusCapture c = simulated(Mode::ascii);
  return c;
}

void count_frames(benchmark::State& state, uint64_t frames) {
  state.counters["frames/s"] =
      benchmark::Counter(static_cast<double>(frames), benchmark::Counter::kIsRate);
}

// The checks over 64 KiB of the capture.
void BM_Crc16(benchmark::State& state) {
  const std::span<const uint8_t> bytes(rtu_capture().bytes.data(), 65536);
  for (auto _ : state) benchmark::DoNotOptimize(crc16(bytes));
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * bytes.size()));
}
BENCHMARK(BM_Crc16);

void BM_Lrc(benchmark::State& state) {
  const std::span<const uint8_t> bytes(rtu_capture().bytes.data(), 65536);
  for (auto _ : state) benchmark::DoNotOptimize(lrc(bytes));
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * bytes.size()));
}
BENCHMARK(BM_Lrc);

// A framer's sink that only counts; no request is ever pending, so the framer reads each frame
// by its structure alone, as it does before the matcher has seen a request.
class FrameCounter final : public FrameSink {
 public:
  void on_frame(Frame&) override { ++frames; }
  void on_noise(Noise&) override {}
  uint64_t frames = 0;
};

// The capture as an adapter hands it over: each byte with its time (a logic analyzer), what
// arrived every 16 ms (a USB adapter), or blocks with no time (a raw file).
std::vector<Chunk> chunks_of(const busgen::BusCapture& capture, busgen::Delivery delivery) {
  std::vector<Chunk> chunks;
  for (const auto& c : busgen::deliver(capture, delivery, 1))
    chunks.push_back({0, c.t_ns, {capture.bytes.data() + c.offset, c.size}});
  return chunks;
}

template <typename Framer, typename Options>
void run_framer(benchmark::State& state, const busgen::BusCapture& capture,
                busgen::Delivery delivery, Options options) {
  const std::vector<Chunk> chunks = chunks_of(capture, delivery);
  options.clock = busgen::clock_of(delivery);
  uint64_t frames = 0;
  for (auto _ : state) {
    FrameCounter sink;
    Framer framer(0, options, sink);
    for (const Chunk& chunk : chunks) framer.push(chunk);
    framer.finish();
    frames += sink.frames;
  }
  count_frames(state, frames);
  state.counters["chunks/frame"] =
      static_cast<double>(chunks.size()) / static_cast<double>(capture.frames.size());
}

void BM_RtuFramer(benchmark::State& state, busgen::Delivery delivery) {
  RtuFramerOptions options;
  options.format = busgen::BusOptions{}.format;
  run_framer<RtuFramer>(state, rtu_capture(), delivery, options);
}
BENCHMARK_CAPTURE(BM_RtuFramer, per_byte, busgen::Delivery::per_byte)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_RtuFramer, bursts_16ms, busgen::Delivery::bursts)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_RtuFramer, untimed, busgen::Delivery::untimed)->Unit(benchmark::kMillisecond);

void BM_AsciiFramer(benchmark::State& state, busgen::Delivery delivery) {
  run_framer<AsciiFramer>(state, ascii_capture(), delivery, AsciiFramerOptions{});
}
BENCHMARK_CAPTURE(BM_AsciiFramer, bursts_16ms, busgen::Delivery::bursts)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_AsciiFramer, untimed, busgen::Delivery::untimed)
    ->Unit(benchmark::kMillisecond);

// The frames of the capture as the framer hands them on (each byte timed), their bytes in the
// capture itself so that they outlive the framer.
class FrameCollector final : public FrameSink {
 public:
  explicit FrameCollector(const busgen::BusCapture& capture) : capture_(capture) {}
  void on_frame(Frame& frame) override {
    Frame kept = frame;
    kept.index = frames.size() + 1;
    kept.raw = kept.adu = {capture_.bytes.data() + frame.offset, frame.raw.size()};
    frames.push_back(kept);
  }
  void on_noise(Noise&) override {}
  std::vector<Frame> frames;

 private:
  const busgen::BusCapture& capture_;
};

std::vector<Frame> framed(const busgen::BusCapture& capture) {
  FrameCollector collector(capture);
  RtuFramerOptions options;
  options.clock = ClockQuality::per_byte;
  RtuFramer framer(0, options, collector);
  for (const Chunk& chunk : chunks_of(capture, busgen::Delivery::per_byte)) framer.push(chunk);
  framer.finish();
  return std::move(collector.frames);
}

// The same frames with the roles, pairs and latencies the matcher gives them.
std::vector<Frame> matched(const busgen::BusCapture& capture) {
  std::vector<Frame> frames = framed(capture);
  MatcherOptions options;
  options.t35_ns = busgen::BusOptions{}.format.t35_ns();
  Matcher matcher(options, [](const Timeout&) {});
  for (Frame& frame : frames) {
    matcher.advance(frame.t_ns);
    matcher.on_frame(frame, ChannelRole::bus);
    if (frame.request) frame.request_pdu = frames[*frame.request - 1].pdu();
  }
  return frames;
}

void BM_Matcher(benchmark::State& state) {
  const std::vector<Frame> frames = framed(rtu_capture());
  MatcherOptions options;
  options.t35_ns = busgen::BusOptions{}.format.t35_ns();
  uint64_t matched = 0, timeouts = 0;
  for (auto _ : state) {
    Matcher matcher(options, [&](const Timeout&) { ++timeouts; });
    for (Frame frame : frames) {
      matcher.advance(frame.t_ns);
      matcher.on_frame(frame, ChannelRole::bus);
      matched += frame.request.has_value();
    }
    matcher.finish(frames.back().end_ns);
  }
  count_frames(state, state.iterations() * frames.size());
  // What it found, to see that it worked: the responses paired, the requests that timed out.
  const auto per_frame = [&](uint64_t n) {
    return static_cast<double>(n) / static_cast<double>(state.iterations() * frames.size());
  };
  state.counters["paired/frame"] = per_frame(matched);
  state.counters["timeouts/frame"] = per_frame(timeouts);
}
BENCHMARK(BM_Matcher)->Unit(benchmark::kMillisecond);

class Counting final : public RecordSink {
 public:
  void on_frame(const Frame& frame) override {
    registers += frame.meaning ? frame.meaning->registers.size() : 0;
  }
  void on_noise(const Noise&) override {}
  void on_timeout(const Timeout&) override {}
  uint64_t registers = 0;
};

// Every frame read through a device model: the generic one, and GD20's names, scaling, rules
// and group parameters.
void BM_ModelStage(benchmark::State& state, const char* model) {
  tools::ModelCatalog catalog;
  catalog.load_builtin();
  const std::vector<Frame> frames = matched(rtu_capture());
  Counting sink;
  ModelInterpreter interpreter(catalog.all(), catalog.choose({model}), ClockQuality::per_byte,
                               sink);
  for (auto _ : state)
    for (const Frame& frame : frames) interpreter.on_frame(frame);
  count_frames(state, state.iterations() * frames.size());
  benchmark::DoNotOptimize(sink.registers);
}
BENCHMARK_CAPTURE(BM_ModelStage, generic, "generic")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_ModelStage, gd20, "gd20")->Unit(benchmark::kMillisecond);

// Packet blocks with a comment of the usual length, to /dev/null; every request held until the
// next frame, as the pcapng sink holds a request until its answer.
void BM_PcapngWriter(benchmark::State& state) {
  const std::vector<Frame> frames = matched(rtu_capture());
  const std::string comment =
      "modtap index=6 mode=rtu role=response check=ok duration_ns=6302076 "
      "function=\"Read Holding Registers\" request=5 latency_us=2120.520 model=generic";
  for (auto _ : state) {
    captures::PcapngWriter writer("/dev/null");
    const uint32_t bus = writer.add_interface(147, "bench");
    for (const Frame& frame : frames) {
      if (frame.request) writer.release(*frame.request);
      const bool request = frame.role == Role::request;
      writer.write_packet(
          bus, frame.t_ns, frame.raw,
          request ? captures::PacketDirection::outbound : captures::PacketDirection::inbound,
          comment, request ? frame.index : 0);
    }
    writer.close();
  }
  count_frames(state, state.iterations() * frames.size());
}
BENCHMARK(BM_PcapngWriter)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
