// One way from a source to the outputs, for modtap and for modtap-extcap alike: the options a
// run takes and the chain of stages and sinks they build (docs/architecture.md). Wireshark's
// capture through the extcap is modtap's own `-i PORT -w FIFO` run.
#pragma once

#include <cstdint>
#include <functional>
#include <initializer_list>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "captures/file_ring.hpp"
#include "captures/open_capture.hpp"
#include "decoder/analysis/bus_diagnostics.hpp"
#include "decoder/analysis/bus_problems.hpp"
#include "decoder/analysis/bus_statistics.hpp"
#include "decoder/analysis/bus_timeline.hpp"
#include "decoder/analysis/register_discovery.hpp"
#include "decoder/filter/display_filter.hpp"
#include "decoder/models/model_interpreter.hpp"
#include "decoder/protocol/analyzer.hpp"
#include "decoder/protocol/record_sink.hpp"
#include "output/cited_records.hpp"
#include "output/csv_sink.hpp"
#include "output/explain_sink.hpp"
#include "output/metrics.hpp"
#include "output/mqtt_publisher.hpp"
#include "output/network/mosquitto_broker.hpp"
#include "output/output.hpp"
#include "output/pcapng_sink.hpp"
#include "output/text_sink.hpp"
#include "tools/modtap/model_catalog.hpp"
#include "tools/top/top_feed.hpp"

namespace modtap::tools {

// What prints a line per record on standard output, or nothing (-T).
enum class OutputKind : uint8_t { text, json, stats, csv, none };

// Whether the output prints records (or the statistics) on standard output.
constexpr bool prints_to_terminal(OutputKind output) {
  return output != OutputKind::none;
}

// Everything a run is given: modtap's command line, or the extcap's translation of
// Wireshark's, parsed once into the values the run compares.
struct RunOptions {
  std::string read_file;
  std::vector<std::string> interfaces;
  bool reconnect = false;
  captures::Format format = captures::Format::automatic;
  ModeChoice mode = ModeChoice::automatic;
  OutputKind output = OutputKind::text;
  bool verbose = false;
  std::optional<uint64_t> explain;       // --explain INDEX: that record, and why it was cut there
  std::optional<uint32_t> baud = 19200;  // none: --baud auto
  std::optional<Parity> parity = Parity::even;  // none: --parity auto
  unsigned stop_bits = 1;
  std::optional<unsigned> data_bits;  // none: the mode's (RTU 8, ASCII 7)
  double timeout_s = 1.0;
  bool timeout_given = false;  // --timeout wins over the models' own time-outs
  double ascii_timeout_s = 1.0;
  double jitter_ms = default_read_jitter_ns / 1e6;
  std::string sigrok_channels;
  bool sigrok_invert = false;
  std::string write_file;
  output::PcapngLink link = output::PcapngLink::user;
  int dlt = 147;
  std::vector<std::string> models;
  std::string models_dir;
  double probe_s = 2.0;
  std::string save_raw;
  std::string stats_file;
  std::string report_file;
  output::TimeFormat time_format = output::TimeFormat::relative;
  uint64_t max_records = 0;  // -c: frames and noise; 0: no limit
  bool quiet = false;
  std::string display_filter;
  std::string follow_list;  // --follow as given
  // --follow parsed, once the register base is known: none follows every register.
  std::vector<output::FollowedRegister> follow;
  RegisterBase register_base = RegisterBase::hex;
  std::string metrics_address;
  std::string metrics_web_config;  // HTTPS and users, in the Prometheus exporter toolkit's format
  std::string mqtt_url;
  double mqtt_interval_s = 10;
  std::string mqtt_bus;
  std::string mqtt_discovery;            // Home Assistant's discovery prefix; empty: no discovery
  output::MqttTls mqtt_tls;              // mqtts://: --mqtt-ca, --mqtt-cert, --mqtt-key
  std::string mqtt_password_file;        // the password, kept off the command line
  std::vector<std::string> autostop;     // -a duration:S, filesize:KB, frames:N
  std::vector<std::string> ring_buffer;  // -b duration:S, filesize:KB, files:N
  // modtap top: the live view instead of lines; a file replayed at `top_speed` times its pace.
  bool top = false;
  double top_speed = 1;
  // modtap discover: each slave's registers drafted from their values; to files in this folder
  // (DIR/slave-N.yaml), or summarised on standard output where empty.
  bool discover = false;
  std::string discover_out;
  // Say on standard error which port is listened to, and keep a status line there (not to
  // Wireshark: it reads anything there as an error).
  bool announce = true;
};

SerialFormat serial_format(const RunOptions& o);
// The time column's format: -t a and ad count from the first record on a capture without a
// clock (raw bytes), which has no time of day to show.
output::TimeFormat time_format_for(const RunOptions& o, ClockQuality clock);
AnalyzerOptions analyzer_options(const RunOptions& o, ClockQuality clock);
ModelCatalog load_models(const RunOptions& o);

// --follow: which followed registers some frame read or wrote, so that the end of the run can
// name those none did (a mistyped address, a register the master never touches).
class FollowWatch final : public RecordSink {
 public:
  FollowWatch(const std::vector<output::FollowedRegister>& follow, RecordSink& next);
  void on_frame(const Frame& frame) override;
  void on_noise(const Noise& noise) override { next_.on_noise(noise); }
  void on_timeout(const Timeout& timeout) override { next_.on_timeout(timeout); }
  std::vector<std::string> unseen() const;  // as --follow wrote them

