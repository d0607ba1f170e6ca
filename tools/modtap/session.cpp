#include "tools/modtap/session.hpp"

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include <fmt/format.h>

#include "captures/piped_input.hpp"
#include "output/model_draft.hpp"
#include "output/mqtt_publisher.hpp"
#include "output/network/mosquitto_broker.hpp"
#include "output/report.hpp"
#include "output/statistics_output.hpp"

namespace modtap::tools {
namespace {

void write_whole(const std::string& path, const fmt::memory_buffer& content) {
  captures::OutputFile file(path);
  file.write(std::string_view(content.data(), content.size()));
  file.close();
}

// The end of a run: -T stats prints the statistics, --stats and --report write them
// (`complete` false when the input broke off: they cover what was read).
// modtap discover: the drafts, to files or summarised; a capture with no register reads says so.
void write_discovery(const RunOptions& o, output::Output& out, const RegisterDiscovery& found) {
  if (!found.saw_register_reads()) {
    fmt::print(stderr,
               "modtap discover: no register values (no good answer that reads or writes holding "
               "or input registers): nothing to draft\n");
    return;
  }
  if (found.registers_not_followed())
    fmt::print(stderr, "modtap discover: {} values of registers past the first {} not followed\n",
               found.registers_not_followed(), RegisterDiscovery::max_registers);
  const std::vector<SlaveDraft> drafts = found.drafts();
  if (o.discover_out.empty())
    return output::write_discovery_summary(out, drafts, found.polling_program());
  for (const std::string& path : output::write_model_drafts(o.discover_out, drafts))
    fmt::print(stderr, "modtap discover: wrote {}\n", path);
  fmt::print(stderr, "modtap discover: read with them: modtap -r CAPTURE --models-dir {}{}\n",
             o.discover_out, [&] {
               std::string models;
               for (const SlaveDraft& d : drafts)
                 models += fmt::format(" --model {}=slave-{}", d.slave, d.slave);
               return models;
             }());
}

void summarise(const RunOptions& o, output::Output& out, const Pipeline& pipeline, bool complete) {
  if (pipeline.discovery()) write_discovery(o, out, *pipeline.discovery());
  const BusStatistics* statistics = pipeline.statistics();
  if (!statistics) return;
  const auto base = o.register_base;
  const auto problems = pipeline.problems();
  if (o.output == OutputKind::stats) output::print_statistics(out, *statistics, problems, base);
  if (!o.stats_file.empty()) {
    fmt::memory_buffer json;
    output::append_statistics_json(json, *statistics, problems, complete);
    write_whole(o.stats_file, json);
  }
  if (!o.report_file.empty()) {
    fmt::memory_buffer html;
    const std::string capture = o.read_file.empty()
                                    ? fmt::format("{}", fmt::join(o.interfaces, " "))
                                : o.read_file == "-" ? "standard input"
                                                     : o.read_file;
    output::append_report(html, *statistics, *pipeline.timeline(), problems,
                          pipeline.cited_records()->lines(),
                          {capture, MODTAP_VERSION, complete, base, pipeline.unseen_follow()});
    write_whole(o.report_file, html);
  }
}

// What -w wrote, as dumpcap says it: a run to a file otherwise ends in silence.
void say_written(const RunOptions& o, const Pipeline& pipeline) {
  if (o.write_file.empty() || o.write_file == "-") return;
  const uint64_t files = pipeline.pcapng_files();
  fmt::print(stderr, "modtap: wrote {} ({} bytes) to {}{}\n",
             output::counted(pipeline.pcapng_packets(), "packet", "packets"),
             pipeline.pcapng_bytes(), o.write_file,
             files > 1 ? fmt::format(", in {} files", files) : "");
}

// --follow items no frame carried: a mistyped address, or a register the master never touched.
void say_unseen(const Pipeline& pipeline) {
  for (const std::string& item : pipeline.unseen_follow())
    fmt::print(stderr, "modtap: --follow {}: no frame read or wrote it\n", item);
}

// What names the bus in MQTT topics unless --mqtt-bus does: the port's or the file's name.
std::string bus_name(const std::string& path) {
  if (path == "-") return "stdin";
  return std::filesystem::path(path).stem().string();
}

// --metrics: /metrics served from the statistics while the run goes on.
std::unique_ptr<output::MetricsServer> serve_metrics(const RunOptions& o, Pipeline& pipeline,
                                                     const output::PortHealth& ports) {
  if (o.metrics_address.empty()) return nullptr;
  output::SharedStatistics& shared = *pipeline.shared_statistics();
  auto render = [&shared, &pipeline, &ports] {
    fmt::memory_buffer text;
    shared.read([&] {
      output::append_metrics(text, MODTAP_VERSION, *pipeline.statistics(), pipeline.problems(),
                             ports);
    });
    return fmt::to_string(text);
  };
  output::WebConfig web;
  if (!o.metrics_web_config.empty()) web = output::read_web_config(o.metrics_web_config);
  return std::make_unique<output::MetricsServer>(o.metrics_address, render, std::move(web));
}

std::unique_ptr<captures::RawRecorder> raw_recorder(const RunOptions& o,
                                                    const captures::RingLimits& ring,
                                                    const std::vector<ChannelInfo>& channels) {
  if (o.save_raw.empty()) return nullptr;
  return std::make_unique<captures::RawRecorder>(o.save_raw, channels, ring);
}

// The MQTT password: from --mqtt-password-file or MODTAP_MQTT_PASSWORD, where `ps` and a
// unit file do not show it; one in the URL still works, with a warning.
std::string mqtt_password(const RunOptions& o, const output::MqttUrl& url) {
  if (!o.mqtt_password_file.empty()) {
    std::ifstream file(o.mqtt_password_file);
    std::string password;
    if (!file || !std::getline(file, password))
      throw std::runtime_error(fmt::format(
          "--mqtt-password-file {}: cannot read a password from it", o.mqtt_password_file));
    return password;
  }
  if (const char* password = std::getenv("MODTAP_MQTT_PASSWORD")) return password;
  if (!url.password.empty())
    fmt::print(stderr,
               "modtap: warning: the --mqtt URL holds a password, which every local user sees in "
               "the process list; give it with --mqtt-password-file or MODTAP_MQTT_PASSWORD\n");
  return url.password;
}

}  // namespace

// --mqtt: the publisher and its broker, connected. A file read waits for the broker and fails
// without it; a port goes on listening while the client keeps trying (a service may start
// before its broker).
class MqttOutput {
 public:
  MqttOutput(const RunOptions& o, Pipeline& pipeline, const std::string& bus, bool live) {
    output::MqttUrl url = output::parse_mqtt_url(o.mqtt_url);
    url.password = mqtt_password(o, url);
    output::MqttOptions options;
    options.prefix = url.prefix;
    options.bus = o.mqtt_bus.empty() ? bus : o.mqtt_bus;
    options.interval_ns = static_cast<int64_t>(o.mqtt_interval_s * 1e9);
    const auto base = o.register_base;
    options.follow = o.follow;
    options.base = base;
    if (!o.mqtt_discovery.empty()) options.discovery_prefix = o.mqtt_discovery;
    broker_ =
        std::make_unique<output::MosquittoBroker>(url, o.mqtt_tls, output::status_topic(options));
    if (!broker_->wait_connected(live ? 3 : 10)) {
      const std::string why =
          fmt::format("{}: cannot connect: {}", broker_->name(), broker_->connect_error());
      if (!live) throw std::runtime_error(why);
      fmt::print(stderr, "modtap: {}; trying again while listening\n", why);
    }
    publisher_ = &pipeline.publish(*broker_, std::move(options));
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
  std::unique_ptr<output::MosquittoBroker> broker_;
  output::MqttPublisher* publisher_ = nullptr;
};

Session::Session(const RunOptions& o, const captures::RingLimits& ring, const SessionSource& source,
                 std::function<void()> on_limit)
    : o_(o),
      standard_output_(stdout, "standard output"),
      out_(standard_output_),
      pipeline_(o, ring, out_, source.channels, source.format, source.clock) {
  out_.set_line_buffered(source.live);
  // A file read through gives no row to anyone waiting for it: rows may wait for a name.
  if (!source.live && !captures::is_piped(o.read_file)) pipeline_.hold_rows_until_identified();
  if (time_format_for(o, source.clock) != o.time_format)
    fmt::print(stderr,
               "modtap: warning: {} has no clock (raw bytes): the time column counts seconds "
               "from the first byte, the bytes laid end to end at the line's speed\n",
               source.path);
  pipeline_.limit_records(o.max_records, std::move(on_limit));
  raw_ = raw_recorder(o, ring, source.channels);
  metrics_ = serve_metrics(o, pipeline_, port_health_);
  if (!o.mqtt_url.empty())
    mqtt_ = std::make_unique<MqttOutput>(o, pipeline_, bus_name(source.path), source.live);
}

Session::~Session() = default;

void Session::tick(int64_t now_ns) {
  if (mqtt_) mqtt_->tick(now_ns);
}

void Session::finish(bool complete, const std::string& stopped_by) {
  pipeline_.end_of_records();
  metrics_.reset();
  if (mqtt_) mqtt_->finish();
  summarise(o_, out_, pipeline_, complete);
  out_.flush();
  say_unseen(pipeline_);
  pipeline_.close();
  if (raw_) raw_->close();
  if (!o_.announce) return;  // Wireshark reads standard error as errors
  if (!stopped_by.empty()) fmt::print(stderr, "modtap: stopped at -a {}\n", stopped_by);
  say_written(o_, pipeline_);
}

}  // namespace modtap::tools
