// modtap: a passive Modbus RTU/ASCII analyzer. This file wires a capture, the analyzer and a
// sink together; the work happens in decoder/ and captures/.
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include "captures/open_capture.hpp"
#include "captures/pcapng_sink.hpp"
#include "captures/piped_input.hpp"
#include "captures/raw_recorder.hpp"
#include "decoder/analyzer.hpp"
#include "decoder/bus_diagnostics.hpp"
#include "decoder/bus_statistics.hpp"
#include "decoder/bus_timeline.hpp"
#include "decoder/display_filter.hpp"
#include "decoder/format_probe.hpp"
#include "tools/live/live_capture.hpp"
#include "tools/modtap/auto_format.hpp"
#include "tools/modtap/capture_conditions.hpp"
#include "tools/modtap/csv_sink.hpp"
#include "tools/modtap/json_sink.hpp"
#include "tools/modtap/metrics.hpp"
#include "tools/modtap/model_catalog.hpp"
#include "tools/modtap/mosquitto_broker.hpp"
#include "tools/modtap/mqtt_publisher.hpp"
#include "tools/modtap/output.hpp"
#include "tools/modtap/progress.hpp"
#include "tools/modtap/report.hpp"
#include "tools/modtap/statistics_output.hpp"
#include "tools/modtap/text_sink.hpp"