 private:
  std::vector<std::vector<output::FollowedRegister>>
      unseen_;  // one item each, as follows() takes them
  RecordSink& next_;
};

struct Needs;  // what the outputs a run asks for need of the stages before them

// The stages and sinks a run writes to: in front, the record limit, the bus's history, the
// stage that reads frames through the device models, the --follow watch, the clock of every
// record and the filter; then the terminal's output, the statistics, the report's timeline,
// MQTT and the pcapng files of -w.
class Pipeline {
 public:
  Pipeline(const RunOptions& o, const captures::RingLimits& ring, output::Output& out,
           const std::vector<ChannelInfo>& channels, const SerialFormat& format,
           ClockQuality clock);
  // Where records enter.
  RecordSink& all() {
    if (limit_) return *limit_;
    return *entry_;
  }
  // -c N: stop after N frames and noise records; `on_reached` stops a live run.
  void limit_records(uint64_t max_records, std::function<void()> on_reached = {});
  bool limit_reached() const { return limit_ && limit_->reached(); }
  // --mqtt: the register values and the statistics' summary, to `broker`.
  output::MqttPublisher& publish(output::MessageBroker& broker, output::MqttOptions options);
  // How much the -w files hold so far (0 without -w).
  uint64_t pcapng_bytes() const { return pcapng_ ? pcapng_->bytes_written() : 0; }
  uint64_t pcapng_packets() const { return pcapng_ ? pcapng_->packets() : 0; }
  // --explain: the sink that prints the record, told the framer's readings.
  output::ExplainSink* explain() const { return explain_; }
  uint64_t pcapng_files() const { return pcapng_ ? pcapng_->files_begun() : 0; }
  const BusStatistics* statistics() const { return statistics_.get(); }
  const ProblemEvidence* evidence() const { return evidence_.get(); }
  // modtap top's records, read under shared_statistics()'s lock.
  top::TopFeed* top_feed() { return top_feed_.get(); }
  // A read from the source, before its bytes are framed: its pace says whether the line is
  // faster than the settings modtap was given. Only for sources with a clock (per read, per byte).
  void on_read(const Chunk& chunk);
  const ChunkPace& pace() const { return pace_; }
  // Settings found to read the capture where the given ones did not: the settings' problem
  // names them.
  void found_better_settings(const BetterSettings& better) { problem_options_.better = better; }
  // The problems the statistics and the evidence beside them show (none without statistics).
  // With --metrics, call it under shared_statistics()'s lock.
  std::vector<Problem> problems() const;
  // With --report: the lines of the records the problems cite.
  const output::CitedRecords* cited_records() const { return cited_.get(); }
  output::SharedStatistics* shared_statistics() { return shared_statistics_.get(); }
  const BusTimeline* timeline() const { return timeline_.get(); }
  const RegisterDiscovery* discovery() const { return discovery_.get(); }
  // The --follow items no frame read or wrote, so far.
  std::vector<std::string> unseen_follow() const {
    return follow_watch_ ? follow_watch_->unseen() : std::vector<std::string>{};
  }
  // The slaves whose model sets a response time-out, unless --timeout was given.
  // The slaves' own time-outs, as their models give them, for the analyzer: the model stage
  // adds a slave's as it identifies itself.
  const SlaveTimeouts& slave_timeouts() const { return slave_timeouts_; }
  // -T csv on a file: the rows of a slave that may identify itself wait until it does
  // (CsvSink::hold_until_identified).
  void hold_rows_until_identified();
  // The records are all in: the rows still held are written.
  void end_of_records() {
    if (csv_) csv_->finish();
  }
  // The end of a run: the pcapng file is complete, or its failure is reported.
  void close() {
    if (pcapng_) pcapng_->close();
  }

