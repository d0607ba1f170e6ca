// modtap: a passive Modbus RTU/ASCII analyzer. This file wires a capture, the analyzer and a
// sink together; the work happens in decoder/ and captures/.
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include "captures/open_capture.hpp"
#include "captures/pcapng_sink.hpp"
#include "decoder/analyzer.hpp"
#include "tools/modtap/json_sink.hpp"
#include "tools/modtap/output.hpp"
#include "tools/modtap/stats_sink.hpp"
#include "tools/modtap/text_sink.hpp"

namespace {

using namespace modtap;

struct Options {
  std::string read_file;
  std::string format = "auto";
  std::string mode = "auto";
  std::string output = "text";
  bool verbose = false;
  uint32_t baud = 19200;
  std::string parity = "even";
  unsigned stop_bits = 1;
  unsigned data_bits = 8;
  double timeout_s = 1.0;
  double ascii_timeout_s = 1.0;
  double jitter_ms = 20.0;
  std::string sigrok_channels;
  bool sigrok_invert = false;
  std::string write_file;
  std::string link = "user";
  int dlt = 147;
};

// Hands every record to each of several sinks (the terminal and a pcapng file, say).
class FanOut final : public decoder::RecordSink {
 public:
  void add(decoder::RecordSink& sink) { sinks_.push_back(&sink); }
  void on_frame(const decoder::Frame& f) override {
    for (auto* s : sinks_) s->on_frame(f);
  }
  void on_noise(const decoder::Noise& n) override {
    for (auto* s : sinks_) s->on_noise(n);
  }
  void on_timeout(const decoder::Timeout& t) override {
    for (auto* s : sinks_) s->on_timeout(t);
  }

 private:
  std::vector<decoder::RecordSink*> sinks_;
};

decoder::Parity parse_parity(const std::string& s) {
  if (s == "none") return decoder::Parity::none;
  if (s == "odd") return decoder::Parity::odd;
  return decoder::Parity::even;
}

decoder::ModeChoice parse_mode(const std::string& s) {
  if (s == "rtu") return decoder::ModeChoice::rtu;
  if (s == "ascii") return decoder::ModeChoice::ascii;
  return decoder::ModeChoice::automatic;
}

std::unique_ptr<decoder::RecordSink> make_sink(const Options& o, tools::Output& out,
                                               const std::vector<decoder::ChannelInfo>& channels) {
  if (o.output == "json") return std::make_unique<tools::JsonSink>(out, channels);
  if (o.output == "text") return std::make_unique<tools::TextSink>(out, channels, o.verbose);
  if (o.output == "stats") return std::make_unique<tools::StatsSink>();
  return std::make_unique<tools::NullSink>();
}

int run(const Options& o) {
  captures::OpenOptions open;
  open.format = captures::parse_format(o.format);
  open.serial = {o.baud, static_cast<uint8_t>(o.data_bits), parse_parity(o.parity),
                 static_cast<uint8_t>(o.stop_bits)};
  if (!o.sigrok_channels.empty())
    open.sigrok.lines = captures::parse_sigrok_channels(o.sigrok_channels);
  open.sigrok.invert = o.sigrok_invert;
  auto source = captures::open_capture(o.read_file, open);

  decoder::AnalyzerOptions analyzer;
  analyzer.mode = parse_mode(o.mode);
  analyzer.format = open.serial;
  analyzer.clock = source->clock();
  analyzer.timeout_ns = static_cast<int64_t>(o.timeout_s * 1e9);
  analyzer.ascii_char_timeout_ns = static_cast<int64_t>(o.ascii_timeout_s * 1e9);
  analyzer.chunk_jitter_ns = static_cast<int64_t>(o.jitter_ms * 1e6);

  tools::Output out(stdout);
  auto sink = make_sink(o, out, source->channels());
  FanOut sinks;
  sinks.add(*sink);
  std::unique_ptr<captures::PcapngWriter> pcapng;
  std::unique_ptr<captures::PcapngSink> pcapng_sink;
  if (!o.write_file.empty()) {
    captures::PcapngOptions options;
    options.link = captures::parse_link(o.link);
    options.dlt = o.dlt;
    pcapng = std::make_unique<captures::PcapngWriter>(o.write_file);
    pcapng_sink = std::make_unique<captures::PcapngSink>(*pcapng, source->channels(), options);
    sinks.add(*pcapng_sink);
  }
  decoder::Analyzer bus(analyzer, source->channels(), sinks);
  decoder::Chunk chunk;
  while (source->next(chunk)) bus.push(chunk);
  bus.finish();
  if (auto* stats = dynamic_cast<tools::StatsSink*>(sink.get())) print_stats(out, stats->stats());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"modtap: a passive analyzer for Modbus RTU and ASCII on serial lines"};
  Options o;
  app.add_option("-r,--read", o.read_file, "Capture file to read")->required();
  app.add_option("--format", o.format, "Capture format")
      ->check(CLI::IsMember({"auto", "raw", "hexlog", "pcap", "pcapng", "sigrok"}));
  app.add_option("--mode", o.mode, "Transmission mode")
      ->check(CLI::IsMember({"auto", "rtu", "ascii"}));
  auto* output = app.add_option("-T,--output", o.output,
                                "Output: text, json (JSON Lines), stats, none (default: text, "
                                "or none with -w)")
                     ->check(CLI::IsMember({"text", "json", "stats", "none"}));
  app.add_option("-w,--write", o.write_file, "Write every frame and noise record as pcapng");
  app.add_option("--link", o.link, "pcapng link: user (DLT_USER + modtap.lua), exported-pdu, bare")
      ->check(CLI::IsMember({"user", "exported-pdu", "bare"}));
  app.add_option("--dlt", o.dlt, "DLT_USER link type for --link user or bare")
      ->check(CLI::Range(147, 162));
  app.add_flag("-V,--verbose", o.verbose, "Print each frame's field tree");
  app.add_option("--baud", o.baud, "Baud rate")->check(CLI::Range(50u, 4'000'000u));
  app.add_option("--parity", o.parity, "Parity")->check(CLI::IsMember({"none", "even", "odd"}));
  app.add_option("--stop-bits", o.stop_bits, "Stop bits")->check(CLI::IsMember({1u, 2u}));
  app.add_option("--data-bits", o.data_bits, "Data bits")->check(CLI::IsMember({7u, 8u}));
  app.add_option("--timeout", o.timeout_s, "Seconds of silence before a request times out")
      ->check(CLI::PositiveNumber);
  app.add_option("--ascii-timeout", o.ascii_timeout_s, "ASCII inter-character time-out, seconds")
      ->check(CLI::PositiveNumber);
  app.add_option("--chunk-jitter", o.jitter_ms,
                 "For sources timed per read: milliseconds an adapter may hold bytes back")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--sigrok-channels", o.sigrok_channels,
                 "sigrok lines: tx=NAME,rx=NAME (the master's transmit and receive) or bus=NAME");
  app.add_flag("--sigrok-invert", o.sigrok_invert, "The sigrok lines have inverted levels");
  CLI11_PARSE(app, argc, argv);
  if (!o.write_file.empty() && output->count() == 0) o.output = "none";  // as tshark -w
  try {
    return run(o);
  } catch (const std::exception& e) {
    std::fflush(stdout);
    fmt::print(stderr, "modtap: {}\n", e.what());
    return 2;
  }
}
