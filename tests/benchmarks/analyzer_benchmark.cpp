// Framing, checking and matching throughput on back-to-back simulated RTU traffic and on junk;
// the outputs (text, JSON, CSV, statistics, pcapng) on the same traffic, with the allocations
// they make. Each stage on its own is in stage_benchmark.cpp.
#include <benchmark/benchmark.h>

#include <atomic>
#include <cstdlib>
#include <new>

#include "decoder/analysis/bus_statistics.hpp"
#include "decoder/models/model_interpreter.hpp"
#include "decoder/protocol/analyzer.hpp"
#include "output/csv_sink.hpp"
#include "output/json_sink.hpp"
#include "output/pcapng_sink.hpp"
#include "output/text_sink.hpp"
#include "tools/busgen/bus_simulator.hpp"
#include "tools/modtap/model_catalog.hpp"

// Every allocation of the process is counted, so a benchmark can say how many a frame costs.
namespace {
std::atomic<uint64_t> allocations{0};
}  // namespace

// Not inlined: GCC would then see free() on memory from operator new, or operator delete on
// memory from malloc(), and warn of a mismatch (-Wmismatched-new-delete) where these
// replacements pair them on purpose.
[[gnu::noinline]] void* operator new(size_t size) {
  allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size ? size : 1)) return p;
  throw std::bad_alloc();
}
[[gnu::noinline]] void operator delete(void* p) noexcept {
  std::free(p);
}
[[gnu::noinline]] void operator delete(void* p, size_t) noexcept {
  std::free(p);
}

namespace {

using namespace modtap;

class Counting final : public RecordSink {
 public:
  void on_frame(const Frame&) override { ++frames; }
  void on_noise(const Noise&) override {}
  void on_timeout(const Timeout&) override {}
  uint64_t frames = 0;
};

const busgen::BusCapture& capture() {
  static const busgen::BusCapture c = [] {
    busgen::BusOptions o;
    o.transactions = 200'000;
    o.back_to_back = true;
    o.exception_rate = o.no_response_rate = o.broadcast_rate = 0;
    return busgen::simulate(o);
  }();
  return c;
}

// Frames the whole capture, untimed, in 64 KiB chunks, into `sink`.
void analyze(RecordSink& sink) {
  const auto& c = capture();
  AnalyzerOptions o;
  o.mode = ModeChoice::rtu;
  o.clock = ClockQuality::none;
  Analyzer analyzer(o, {{"bench", ChannelRole::bus}}, sink);
  for (size_t at = 0; at < c.bytes.size(); at += 65536)
    analyzer.push({0, 0, {c.bytes.data() + at, std::min<size_t>(65536, c.bytes.size() - at)}});
  analyzer.finish();
}

void BM_AnalyzeUntimed(benchmark::State& state) {
  uint64_t frames = 0;
  for (auto _ : state) {
    Counting sink;
    analyze(sink);
    frames += sink.frames;
  }
  state.counters["frames/s"] =
      benchmark::Counter(static_cast<double>(frames), benchmark::Counter::kIsRate);
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * capture().bytes.size()));
}
BENCHMARK(BM_AnalyzeUntimed)->Unit(benchmark::kMillisecond);

// The same, with every frame read through a device model (the stage text and JSON output use).
void BM_AnalyzeWithModel(benchmark::State& state, const char* model) {
  tools::ModelCatalog catalog;
  catalog.load_builtin();
  uint64_t frames = 0;
  for (auto _ : state) {
    Counting sink;
    ModelInterpreter interpreter(catalog.all(), catalog.choose({model}), ClockQuality::none, sink);
    analyze(interpreter);
    frames += sink.frames;
  }
  state.counters["frames/s"] =
      benchmark::Counter(static_cast<double>(frames), benchmark::Counter::kIsRate);
}
BENCHMARK_CAPTURE(BM_AnalyzeWithModel, generic, "generic")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_AnalyzeWithModel, gd20, "gd20")->Unit(benchmark::kMillisecond);

// What a user sees: the model stage and a sink, as `modtap -T text|json` and `-w` run them,
// writing to /dev/null. "allocs/frame" counts every allocation made while the capture ran.
enum class Sink { text, json, csv, stats, pcapng };

void BM_Output(benchmark::State& state, Sink kind, const char* model) {
  tools::ModelCatalog catalog;
  catalog.load_builtin();
  const std::vector<ChannelInfo> channels{{"bench", ChannelRole::bus}};
  capture();  // simulated once, before anything is counted
  uint64_t frames = 0;
  uint64_t allocated = 0;
  for (auto _ : state) {
    captures::OutputFile file("/dev/null");
    output::Output out(file);
    captures::PcapngWriter writer("/dev/null");
    std::unique_ptr<RecordSink> sink;
    if (kind == Sink::text) sink = std::make_unique<output::TextSink>(out, channels);
    if (kind == Sink::json) sink = std::make_unique<output::JsonSink>(out, channels);
    if (kind == Sink::csv)  // every register read or written a row
      sink = std::make_unique<output::CsvSink>(out, std::vector<output::FollowedRegister>{},
                                               output::TimeFormat::relative);
    if (kind == Sink::stats)
      sink = std::make_unique<BusStatistics>(SerialFormat{}, ClockQuality::none);
    if (kind == Sink::pcapng)
      sink = std::make_unique<output::PcapngSink>(writer, channels, output::PcapngOptions{});
    ModelInterpreter interpreter(catalog.all(), catalog.choose({model}), ClockQuality::none, *sink);
    const uint64_t before = allocations.load();
    analyze(interpreter);
    allocated += allocations.load() - before;
    frames += capture().frames.size();  // clean back-to-back traffic: the framer finds each
  }
  state.counters["frames/s"] =
      benchmark::Counter(static_cast<double>(frames), benchmark::Counter::kIsRate);
  state.counters["allocs/frame"] = static_cast<double>(allocated) / static_cast<double>(frames);
}
BENCHMARK_CAPTURE(BM_Output, text, Sink::text, "generic")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Output, text_gd20, Sink::text, "gd20")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Output, json, Sink::json, "generic")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Output, csv, Sink::csv, "generic")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Output, stats, Sink::stats, "generic")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Output, pcapng, Sink::pcapng, "generic")->Unit(benchmark::kMillisecond);

// Random bytes, as a capture read with the wrong settings or a noisy line gives them: every
// byte starts a CRC search in RTU and nothing in ASCII, untimed, in 64 KiB chunks.
void BM_AnalyzeRandomBytes(benchmark::State& state, ModeChoice mode) {
  static const std::vector<uint8_t> bytes = [] {
    std::vector<uint8_t> b(4 << 20);
    uint32_t x = 1;
    for (uint8_t& byte : b) byte = static_cast<uint8_t>((x = x * 1664525 + 1013904223) >> 24);
    return b;
  }();
  for (auto _ : state) {
    Counting sink;
    AnalyzerOptions o;
    o.mode = mode;
    o.clock = ClockQuality::none;
    Analyzer analyzer(o, {{"bench", ChannelRole::bus}}, sink);
    for (size_t at = 0; at < bytes.size(); at += 65536)
      analyzer.push({0, 0, {bytes.data() + at, std::min<size_t>(65536, bytes.size() - at)}});
    analyzer.finish();
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * bytes.size()));
}
BENCHMARK_CAPTURE(BM_AnalyzeRandomBytes, rtu, ModeChoice::rtu)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_AnalyzeRandomBytes, ascii, ModeChoice::ascii)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
