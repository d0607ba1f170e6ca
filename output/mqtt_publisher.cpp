#include "output/mqtt_publisher.hpp"

#include <algorithm>
#include <ctime>

#include <fmt/chrono.h>

#include "decoder/models/device_model.hpp"
#include "output/render.hpp"
#include "output/statistics_output.hpp"

namespace modtap::output {

namespace {

constexpr int64_t second_ns = 1'000'000'000;

// ISO 8601 in UTC with milliseconds, as JavaScript and Home Assistant read it.
void append_time(fmt::memory_buffer& out, int64_t t_ns) {
  const int64_t ms = t_ns / 1'000'000;
  const std::time_t seconds = static_cast<std::time_t>(ms / 1000);
  fmt::format_to(fmt::appender(out), "\"{:%Y-%m-%dT%H:%M:%S}.{:03}Z\"", fmt::gmtime(seconds),
                 ms % 1000);
}

}  // namespace

std::string topic_level(std::string_view text) {
  std::string level(text);
  for (char& c : level)
    if (c == '/' || c == '+' || c == '#' || c == ' ' || c == '\0') c = '_';
  return level.empty() ? "_" : level;
}

MqttPublisher::MqttPublisher(MessageBroker& broker, const BusStatistics& statistics,
                             MqttOptions options, std::function<std::vector<Problem>()> problems)
    : broker_(broker),
      statistics_(statistics),
      options_(std::move(options)),
      problems_(std::move(problems)) {
  options_.prefix = topic_level(options_.prefix);
  options_.bus = topic_level(options_.bus);
}

std::string status_topic(const MqttOptions& options) {
  return fmt::format("{}/{}/status", topic_level(options.prefix), topic_level(options.bus));
}

void MqttPublisher::on_frame(const Frame& frame) {
  const Meaning* meaning = frame.meaning;
  if (states_values(frame)) {
    for (const RegisterValue& reg : meaning->registers)
      if (follows(options_.follow, reg))
        see({frame.slave(), reg.table, reg.address}, reg, meaning->model, frame.t_ns);
  }
  tick(frame.t_ns);
}

void MqttPublisher::see(const RegisterKey& key, const RegisterValue& reg, const DeviceModel* model,
                        int64_t t_ns) {
  Published* published = entry(key, reg, model);
  if (!published) return;
  const bool changed =
      !published->sent_ns || published->value.raw != reg.raw || published->value.text != reg.text;
  published->value.keep(reg, t_ns);
  if (!changed || published->held) return;
  if (!published->sent_ns || t_ns - *published->sent_ns >= options_.interval_ns) {
    send(key, *published, t_ns);
  } else {
    published->held = true;
    held_.emplace_back(*published->sent_ns + options_.interval_ns, key);
  }
}

MqttPublisher::Published* MqttPublisher::entry(const RegisterKey& key, const RegisterValue& reg,
                                               const DeviceModel* model) {
  if (auto found = registers_.find(key); found != registers_.end()) return &found->second;
  // As many registers as the statistics keep: random traffic touches every address.
  if (registers_.size() >= BusStatistics::kept_registers) {
    ++not_published_;
    return nullptr;
  }
  const std::string name = reg.name.empty()
                               ? fmt::format("{}_{}", to_string(key.table),
                                             RegisterNumber{key.table, key.address, options_.base})
                               : std::string(reg.name);
  Published& published = registers_[key];
  published.topic =
      fmt::format("{}/{}/{}/{}", options_.prefix, options_.bus, key.slave, topic_level(name));
  published.model = model;
  published.value.keep(reg, 0);
  announce(key, published);
  return &published;
}

void MqttPublisher::send(const RegisterKey& key, Published& published, int64_t now_ns) {
  payload_.clear();
  payload_.push_back('{');
  append_register_keys(payload_, published.value.as_register(key.table, key.address));
  fmt::format_to(fmt::appender(payload_), ",\"time\":");
  append_time(payload_, published.value.t_ns);
  payload_.push_back('}');
  publish(published.topic);
  published.sent_ns = now_ns;
  published.sent_raw = published.value.raw;
  published.sent_text = published.value.text;
  published.held = false;
}

// A value held back by the interval, unless it went back to what was sent.
void MqttPublisher::send_held(const RegisterKey& key, Published& published, int64_t now_ns) {
  if (!published.held) return;
  published.held = false;
  if (published.value.raw != published.sent_raw || published.value.text != published.sent_text)
    send(key, published, now_ns);
}

void MqttPublisher::tick(int64_t now_ns) {
  last_ns_ = std::max(last_ns_, now_ns);
  if (broker_.take_reconnected()) republish_everything();
  while (!held_.empty() && held_.front().first <= now_ns) {
    const RegisterKey key = held_.front().second;
    held_.pop_front();
    send_held(key, registers_.at(key), now_ns);
  }
  const int64_t health_interval = std::max(options_.interval_ns, second_ns);
  if (!health_sent_ns_ || now_ns - *health_sent_ns_ >= health_interval) send_health(now_ns);
}

void MqttPublisher::finish() {
  if (broker_.take_reconnected()) republish_everything();
  for (auto& [key, published] : registers_) send_held(key, published, last_ns_);
  held_.clear();
  send_health(last_ns_);
}

// What the statistics say, small enough for a dashboard to read every interval.
void MqttPublisher::send_health(int64_t now_ns) {
  const BusStatistics& s = statistics_;
  payload_.clear();
  auto out = fmt::appender(payload_);
  fmt::format_to(out, "{{\"time\":");
  append_time(payload_, now_ns);
  fmt::format_to(out,
                 ",\"frames\":{},\"requests\":{},\"responses\":{},\"timeouts\":{},"
                 "\"retries\":{},\"exceptions\":{},\"bad_checks\":{},\"noise_bytes\":{},"
                 "\"bus_load\":",
                 s.frames, s.requests, s.responses, s.timeouts, s.retries, s.exceptions,
                 s.bad_checks, s.noise_bytes);
  if (auto load = s.bus_load()) {
    fmt::format_to(out, "{:.4f}", *load);
  } else {
    fmt::format_to(out, "null");
  }
  fmt::format_to(out, ",\"slaves\":{{");
  const char* comma = "";
  s.for_each_slave([&](uint8_t address, const SlaveStatistics& slave) {
    const ExchangeCounts& c = slave.counts;
    fmt::format_to(out,
                   "{}\"{}\":{{\"requests\":{},\"responses\":{},\"timeouts\":{},\"retries\":{},"
                   "\"exceptions\":{},\"bad_checks\":{},\"last_seen\":",
                   comma, address, c.requests, c.responses, c.timeouts, c.retries, c.exceptions,
                   c.bad_checks);
    append_time(payload_, slave.last_frame_ns);
    payload_.push_back('}');
    comma = ",";
  });
  // What a dashboard shows first: the problems found so far, as --stats writes them.
  fmt::format_to(out, "}},\"problems\":");
  append_problems_json(payload_, problems_ ? problems_() : std::vector<Problem>{});
  payload_.push_back('}');
  publish(fmt::format("{}/{}/health", options_.prefix, options_.bus));
  health_sent_ns_ = now_ns;
}

// Home Assistant's MQTT discovery: a sensor per register, its state the register's topic, grouped
// in a device per slave, unavailable when modtap's status says offline.
void MqttPublisher::announce(const RegisterKey& key, const Published& published) {
  if (!options_.discovery_prefix) return;
  const std::string id =
      fmt::format("modtap_{}_{}_{}_{}_{}", options_.bus, key.slave, to_string(key.table),
                  key.address, topic_level(published.value.name));
  payload_.clear();
  auto out = fmt::appender(payload_);
  const std::string_view label =
      published.value.name.empty()
          ? std::string_view(published.topic).substr(published.topic.rfind('/') + 1)
          : std::string_view(published.value.name);
  fmt::format_to(out, "{{\"name\":");
  append_json_string(payload_, label);
  fmt::format_to(out, ",\"unique_id\":\"{}\",\"state_topic\":", id);
  append_json_string(payload_, published.topic);
  // An enum's or bits' meaning reads better than its number.
  fmt::format_to(out, ",\"value_template\":\"{{{{ value_json.{} }}}}\"",
                 published.value.text.empty() ? "value" : "text");
  if (!published.value.unit.empty()) {
    fmt::format_to(out, ",\"unit_of_measurement\":");
    append_json_string(payload_, published.value.unit);
  }
  fmt::format_to(out, ",\"availability_topic\":");
  append_json_string(payload_, status_topic(options_));
  const std::string model = published.model ? published.model->name : "generic";
  fmt::format_to(out, ",\"device\":{{\"identifiers\":[\"modtap_{}_{}\"],\"name\":", options_.bus,
                 key.slave);
  append_json_string(payload_, fmt::format("{} slave {} ({})", options_.bus, key.slave, model));
  fmt::format_to(out, ",\"model\":");
  append_json_string(payload_, model);
  fmt::format_to(out, "}}}}");
  publish(fmt::format("{}/sensor/{}/config", topic_level(*options_.discovery_prefix), id));
}

// After the broker came back (it may have restarted and forgotten what was retained).
void MqttPublisher::republish_everything() {
  for (auto& [key, published] : registers_) {
    announce(key, published);
    if (published.sent_ns) send(key, published, *published.sent_ns);
  }
  if (health_sent_ns_) send_health(*health_sent_ns_);
}

void MqttPublisher::publish(std::string_view topic) {
  broker_.publish(topic, std::string_view(payload_.data(), payload_.size()), true);
}

}  // namespace modtap::output
