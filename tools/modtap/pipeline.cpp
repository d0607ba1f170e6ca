#include "tools/modtap/pipeline.hpp"

#include <algorithm>

#include "output/csv_sink.hpp"
#include "output/json_sink.hpp"
#include "output/render.hpp"
#include "output/text_sink.hpp"

namespace modtap::tools {

// What an output needs of the stages before it.
struct Needs {
  bool statistics = false;         // the statistics and the problems' evidence
  bool meanings = false;           // frames read through the device models
  bool unnamed_registers = false;  // with the registers no model names

  void add(const Needs& more) {
    statistics |= more.statistics;
    meanings |= more.meanings;
    unnamed_registers |= more.unnamed_registers;
  }
};

namespace {

std::unique_ptr<RecordSink> make_sink(const RunOptions& o, output::Output& out,
                                      const std::vector<ChannelInfo>& channels,
                                      const RecordClock& clock, ClockQuality quality) {
  const output::TimeFormat time_format = time_format_for(o, quality);
  if (o.output == OutputKind::json) return std::make_unique<output::JsonSink>(out, channels);
  const RecordClock* clock_before_filter = o.display_filter.empty() ? nullptr : &clock;
  if (o.output == OutputKind::csv)
    return std::make_unique<output::CsvSink>(out, o.follow, time_format, o.register_base,
                                             clock_before_filter);
  if (o.explain)
    return std::make_unique<output::ExplainSink>(
        out, channels, output::TextOptions{o.verbose, time_format, o.register_base, nullptr},
        *o.explain);
  if (o.output == OutputKind::text)
    return std::make_unique<output::TextSink>(
        out, channels,
        output::TextOptions{o.verbose, time_format, o.register_base, clock_before_filter});
  return std::make_unique<NullSink>();  // stats: the statistics print at the end
}

// Each output a run may ask for, and what it needs: the stages a run builds are those its
// outputs need, so a run that asks less does less (no model is read for -T none alone).
Needs needs_of(const RunOptions& o) {
  constexpr Needs statistics{true, true, true};  // last values, the report's registers
  const struct {
    bool asked;
    Needs needs;
  } outputs[] = {
      {o.output == OutputKind::text, {false, true, o.verbose}},  // -V lists every register
      {o.output == OutputKind::json, {false, true, true}},
      {o.output == OutputKind::csv, {false, true, true}},
      {o.output == OutputKind::stats, statistics},
      {!o.stats_file.empty(), statistics},
      {!o.report_file.empty(), statistics},
      {!o.metrics_address.empty(), statistics},
      {!o.mqtt_url.empty(), statistics},
      {o.top, statistics},
      // The pcapng comments carry the models' verdicts, but a bare file has no comments.
      {!o.write_file.empty() && o.link != output::PcapngLink::bare, {false, true, false}},
      {!o.display_filter.empty(), {false, true, true}},  // a filter may name any register
      {!o.follow.empty(), {false, false, true}},         // --follow may name an unnamed one
  };
  Needs needs;
  for (const auto& [asked, more] : outputs)
    if (asked) needs.add(more);
  return needs;
}

// The report's registers over time: those --follow names, none without it.
std::function<bool(const RegisterValue&)> report_follow(const RunOptions& o) {
  if (o.follow.empty()) return {};
  return [follow = o.follow](const RegisterValue& reg) { return output::follows(follow, reg); };
}

}  // namespace

output::TimeFormat time_format_for(const RunOptions& o, ClockQuality clock) {
  const bool absolute = o.time_format == output::TimeFormat::absolute ||
                        o.time_format == output::TimeFormat::absolute_date;
  return clock == ClockQuality::none && absolute ? output::TimeFormat::relative : o.time_format;
}

SerialFormat serial_format(const RunOptions& o) {
  SerialFormat format{o.baud.value_or(19200), 8, o.parity.value_or(Parity::even),
                      static_cast<uint8_t>(o.stop_bits)};
  if (!o.data_bits) return format.with_data_bits_of(o.mode == ModeChoice::ascii);
  format.data_bits = static_cast<uint8_t>(*o.data_bits);
  return format;
}

namespace {

// How late a clock per read may stamp a byte: the framer's silences, the matcher's retries and
// poll jitter all allow for it.
int64_t read_jitter_ns(const RunOptions& o) {
  return static_cast<int64_t>(o.jitter_ms * 1e6);
}

}  // namespace

AnalyzerOptions analyzer_options(const RunOptions& o, ClockQuality clock) {
  AnalyzerOptions analyzer;
  analyzer.mode = o.mode;
  analyzer.format = serial_format(o);
  analyzer.clock = clock;
  analyzer.timeout_ns = static_cast<int64_t>(o.timeout_s * 1e9);
  analyzer.timeout_told = o.timeout_given;
  analyzer.ascii_char_timeout_ns = static_cast<int64_t>(o.ascii_timeout_s * 1e9);
  analyzer.chunk_jitter_ns = read_jitter_ns(o);
  return analyzer;
}

ModelCatalog load_models(const RunOptions& o) {
  ModelCatalog catalog;
  catalog.load_builtin();
  if (!o.models_dir.empty()) catalog.load_dir(o.models_dir);
  for (const std::string& problem : catalog.left_out())
    fmt::print(stderr, "modtap: warning: {}; the file is left out of --models-dir\n", problem);
  return catalog;
}

Pipeline::Pipeline(const RunOptions& o, const captures::RingLimits& ring, output::Output& out,
                   const std::vector<ChannelInfo>& channels, const SerialFormat& format,
                   ClockQuality clock)
    : terminal_(make_sink(o, out, channels, clock_, clock)), pace_(format) {
  if (o.explain) explain_ = static_cast<output::ExplainSink*>(terminal_.get());
  if (o.output == OutputKind::csv) csv_ = static_cast<output::CsvSink*>(terminal_.get());
  fan_out_.add(*terminal_);
  if (o.discover) {
    discovery_ = std::make_unique<RegisterDiscovery>();
    fan_out_.add(*discovery_);
  }
  const Needs needs = needs_of(o);
  if (needs.statistics) add_health(o, channels, format, clock);
  if (!o.report_file.empty()) {
    timeline_ = std::make_unique<BusTimeline>(report_follow(o));
    fan_out_.add(*timeline_);
  }
  // The YAML is not read unless an output needs the models' meanings or models are named.
  ModelChoice choice;
  if (needs.meanings || !o.models.empty() || !o.models_dir.empty()) {
    catalog_ = load_models(o);
    choice = catalog_.choose(o.models);
    const auto models = catalog_.all();
    if (std::any_of(models.begin(), models.end(), [](auto* m) { return m->identification; }))
      may_identify_ = [named = choice.by_slave](uint8_t slave) { return !named.count(slave); };
    if (!o.timeout_given) slave_timeouts_ = modtap::model_timeouts(choice);
  }
  if (!o.write_file.empty()) write_pcapng(o, ring, channels, format, clock);
  entry_ = &stages(o, needs, choice, channels, format, clock);
}

// The statistics and the problems' evidence (the records problems cite before them, for the
// report), beside the outputs; under a lock where another thread reads them.
void Pipeline::add_health(const RunOptions& o, const std::vector<ChannelInfo>& channels,
                          const SerialFormat& format, ClockQuality clock) {
  statistics_ = std::make_unique<BusStatistics>(format, clock,
                                                !o.data_bits && o.mode == ModeChoice::automatic);
  statistics_->set_read_lag(read_jitter_ns(o));
  evidence_ = std::make_unique<ProblemEvidence>();
  problem_options_.timeout_ns = static_cast<int64_t>(o.timeout_s * 1e9);
  problem_options_.timeout_told = o.timeout_given;
  problem_options_.pace = &pace_;
  if (!o.report_file.empty()) {  // the report shows the lines of the records problems cite
    cited_ = std::make_unique<output::CitedRecords>(*evidence_, channels, o.register_base,
                                                    o.display_filter.empty() ? nullptr : &clock_);
    health_.add(*cited_);
  } else {
    health_.add(*evidence_);
  }
  health_.add(*statistics_);
  if (o.top) feed_top(o, channels, format, clock);
  if (o.metrics_address.empty() && !o.top) {
    fan_out_.add(health_);
  } else {  // read by the metrics server's or the screen's thread while records come in
    shared_statistics_ = std::make_unique<output::SharedStatistics>(health_);
    fan_out_.add(*shared_statistics_);
  }
}

// The stages every record passes, in the order it passes them, each present where the run
// needs it; then every output (fan_out_). The record limit goes in front of them later.
RecordSink& Pipeline::stages(const RunOptions& o, const Needs& needs, const ModelChoice& choice,
                             const std::vector<ChannelInfo>& channels, const SerialFormat& format,
                             ClockQuality clock) {
  const bool filtered = !o.display_filter.empty();
  return in_order(
      {
          [&](RecordSink& next) -> RecordSink& {  // the bus's history: its findings
            diagnostics_ = std::make_unique<BusDiagnostics>(format, clock, next, read_jitter_ns(o));
            return *diagnostics_;
          },
          [&](RecordSink& next) -> RecordSink& {  // frames read through the device models
            if (!needs.meanings) return next;
            interpreter_ = std::make_unique<ModelInterpreter>(
                catalog_.all(), choice, clock, next, needs.unnamed_registers,
                o.timeout_given ? nullptr : &slave_timeouts_);
            return *interpreter_;
          },
          [&](RecordSink& next) -> RecordSink& {  // which --follow registers some frame read
            if (!needs.meanings || o.follow.empty()) return next;
            follow_watch_ = std::make_unique<FollowWatch>(o.follow, next);
            return *follow_watch_;
          },
          // Every record's time, kept before the filter picks some: the time column counts
          // over the whole capture, as without the filter.
          [&](RecordSink& next) -> RecordSink& {
            if (!filtered) return next;
            clock_stage_ = std::make_unique<ClockStage>(clock_, next);
            return *clock_stage_;
          },
          [&](RecordSink& next) -> RecordSink& {  // -Y
            if (!filtered) return next;
            filter_ = std::make_unique<FilterStage>(
                compile_filter(o.display_filter, o.register_base, channels), next);
            return *filter_;
          },
      },
      fan_out_);
}

namespace {

output::PcapngOptions pcapng_options(const RunOptions& o, const SerialFormat& format,
                                     ClockQuality clock) {
  output::PcapngOptions options;
  options.link = o.link;
  options.dlt = o.dlt;
  options.clock = clock;
  options.char_ns = format.char_time_ns();
  // On a port, someone may read the file as it grows (Wireshark through the extcap's FIFO,
  // `-w -` into a pipe): each packet is flushed when it is written.
  options.live = !o.interfaces.empty();
  return options;
}

}  // namespace

void Pipeline::write_pcapng(const RunOptions& o, const captures::RingLimits& ring,
                            const std::vector<ChannelInfo>& channels, const SerialFormat& format,
                            ClockQuality clock) {
  pcapng_ = std::make_unique<output::PcapngFiles>(o.write_file, ring, channels,
                                                  pcapng_options(o, format, clock));
  fan_out_.add(*pcapng_);
}

// Beside the statistics, under their lock: the screen's thread reads both.
void Pipeline::feed_top(const RunOptions& o, const std::vector<ChannelInfo>& channels,
                        const SerialFormat& format, ClockQuality clock) {
  const output::TextOptions text{false, time_format_for(o, clock), o.register_base, nullptr};
  auto filter_for = [this, base = o.register_base, &channels](const std::string& text) {
    return compile_filter(text, base, channels);
  };
  top_feed_ =
      std::make_unique<top::TopFeed>(channels, text, pcapng_options(o, format, clock), filter_for);
  health_.add(*top_feed_);
}

void Pipeline::hold_rows_until_identified() {
  if (csv_ && may_identify_) csv_->hold_until_identified(may_identify_);
}

void Pipeline::on_read(const Chunk& chunk) {
  if (!shared_statistics_) return pace_.add(chunk);
  shared_statistics_->read([&] { pace_.add(chunk); });  // --metrics reads the pace meanwhile
}

std::vector<Problem> Pipeline::problems() const {
  if (!statistics_) return {};
  return find_problems(*statistics_, *evidence_, problem_options_);
}

void Pipeline::limit_records(uint64_t max_records, std::function<void()> on_reached) {
  if (max_records == 0) return;
  RecordSink& next = all();
  limit_ = std::make_unique<RecordLimit>(max_records, next, std::move(on_reached));
}

output::MqttPublisher& Pipeline::publish(output::MessageBroker& broker,
                                         output::MqttOptions options) {
  mqtt_ = std::make_unique<output::MqttPublisher>(broker, *statistics_, std::move(options),
                                                  [this] { return problems(); });
  fan_out_.add(*mqtt_);
  return *mqtt_;
}

// Each stage built in front of the ones after it, from the last: `stages` in flow order.
RecordSink& Pipeline::in_order(std::initializer_list<StageBuilder> stages, RecordSink& last) {
  RecordSink* next = &last;
  for (auto stage = std::rbegin(stages); stage != std::rend(stages); ++stage)
    next = &(*stage)(*next);
  return *next;
}

FollowWatch::FollowWatch(const std::vector<output::FollowedRegister>& follow, RecordSink& next)
    : next_(next) {
  for (const output::FollowedRegister& item : follow) unseen_.push_back({item});
}

void FollowWatch::on_frame(const Frame& frame) {
  if (frame.meaning && !unseen_.empty())
    for (const RegisterValue& reg : frame.meaning->registers)
      std::erase_if(unseen_, [&](const auto& item) { return output::follows(item, reg); });
  next_.on_frame(frame);
}

std::vector<std::string> FollowWatch::unseen() const {
  std::vector<std::string> names;
  for (const auto& item : unseen_) names.push_back(item.front().name);
  return names;
}

// -Y: every output (text, JSON, statistics, pcapng) sees only the records it matches.
DisplayFilter Pipeline::compile_filter(const std::string& text, RegisterBase base,
                                       const std::vector<ChannelInfo>& channels) const {
  const auto models = catalog_.all();
  const auto is_register_name = [models](std::string_view name) {
    return std::any_of(models.begin(), models.end(),
                       [&](const DeviceModel* m) { return names_register(*m, name); });
  };
  DisplayFilter filter(text, is_register_name, base);
  std::vector<std::string> names;
  for (const auto& channel : channels) names.push_back(channel.name);
  filter.set_channel_names(std::move(names));
  return filter;
}

}  // namespace modtap::tools