namespace {

using namespace modtap;

struct Options {
  std::string read_file;
  std::vector<std::string> interfaces;
  bool reconnect = false;
  std::string format = "auto";
  std::string mode = "auto";
  std::string output = "text";
  bool verbose = false;
  std::string baud = "19200";  // or "auto"
  std::string parity = "even";
  unsigned stop_bits = 1;
  unsigned data_bits = 8;
  double timeout_s = 1.0;
  bool timeout_given = false;  // --timeout wins over the models' own time-outs
  double ascii_timeout_s = 1.0;
  double jitter_ms = 20.0;
  std::string sigrok_channels;
  bool sigrok_invert = false;
  std::string write_file;
  std::string link = "user";
  int dlt = 147;
  std::vector<std::string> models;
  std::string models_dir;
  double probe_s = 2.0;
  std::string save_raw;
  std::string stats_file;
  std::string report_file;
  std::string time_format = "r";
  uint64_t max_frames = 0;  // 0: no limit
  bool quiet = false;
  std::string display_filter;
  std::string follow;
  std::string register_base = "hex";
  std::string metrics_address;
  std::string mqtt_url;
  double mqtt_interval_s = 10;
  std::string mqtt_bus;
  std::string mqtt_discovery;            // Home Assistant's discovery prefix; empty: no discovery
  std::vector<std::string> autostop;     // -a duration:S, filesize:KB, frames:N
  std::vector<std::string> ring_buffer;  // -b duration:S, filesize:KB, files:N
};

using tools::Autostop;

std::optional<uint32_t> fixed_baud(const Options& o) {
  if (o.baud == "auto") return std::nullopt;
  return static_cast<uint32_t>(std::stoul(o.baud));
}

std::optional<decoder::Parity> fixed_parity(const Options& o) {
  if (o.parity == "auto") return std::nullopt;
  return decoder::parity_named(o.parity);
}

std::unique_ptr<decoder::RecordSink> make_sink(const Options& o, tools::Output& out,
                                               const std::vector<decoder::ChannelInfo>& channels) {
  if (o.output == "json") return std::make_unique<tools::JsonSink>(out, channels);
  if (o.output == "csv")
    return std::make_unique<tools::CsvSink>(
        out, tools::parse_follow_or_all(o.follow, decoder::register_base_named(o.register_base)),
        tools::time_format_named(o.time_format), decoder::register_base_named(o.register_base));
  if (o.output == "text")
    return std::make_unique<tools::TextSink>(
        out, channels,
        tools::TextOptions{o.verbose, tools::time_format_named(o.time_format),
                           decoder::register_base_named(o.register_base)});
  return std::make_unique<decoder::NullSink>();  // stats: the statistics print at the end
}

decoder::SerialFormat serial_format(const Options& o) {
  return {fixed_baud(o).value_or(19200), static_cast<uint8_t>(o.data_bits),
          decoder::parity_named(o.parity), static_cast<uint8_t>(o.stop_bits)};
}

decoder::AnalyzerOptions analyzer_options(const Options& o, decoder::ClockQuality clock) {
  decoder::AnalyzerOptions analyzer;
  analyzer.mode = decoder::mode_named(o.mode);
  analyzer.format = serial_format(o);
  analyzer.clock = clock;
  analyzer.timeout_ns = static_cast<int64_t>(o.timeout_s * 1e9);
  analyzer.ascii_char_timeout_ns = static_cast<int64_t>(o.ascii_timeout_s * 1e9);
  analyzer.chunk_jitter_ns = static_cast<int64_t>(o.jitter_ms * 1e6);
  return analyzer;
}

tools::ModelCatalog load_models(const Options& o) {
  tools::ModelCatalog catalog;
  catalog.load_builtin();
  if (!o.models_dir.empty()) catalog.load_dir(o.models_dir);
  return catalog;
}

bool wants_statistics(const Options& o) {
  return o.output == "stats" || !o.stats_file.empty() || !o.report_file.empty() ||
         !o.metrics_address.empty() || !o.mqtt_url.empty();
}

// The report's registers over time: those --follow names, none without it.
std::function<bool(const decoder::RegisterValue&)> report_follow(const Options& o) {
  if (o.follow.empty()) return {};
  const auto base = decoder::register_base_named(o.register_base);
  return [follow = tools::parse_follow(o.follow, base)](const decoder::RegisterValue& reg) {
    return tools::follows(follow, reg);
  };
}

// The sinks a run writes to: the terminal's, the statistics, and a pcapng file with -w; in
// front of them, the stage that reads frames through the device models.
class Sinks {
 public:
  Sinks(const Options& o, const captures::RingLimits& ring, tools::Output& out,
        const std::vector<decoder::ChannelInfo>& channels, const decoder::SerialFormat& format,
        decoder::ClockQuality clock)
      : terminal_(make_sink(o, out, channels)) {
    fan_out_.add(*terminal_);
    if (wants_statistics(o)) {
      statistics_ = std::make_unique<decoder::BusStatistics>(format, clock);
      if (o.metrics_address.empty()) {
        fan_out_.add(*statistics_);
      } else {  // read by the metrics server's thread while records come in
        shared_statistics_ = std::make_unique<tools::SharedStatistics>(*statistics_);
        fan_out_.add(*shared_statistics_);
      }
    }
    if (!o.report_file.empty()) {
      timeline_ = std::make_unique<decoder::BusTimeline>(report_follow(o));
      fan_out_.add(*timeline_);
    }
    // Only text, JSON, CSV, MQTT, pcapng comments and statistics show what the models say;
    // the other outputs skip the work, and the YAML is not read unless models are asked for.
    // A filter may name registers, so it reads frames through the models too.
    const bool interpret = o.output == "text" || o.output == "json" || o.output == "csv" ||
                           wants_statistics(o) ||  // the registers' last values
                           (!o.write_file.empty() && o.link != "bare") || !o.display_filter.empty();
    if (interpret || !o.models.empty() || !o.models_dir.empty()) {
      catalog_ = load_models(o);
      auto choice = catalog_.choose(o.models);
      if (!o.timeout_given) model_timeouts_ = decoder::model_timeouts(choice);
      if (!o.display_filter.empty()) filter(o.display_filter, channels);
      decoder::RecordSink& after = filter_ ? static_cast<decoder::RecordSink&>(*filter_) : fan_out_;
      if (interpret)
        interpreter_ =
            std::make_unique<decoder::ModelInterpreter>(catalog_.all(), choice, clock, after);
    }
    diagnostics_ = std::make_unique<decoder::BusDiagnostics>(format, clock, after_diagnostics());
    if (o.write_file.empty()) return;
    captures::PcapngOptions options;
    options.link = captures::parse_link(o.link);
    options.dlt = o.dlt;
    options.clock = clock;
    pcapng_ = std::make_unique<captures::PcapngFiles>(o.write_file, ring, channels, options);
    fan_out_.add(*pcapng_);
  }
  // Where records enter: the frame limit, the bus's history, the model stage, the filter,
  // then every sink.
  decoder::RecordSink& all() {
    if (limit_) return *limit_;
    return *diagnostics_;
  }
  const decoder::BusDiagnostics& diagnostics() const { return *diagnostics_; }
  // -c N: stop after N frames; `on_reached` stops a live run.
  void limit_frames(uint64_t max_frames, std::function<void()> on_reached = {}) {
    if (max_frames == 0) return;
    decoder::RecordSink& next = all();
    limit_ = std::make_unique<decoder::FrameLimit>(max_frames, next, std::move(on_reached));
  }
  bool limit_reached() const { return limit_ && limit_->reached(); }
  // --mqtt: the register values and the statistics' summary, to `broker`.
  tools::MqttPublisher& publish(tools::MessageBroker& broker, tools::MqttOptions options) {
    mqtt_ = std::make_unique<tools::MqttPublisher>(broker, *statistics_, std::move(options));
    fan_out_.add(*mqtt_);
    return *mqtt_;
  }
  // How much the -w files hold so far (0 without -w).
  uint64_t pcapng_bytes() const { return pcapng_ ? pcapng_->bytes_written() : 0; }
  const decoder::BusStatistics* statistics() const { return statistics_.get(); }
  tools::SharedStatistics* shared_statistics() { return shared_statistics_.get(); }
  const decoder::BusTimeline* timeline() const { return timeline_.get(); }
  // The slaves whose model sets a response time-out, unless --timeout was given.
  const std::map<uint8_t, int64_t>& model_timeouts() const { return model_timeouts_; }
  // The end of a run: the pcapng file is complete, or its failure is reported.
  void close() {
    if (pcapng_) pcapng_->close();
  }