 private:
  void add_health(const RunOptions& o, const std::vector<ChannelInfo>& channels,
                  const SerialFormat& format, ClockQuality clock);
  RecordSink& stages(const RunOptions& o, const Needs& needs, const ModelChoice& choice,
                     const std::vector<ChannelInfo>& channels, const SerialFormat& format,
                     ClockQuality clock);
  // A stage of the chain: built in front of `next`, the stages after it, or absent (`next`).
  using StageBuilder = std::function<RecordSink&(RecordSink& next)>;
  static RecordSink& in_order(std::initializer_list<StageBuilder> stages, RecordSink& last);
  DisplayFilter compile_filter(const std::string& text, RegisterBase base,
                               const std::vector<ChannelInfo>& channels) const;
  void feed_top(const RunOptions& o, const std::vector<ChannelInfo>& channels,
                const SerialFormat& format, ClockQuality clock);
  void write_pcapng(const RunOptions& o, const captures::RingLimits& ring,
                    const std::vector<ChannelInfo>& channels, const SerialFormat& format,
                    ClockQuality clock);

  RecordClock clock_;  // of every record, before the filter: the text's time column
  FanOut fan_out_;
  std::unique_ptr<RecordSink> terminal_;
  output::ExplainSink* explain_ = nullptr;  // terminal_, with --explain
  output::CsvSink* csv_ = nullptr;          // terminal_, with -T csv
  // Whether a slave may identify itself as a model: no --model names it, and a loaded model
  // has an identification rule. Empty where none may.
  std::function<bool(uint8_t)> may_identify_;
  std::unique_ptr<BusStatistics> statistics_;
  std::unique_ptr<ProblemEvidence> evidence_;
  std::unique_ptr<output::CitedRecords> cited_;  // in front of the evidence, with --report
  FanOut health_;                                // the evidence, then the statistics
  ProblemOptions problem_options_;
  ChunkPace pace_;  // of the reads: a line faster than its settings (problem_options_.pace)
  std::unique_ptr<output::SharedStatistics> shared_statistics_;
  std::unique_ptr<BusTimeline> timeline_;
  ModelCatalog catalog_;
  std::unique_ptr<FilterStage> filter_;
  std::unique_ptr<ClockStage> clock_stage_;
  std::unique_ptr<FollowWatch> follow_watch_;
  std::unique_ptr<BusDiagnostics> diagnostics_;
  std::unique_ptr<ModelInterpreter> interpreter_;
  SlaveTimeouts slave_timeouts_{};
  std::unique_ptr<output::PcapngFiles> pcapng_;
  RecordSink* entry_ = nullptr;  // the first stage of the chain
  std::unique_ptr<RecordLimit> limit_;
  std::unique_ptr<output::MqttPublisher> mqtt_;
  std::unique_ptr<top::TopFeed> top_feed_;
  std::unique_ptr<RegisterDiscovery> discovery_;
};

}  // namespace modtap::tools

template <>
struct modtap::EnumNames<modtap::tools::OutputKind> {
  static constexpr std::array<std::string_view, 5> names{"text", "json", "stats", "csv", "none"};
};
