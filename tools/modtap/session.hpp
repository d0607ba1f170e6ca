// One run's outputs, the same whether the bytes come from a file or from ports: the pipeline of
// stages and sinks, the --save-raw recorder, the metrics server, MQTT, and the end of the run
// (the statistics and report written, MQTT's last messages, every file closed). read_capture
// and listen (run.hpp) only feed it.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "captures/file_ring.hpp"
#include "captures/output_file.hpp"
#include "captures/raw_recorder.hpp"
#include "decoder/protocol/records.hpp"
#include "decoder/protocol/serial_format.hpp"
#include "output/metrics.hpp"
#include "output/network/metrics_server.hpp"
#include "output/output.hpp"
#include "tools/modtap/pipeline.hpp"

namespace modtap::tools {

class MqttOutput;

// Where a session's bytes come from.
struct SessionSource {
  const std::vector<ChannelInfo>& channels;
  SerialFormat format;
  ClockQuality clock = ClockQuality::per_chunk;
  std::string path;   // the file or the first port: names the bus in MQTT topics
  bool live = false;  // ports: lines written as they come, MQTT retries a broker away
};

class Session {
 public:
  // `on_limit`: what stops the source when -c is reached (a live loop's stop).
  Session(const RunOptions& o, const captures::RingLimits& ring, const SessionSource& source,
          std::function<void()> on_limit = {});
  ~Session();

  // Where the analyzer's records go.
  RecordSink& records() { return pipeline_.all(); }
  const Pipeline& pipeline() const { return pipeline_; }
  Pipeline& pipeline() { return pipeline_; }
  output::ExplainSink* explain() const { return pipeline_.explain(); }
  bool limit_reached() const { return pipeline_.limit_reached(); }
  uint64_t pcapng_bytes() const { return pipeline_.pcapng_bytes(); }
  const SlaveTimeouts& slave_timeouts() const { return pipeline_.slave_timeouts(); }
  // The ports' troubles, counted by the live loop for the metrics.
  output::PortHealth& port_health() { return port_health_; }

  // A read as it came, for --save-raw.
  // What the records printed so far: a pipe's reader sees each read's lines before the next
  // read waits for its writer.
  void flush_output() { out_.flush(); }
  bool keeps_raw() const { return raw_ != nullptr; }
  void keep_raw(const Chunk& chunk, bool between_frames) { raw_->write(chunk, between_frames); }
  // Time passing on a quiet bus: MQTT's held values and summary.
  bool publishes() const { return mqtt_ != nullptr; }
  void tick(int64_t now_ns);

  // The end of the run; `complete` false when the input broke off; `stopped_by` the -a
  // condition met, if one was.
  void finish(bool complete, const std::string& stopped_by = {});

 private:
  const RunOptions& o_;
  captures::OutputFile standard_output_;
  output::Output out_;
  Pipeline pipeline_;
  std::unique_ptr<captures::RawRecorder> raw_;
  output::PortHealth port_health_;
  std::unique_ptr<output::MetricsServer> metrics_;
  std::unique_ptr<MqttOutput> mqtt_;
};

}  // namespace modtap::tools