 private:
  decoder::RecordSink& after_diagnostics() {
    if (interpreter_) return *interpreter_;
    if (filter_) return *filter_;
    return fan_out_;
  }

  // -Y: every output (text, JSON, statistics, pcapng) sees only the records it matches.
  void filter(const std::string& text, const std::vector<decoder::ChannelInfo>& channels) {
    const auto models = catalog_.all();
    decoder::DisplayFilter filter(text, [models](std::string_view name) {
      return std::any_of(models.begin(), models.end(),
                         [&](const decoder::DeviceModel* m) { return names_register(*m, name); });
    });
    std::vector<std::string> names;
    for (const auto& channel : channels) names.push_back(channel.name);
    filter.set_channel_names(std::move(names));
    filter_ = std::make_unique<decoder::FilterStage>(std::move(filter), fan_out_);
  }

  decoder::FanOut fan_out_;
  std::unique_ptr<decoder::RecordSink> terminal_;
  std::unique_ptr<decoder::BusStatistics> statistics_;
  std::unique_ptr<tools::SharedStatistics> shared_statistics_;
  std::unique_ptr<decoder::BusTimeline> timeline_;
  tools::ModelCatalog catalog_;
  std::unique_ptr<decoder::FilterStage> filter_;
  std::unique_ptr<decoder::BusDiagnostics> diagnostics_;
  std::unique_ptr<decoder::ModelInterpreter> interpreter_;
  std::map<uint8_t, int64_t> model_timeouts_;
  std::unique_ptr<captures::PcapngFiles> pcapng_;
  std::unique_ptr<decoder::FrameLimit> limit_;
  std::unique_ptr<tools::MqttPublisher> mqtt_;
};

bool same_file(const std::string& a, const std::string& b) {
  namespace fs = std::filesystem;
  std::error_code error;
  if (fs::equivalent(a, b, error)) return true;
  return fs::weakly_canonical(a, error) == fs::weakly_canonical(b, error) && !error;
}

// Outputs that would destroy the input or each other, or mix two formats on one stream.
std::optional<std::string> refuse_outputs(const Options& o) {
  const std::vector<std::pair<const char*, std::string>> files{{"-w", o.write_file},
                                                               {"--save-raw", o.save_raw},
                                                               {"--stats", o.stats_file},
                                                               {"--report", o.report_file}};
  for (size_t i = 0; i < files.size(); ++i) {
    const auto& [option, path] = files[i];
    if (path.empty() || path == "-") continue;
    if (!o.read_file.empty() && o.read_file != "-" && same_file(path, o.read_file))
      return fmt::format("{} {} would overwrite the capture being read", option, path);
    for (size_t j = i + 1; j < files.size(); ++j)
      if (!files[j].second.empty() && same_file(path, files[j].second))
        return fmt::format("{} and {} both name {}", option, files[j].first, path);
  }
  const bool terminal_output =
      o.output == "text" || o.output == "json" || o.output == "stats" || o.output == "csv";
  std::vector<std::string> on_standard_output;
  for (const auto& [option, path] : files)
    if (path == "-") on_standard_output.push_back(std::string(option) + " -");
  if (terminal_output) on_standard_output.push_back("-T " + o.output);
  if (on_standard_output.size() > 1)
    return fmt::format("{} and {} would both write to standard output", on_standard_output[0],
                       on_standard_output[1]);
  return std::nullopt;
}

// -b turns files: it needs a file to turn, and standard output is none.
std::optional<std::string> refuse_ring(const Options& o, const captures::RingLimits& ring) {
  if (!ring.rotates()) return std::nullopt;
  if (o.write_file.empty() && o.save_raw.empty())
    return "-b turns the files of -w and --save-raw: give one of them";
  if (o.write_file == "-" || o.save_raw == "-")
    return "-b writes a ring of files; standard output is one stream: give a file name";
  return std::nullopt;
}

int list_models(const Options& o) {
  const tools::ModelCatalog catalog = load_models(o);
  for (const auto& entry : catalog.entries())
    fmt::print("{:<12} {:<40} {}\n", entry.model.name, entry.model.title, entry.origin);
  return 0;
}

void write_whole(const std::string& path, const fmt::memory_buffer& content) {
  captures::OutputFile file(path);
  file.write(std::string_view(content.data(), content.size()));
  file.close();
}

// The end of a run: -T stats prints the statistics, --stats and --report write them
// (`complete` false when the input broke off: they cover what was read).
void summarise(const Options& o, tools::Output& out, const Sinks& sinks, bool complete) {
  const decoder::BusStatistics* statistics = sinks.statistics();
  if (!statistics) return;
  const auto base = decoder::register_base_named(o.register_base);
  if (o.output == "stats") tools::print_statistics(out, *statistics, sinks.diagnostics(), base);
  if (!o.stats_file.empty()) {
    fmt::memory_buffer json;
    tools::append_statistics_json(json, *statistics, sinks.diagnostics(), complete);
    write_whole(o.stats_file, json);
  }
  if (!o.report_file.empty()) {
    fmt::memory_buffer html;
    const std::string capture = o.read_file.empty()
                                    ? fmt::format("{}", fmt::join(o.interfaces, " "))
                                : o.read_file == "-" ? "standard input"
                                                     : o.read_file;
    tools::append_report(html, *statistics, sinks.diagnostics(), *sinks.timeline(),
                         {capture, MODTAP_VERSION, complete, base});
    write_whole(o.report_file, html);
  }
}

// Whether the terminal is free for a status or progress line: standard error is one, and
// frame lines are not printed on that same terminal.
bool terminal_free_for_status(const Options& o) {
  const bool lines_on_stdout = o.output == "text" || o.output == "json" || o.output == "csv";
  return isatty(STDERR_FILENO) && (!lines_on_stdout || !isatty(STDOUT_FILENO));
}

// A bar for a file read straight through, on a terminal that has room for it.
std::unique_ptr<tools::ProgressBar> progress_bar(const Options& o,
                                                 const captures::ChunkSource& source, bool piped) {
  if (piped || !source.file_position() || !terminal_free_for_status(o)) return nullptr;
  std::error_code error;
  const auto size = std::filesystem::file_size(o.read_file, error);
  if (error) return nullptr;
  return std::make_unique<tools::ProgressBar>(stderr, size);
}

// -c N and -a frames:N: whichever stops first (0: no limit).
uint64_t frame_limit(const Options& o, const Autostop& autostop) {
  if (!autostop.frames) return o.max_frames;
  return o.max_frames ? std::min(o.max_frames, *autostop.frames) : *autostop.frames;
}

// What names the bus in MQTT topics unless --mqtt-bus does: the port's or the file's name.
std::string bus_name(const std::string& path) {
  if (path == "-") return "stdin";
  return std::filesystem::path(path).stem().string();
}

// --metrics: /metrics served from the statistics while the run goes on.
std::unique_ptr<tools::MetricsServer> serve_metrics(const Options& o, Sinks& sinks,
                                                    const tools::PortHealth& ports) {
  if (o.metrics_address.empty()) return nullptr;
  tools::SharedStatistics& shared = *sinks.shared_statistics();
  return std::make_unique<tools::MetricsServer>(o.metrics_address, [&shared, &ports] {
    fmt::memory_buffer text;
    shared.read([&](const decoder::BusStatistics& s) { tools::append_metrics(text, s, ports); });
    return fmt::to_string(text);
  });
}

std::unique_ptr<captures::RawRecorder> raw_recorder(
    const Options& o, const captures::RingLimits& ring,
    const std::vector<decoder::ChannelInfo>& channels, const decoder::SerialFormat& format) {
  if (o.save_raw.empty()) return nullptr;
  return std::make_unique<captures::RawRecorder>(o.save_raw, channels, format.char_time_ns(), ring);
}

// --mqtt: the publisher and its broker, connected. A file read waits for the broker and fails
// without it; a port goes on listening while the client keeps trying (a service may start
// before its broker).
class MqttOutput {
 public:
  MqttOutput(const Options& o, Sinks& sinks, const std::string& bus, bool live) {
    const tools::MqttUrl url = tools::parse_mqtt_url(o.mqtt_url);
    tools::MqttOptions options;
    options.prefix = url.prefix;
    options.bus = o.mqtt_bus.empty() ? bus : o.mqtt_bus;
    options.interval_ns = static_cast<int64_t>(o.mqtt_interval_s * 1e9);
    const auto base = decoder::register_base_named(o.register_base);
    options.follow = tools::parse_follow_or_all(o.follow, base);
    options.base = base;
    if (!o.mqtt_discovery.empty()) options.discovery_prefix = o.mqtt_discovery;
    broker_ = std::make_unique<tools::MosquittoBroker>(url, tools::status_topic(options));
    if (!broker_->wait_connected(live ? 3 : 10)) {
      const std::string why =
          fmt::format("{}: cannot connect: {}", broker_->name(), broker_->connect_error());
      if (!live) throw std::runtime_error(why);
      fmt::print(stderr, "modtap: {}; trying again while listening\n", why);
    }
    publisher_ = &sinks.publish(*broker_, std::move(options));
  }
  void tick(int64_t now_ns) { publisher_->tick(now_ns); }
  // The last values and summary, status offline, and what the broker missed.
  void finish() {
    publisher_->finish();
    broker_->close();
    if (broker_->dropped())
      fmt::print(stderr, "modtap: {}: {} messages not sent while the broker was away\n",
                 broker_->name(), broker_->dropped());
  }

 private:
  std::unique_ptr<tools::MosquittoBroker> broker_;
  tools::MqttPublisher* publisher_ = nullptr;
};

std::unique_ptr<MqttOutput> mqtt_output(const Options& o, Sinks& sinks, const std::string& bus,
                                        bool live) {
  if (o.mqtt_url.empty()) return nullptr;
  return std::make_unique<MqttOutput>(o, sinks, bus, live);
}

// After a run whose traffic made little sense, or came faster than the baud allows, say so.
void hint_settings(const decoder::SerialFormat& format, const decoder::LineHealth& health,
                   const decoder::ChunkPace& pace, bool logic_analyzer) {
  // A logic-analyzer capture that reads as nothing is usually a line inverted (RS-232 levels)
  // or probes swapped, which no baud rate mends.
  if (logic_analyzer && health.looks_wrong() && health.good_frames == 0) {
    fmt::print(stderr,
               "modtap: hint: no frame had a good check; is the line inverted (try "
               "--sigrok-invert), are the channels right (--sigrok-channels tx=NAME,rx=NAME), "
               "or are {} not the line's settings (try --baud auto)?\n",
               decoder::describe(format));
    return;
  }
  if (pace.too_fast())
    fmt::print(stderr,
               "modtap: hint: bytes arrive faster than {} allows ({} of {} reads); "
               "the line is faster: try --baud auto\n",
               decoder::describe(format), pace.fast_reads, pace.reads);
  else if (health.looks_wrong())
    fmt::print(stderr,
               "modtap: hint: only {:.0f}% of {} bytes formed frames with a good check; are {} "
               "the line's settings? try --baud auto\n",
               100 * health.good_share(), health.bytes, decoder::describe(format));
}

int read_file(const Options& o, const Autostop& autostop, const captures::RingLimits& ring) {
  captures::OpenOptions open;
  open.format = captures::parse_format(o.format);
  open.serial = serial_format(o);
  if (!o.sigrok_channels.empty())
    open.sigrok.lines = captures::parse_sigrok_channels(o.sigrok_channels);
  open.sigrok.invert = o.sigrok_invert;
  const bool piped = captures::is_piped(o.read_file);
  if (o.baud == "auto" || o.parity == "auto") {
    if (piped)
      throw std::runtime_error(fmt::format(
          "{}: --baud auto and --parity auto read a capture once per setting; a pipe can be "
          "read only once: give a file",
          o.read_file == "-" ? "standard input" : o.read_file));
    open.serial = tools::choose_file_format(o.read_file, open, analyzer_options(o, {}),
                                            fixed_baud(o), fixed_parity(o));
  }
  auto source = piped ? captures::open_piped_capture(o.read_file, open)
                      : captures::open_capture(o.read_file, open);

  captures::OutputFile standard_output(stdout, "standard output");
  tools::Output out(standard_output);
  Sinks sinks(o, ring, out, source->channels(), open.serial, source->clock());
  sinks.limit_frames(o.max_frames);
  decoder::LineHealth health(&sinks.all());
  decoder::AnalyzerOptions options = analyzer_options(o, source->clock());
  options.format = open.serial;
  options.slave_timeout_ns = sinks.model_timeouts();
  decoder::Analyzer bus(options, source->channels(), health);
  decoder::ChunkPace pace(open.serial);
  auto raw = raw_recorder(o, ring, source->channels(), open.serial);
  decoder::Chunk chunk;
  // A capture that breaks off (a truncated file) still gives everything read before the
  // break, in every output, and then the error.
  std::optional<captures::CaptureError> broken;
  auto progress = progress_bar(o, *source, piped);
  const tools::PortHealth no_ports;
  auto metrics = serve_metrics(o, sinks, no_ports);
  auto mqtt = mqtt_output(o, sinks, bus_name(o.read_file), false);
  try {
    std::optional<int64_t> first_ns;
    while (!sinks.limit_reached() && source->next(chunk)) {
      if (!first_ns) first_ns = chunk.t_ns;
      if (autostop.duration_ns && chunk.t_ns - *first_ns >= *autostop.duration_ns) break;
      if (autostop.filesize_bytes && sinks.pcapng_bytes() >= *autostop.filesize_bytes) break;
      if (progress) progress->update(*source->file_position());
      if (source->clock() == decoder::ClockQuality::per_chunk) pace.add(chunk);
      if (raw) raw->write(chunk, bus.between_frames());
      bus.push(chunk);
    }
  } catch (const captures::CaptureError& e) {
    broken = e;
  }
  progress.reset();  // wiped before anything else reaches the terminal
  bus.finish();
  metrics.reset();
  if (mqtt) mqtt->finish();
  summarise(o, out, sinks, !broken);
  out.flush();
  sinks.close();
  if (raw) raw->close();
  if (bus.clock_steps_back())
    fmt::print(stderr,
               "modtap: warning: {}: the time stamps go backwards {} times; latencies across "
               "those steps are not measured\n",
               o.read_file, bus.clock_steps_back());
  if (broken) throw *broken;
  // A pipe is not read again: it holds no logic-analyzer capture anyway.
  const captures::Format format = open.format != captures::Format::automatic ? open.format
                                  : piped                                    ? captures::Format::raw
                                          : captures::detect_format(o.read_file);
  hint_settings(open.serial, health, pace, format == captures::Format::sigrok);
  return 0;
}

int listen(const Options& o, const Autostop& autostop, const captures::RingLimits& ring) {
  std::vector<live::PortSpec> ports;
  std::vector<decoder::ChannelInfo> channels;
  for (const auto& spec : o.interfaces) {
    ports.push_back(live::parse_port(spec));
    channels.push_back({ports.back().name, ports.back().role});
  }
  const auto& stop = live::stop_on_signals();
  captures::OutputFile standard_output(stdout, "standard output");
  tools::Output out(standard_output);
  out.set_line_buffered(true);
  live::LiveOptions options;
  options.analyzer = analyzer_options(o, decoder::ClockQuality::per_chunk);
  if (o.baud == "auto" || o.parity == "auto") {
    auto probed = live::probe_ports(ports, options, fixed_baud(o), fixed_parity(o),
                                    static_cast<int64_t>(o.probe_s * 1e9), stop);
    options.analyzer.format = probed.format;
    options.replay = std::move(probed.read);  // the winning setting's bytes are analysed too
  }
  Sinks sinks(o, ring, out, channels, options.analyzer.format, decoder::ClockQuality::per_chunk);
  sinks.limit_frames(o.max_frames, live::request_stop);
  const int64_t started_ns = live::wall_clock_ns();
  options.done = [&](int64_t now_ns) {
    return (autostop.duration_ns && now_ns - started_ns >= *autostop.duration_ns) ||
           (autostop.filesize_bytes && sinks.pcapng_bytes() >= *autostop.filesize_bytes);
  };
  options.analyzer.slave_timeout_ns = sinks.model_timeouts();
  auto raw = raw_recorder(o, ring, channels, options.analyzer.format);
  if (raw)
    options.on_read = [&](const decoder::Chunk& chunk, bool between_frames) {
      raw->write(chunk, between_frames);
    };
  options.reconnect = o.reconnect;
  tools::PortHealth port_health;
  options.on_port_event = [&port_health](live::PortEvent event) {
    ++(event == live::PortEvent::read_failed ? port_health.read_errors : port_health.reconnects);
  };
  auto metrics = serve_metrics(o, sinks, port_health);
  auto mqtt = mqtt_output(o, sinks, bus_name(ports.front().path), true);
  if (mqtt) options.on_wake = [&](int64_t now_ns) { mqtt->tick(now_ns); };
  // A status line on the terminal, unless frame lines are printed on that same terminal.
  options.status_line = terminal_free_for_status(o);
  const int status = live::run_live(ports, options, sinks.all(), stop);
  metrics.reset();
  if (mqtt) mqtt->finish();
  summarise(o, out, sinks, true);  // Ctrl-C is how a live run ends
  out.flush();
  sinks.close();
  if (raw) raw->close();
  return status;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"modtap: a passive analyzer for Modbus RTU and ASCII on serial lines"};
  Options o;
  auto* read = app.add_option("-r,--read", o.read_file,
                              "Capture file to read; - for standard input or a pipe");
  std::string named_capture;
  app.add_option("capture", named_capture, "The capture file, as with -r")->excludes(read);
  auto* listen_on = app.add_option("-i,--interface", o.interfaces,
                                   "Serial port to listen on (read-only): PATH, or master=PATH and "
                                   "slave=PATH for a tap that splits the directions");
  read->excludes(listen_on);
  app.add_flag("--reconnect", o.reconnect, "Wait for an unplugged port to come back");
  app.add_option("--format", o.format, "Capture format")
      ->check(CLI::IsMember({"auto", "raw", "hexlog", "pcap", "pcapng", "sigrok"}));
  app.add_option("--mode", o.mode, "Transmission mode")
      ->check(CLI::IsMember({"auto", "rtu", "ascii"}));
  auto* output = app.add_option("-T,--output", o.output,
                                "Output: text, json (JSON Lines), stats, csv (register values "
                                "over time), none (default: text, or none with -w)")
                     ->check(CLI::IsMember({"text", "json", "stats", "csv", "none"}));
  app.add_option("--follow", o.follow,
                 "With -T csv (implied): the registers to follow, by name or address: "
                 "frequency_command,2503H");
  app.add_option("-w,--write", o.write_file, "Write every frame and noise record as pcapng");
  app.add_option("--save-raw", o.save_raw,
                 "Keep every read as it came, with its time, to read again with other settings: "
                 "FILE.pcapng, or a timed hex log for any other name");
  app.add_option("--stats", o.stats_file,
                 "Write the statistics as one JSON object at the end of the run (also after "
                 "Ctrl-C, and marked incomplete when the input breaks off)");
  app.add_option("--report", o.report_file,
                 "Write a report a customer can read (one HTML file with charts; with --follow, "
                 "those registers over time) at the end of the run, as --stats");
  app.add_option(
         "--register-base", o.register_base,
         "How text, CSV, statistics and the report number registers: hex (2502H, as the "
         "drives' manuals), 0 (0-based decimal, as on the wire), 1 (1-based, as mbpoll), "
         "4xxxx (Modicon: 40001 is holding register 0); --follow reads numbers the same way")
      ->check(CLI::IsMember({"hex", "0", "1", "4xxxx"}));
  app.add_option("--metrics", o.metrics_address,
                 "Serve bus-health metrics for Prometheus on http://ADDR:PORT/metrics while "
                 "running (ADDR:PORT, [IPV6]:PORT, or :PORT for every interface)");
  auto* mqtt = app.add_option(
      "--mqtt", o.mqtt_url,
      "Publish register values (retained, on change), a health summary and an "
      "online/offline status to an MQTT broker: mqtt://[USER[:PASS]@]HOST[:PORT]/PREFIX "
      "(docs/monitoring.md)");
  app.add_option("--mqtt-interval", o.mqtt_interval_s,
                 "Seconds: a register at most this often, the health summary this often "
                 "(at least 1 s); 0 sends every change at once (default 10)")
      ->check(CLI::NonNegativeNumber)
      ->needs(mqtt);
  app.add_option("--mqtt-bus", o.mqtt_bus,
                 "The topic level naming the bus (default: the port's or capture's name)")
      ->needs(mqtt);
  app.add_flag("--mqtt-discovery{homeassistant}", o.mqtt_discovery,
               "Announce each register to Home Assistant (--mqtt-discovery=PREFIX for another "
               "discovery prefix than homeassistant)")
      ->needs(mqtt);
  app.add_option("--link", o.link, "pcapng link: user (DLT_USER + modtap.lua), exported-pdu, bare")
      ->check(CLI::IsMember({"user", "exported-pdu", "bare"}));
  app.add_option("--dlt", o.dlt, "DLT_USER link type for --link user or bare")
      ->check(CLI::Range(147, 162));
  app.add_flag("-V,--verbose", o.verbose, "Print each frame's field tree");
  app.add_option("-t", o.time_format,
                 "Text time column: r (since the first record), a (local time of day), ad "
                 "(local date and time), d (since the record before)")
      ->check(CLI::IsMember({"r", "a", "ad", "d"}));
  app.add_option("-Y,--display-filter", o.display_filter,
                 "Only records that match, in every output: 'slave == 3 && fc == 6', "
                 "'latency_us > 50000', 'finding', 'register.name == \"fault\"' (docs/output.md)");
  app.add_option("-c", o.max_frames, "Stop after this many frames")->check(CLI::PositiveNumber);
  app.add_option("-a,--autostop", o.autostop,
                 "Stop after duration:SECONDS (capture time of a file, wall time on a port), "
                 "filesize:KB (the -w files), or frames:N; repeatable, the first reached wins");
  app.add_option("-b,--ring-buffer", o.ring_buffer,
                 "Write -w and --save-raw as a ring of files, named as dumpcap names them: a "
                 "new file after duration:SECONDS or filesize:KB, keeping the newest files:N");
  app.add_flag("-q,--quiet", o.quiet,
               "No line per frame: only what the run adds up to (-T stats, --stats)");
  app.set_version_flag("--version", std::string("modtap ") + MODTAP_VERSION);
  app.add_option("--baud", o.baud, "Baud rate, or auto to tell it from the traffic")
      ->check(CLI::IsMember({"auto"}) | CLI::Range(50u, 4'000'000u));
  app.add_option("--probe-time", o.probe_s,
                 "With --baud auto on a port: seconds to listen under each setting")
      ->check(CLI::PositiveNumber);
  app.add_option("--parity", o.parity, "Parity: none, even, odd, or auto")
      ->check(CLI::IsMember({"none", "even", "odd", "auto"}));
  app.add_option("--stop-bits", o.stop_bits, "Stop bits")->check(CLI::IsMember({1u, 2u}));
  app.add_option("--data-bits", o.data_bits, "Data bits")->check(CLI::IsMember({7u, 8u}));
  auto* timeout = app.add_option("--timeout", o.timeout_s,
                                 "Seconds of silence before a request times out (1, or what the "
                                 "slave's model says)")
                      ->check(CLI::PositiveNumber);
  app.add_option("--ascii-timeout", o.ascii_timeout_s, "ASCII inter-character time-out, seconds")
      ->check(CLI::PositiveNumber);
  app.add_option("--chunk-jitter", o.jitter_ms,
                 "For sources timed per read: milliseconds an adapter may hold bytes back")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--sigrok-channels", o.sigrok_channels,
                 "sigrok lines: tx=NAME,rx=NAME (the master's transmit and receive) or bus=NAME");
  app.add_flag("--sigrok-invert", o.sigrok_invert, "The sigrok lines have inverted levels");
  app.add_option("--model", o.models,
                 "Device model for the bus (MODEL) or one slave (SLAVE=MODEL); repeatable");
  app.add_option("--models-dir", o.models_dir, "A folder of the user's model files (*.yaml)");
  auto* models = app.add_subcommand("models", "List the device models, or check a model file");
  models->fallthrough();  // `modtap models --models-dir DIR` lists the user's models too
  std::string check_file;
  auto* check = models->add_subcommand("check", "Validate a model file");
  check->add_option("FILE", check_file, "Model file (YAML)")->required();
  CLI11_PARSE(app, argc, argv);
  signal(SIGPIPE, SIG_IGN);
  if (!named_capture.empty()) o.read_file = named_capture;
  o.timeout_given = timeout->count() > 0;  // a closed pipe is a failed write (EPIPE), handled below
  if (!o.write_file.empty() && output->count() == 0) o.output = "none";  // as tshark -w
  // --follow alone asks for the values over time: as CSV, or in the report.
  if (!o.follow.empty() && output->count() == 0) o.output = o.report_file.empty() ? "csv" : "text";
  if (o.quiet && o.output != "stats") o.output = "none";
  try {
    if (check->parsed()) return tools::check_model_file(check_file);
    if (models->parsed()) return list_models(o);
    if (o.interfaces.empty() && o.read_file.empty()) {
      fmt::print(stderr, "modtap: give a capture with -r FILE or a port with -i PORT\n");
      return 2;
    }
    if (o.interfaces.size() > 2) {
      fmt::print(stderr, "modtap: at most two ports (master=PATH slave=PATH)\n");
      return 2;
    }
    // The conditions' errors come before any work.
    const Autostop autostop = tools::parse_autostop(o.autostop);
    const captures::RingLimits ring = tools::parse_ring_buffer(o.ring_buffer);
    o.max_frames = frame_limit(o, autostop);
    if (autostop.filesize_bytes && o.write_file.empty()) {
      fmt::print(stderr, "modtap: -a filesize stops on the size of the -w file: give -w\n");
      return 2;
    }
    if (auto refusal = refuse_ring(o, ring)) {
      fmt::print(stderr, "modtap: {}\n", *refusal);
      return 2;
    }
    if (auto refusal = refuse_outputs(o)) {
      fmt::print(stderr, "modtap: {}\n", *refusal);
      return 2;
    }
    return o.interfaces.empty() ? read_file(o, autostop, ring) : listen(o, autostop, ring);
  } catch (const decoder::FilterError& e) {
    fmt::print(stderr, "modtap: -Y: {}\n", e.what());
    return 2;
  } catch (const captures::WriteError& e) {
    // The reader went away (`| head`): no message, but not success either, as with tshark.
    if (e.broken_pipe()) return 2;
    fmt::print(stderr, "modtap: cannot write {}\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fflush(stdout);
    fmt::print(stderr, "modtap: {}\n", e.what());
    return 2;
  }
}
