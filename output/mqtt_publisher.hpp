// --mqtt: the register values a bus carries, as MQTT topics a dashboard or Home Assistant
// reads, without a second master on the bus. What is published, and when, is decided here;
// the broker behind `MessageBroker` (libmosquitto in use, a recorder in the tests) only sends.
//
//   PREFIX/BUS/status             online, or offline (retained; offline is also the last will)
//   PREFIX/BUS/SLAVE/NAME         {"addr","name","raw","value","unit","text","time"} (retained)
//   PREFIX/BUS/health             the bus-health summary and problems every interval (retained)
//   DISCOVERY/sensor/ID/config    Home Assistant discovery, once per register (retained)
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <string_view>

#include <fmt/format.h>

#include "decoder/analysis/bus_problems.hpp"
#include "decoder/analysis/bus_statistics.hpp"
#include "decoder/protocol/record_sink.hpp"
#include "decoder/protocol/register_numbering.hpp"
#include "output/csv_sink.hpp"

namespace modtap::output {

// Where messages go. A broker away takes nothing; when it is back, `take_reconnected` says so
// once, and every retained topic is published again, so the broker loses only what happened
// while it was away, never the bus's current state.
class MessageBroker {
 public:
  virtual ~MessageBroker() = default;
  virtual void publish(std::string_view topic, std::string_view payload, bool retain) = 0;
  virtual bool take_reconnected() = 0;
};

struct MqttOptions {
  std::string prefix = "modtap";
  std::string bus;  // the topic level that names the bus: a port's name, a capture's stem
  // A register is published when its value changes, at most once per interval (the latest
  // value goes out when the interval is over); the health summary every interval, at least
  // 1 s. 0: every change at once.
  int64_t interval_ns = 10'000'000'000;
  std::vector<FollowedRegister> follow;  // empty: every register read or written
  RegisterBase base = RegisterBase::hex;
  std::optional<std::string> discovery_prefix;  // Home Assistant's, "homeassistant"
};

// A topic level from any text: MQTT's wildcards and separators ('+', '#', '/') and spaces
// become '_'.
std::string topic_level(std::string_view text);
// PREFIX/BUS/status: online, offline, and the broker's last will.
std::string status_topic(const MqttOptions& options);

class MqttPublisher final : public RecordSink {
 public:
  // `statistics` gives the health summary; it is a sink of the same pipeline, fed first.
  // `problems` gives the problems found so far (none when empty).
  MqttPublisher(MessageBroker& broker, const BusStatistics& statistics, MqttOptions options,
                std::function<std::vector<Problem>()> problems = {});

  void on_frame(const Frame& frame) override;
  void on_noise(const Noise& noise) override { tick(noise.t_ns); }
  void on_timeout(const Timeout& timeout) override { tick(timeout.t_ns); }

  // Time passing without records (a live bus gone quiet): held values and the summary.
  void tick(int64_t now_ns);
  // The end of the run: every held value and a last summary, then status offline.
  void finish();

  uint64_t registers_not_published() const { return not_published_; }

 private:
  struct Published {
    std::string topic;
    const DeviceModel* model = nullptr;
    LastValue value;  // the latest the bus carried
    std::optional<int64_t> sent_ns;
    uint64_t sent_raw = 0;  // what was sent then
    std::string sent_text;
    bool held = false;  // changed since it was last sent
  };

  void see(const RegisterKey& key, const RegisterValue& reg, const DeviceModel* model,
           int64_t t_ns);
  Published* entry(const RegisterKey& key, const RegisterValue& reg, const DeviceModel* model);
  void send(const RegisterKey& key, Published& published, int64_t now_ns);
  void send_held(const RegisterKey& key, Published& published, int64_t now_ns);
  void send_health(int64_t now_ns);
  void announce(const RegisterKey& key, const Published& published);
  void republish_everything();
  void publish(std::string_view topic);  // payload_, retained

  MessageBroker& broker_;
  const BusStatistics& statistics_;
  MqttOptions options_;
  std::function<std::vector<Problem>()> problems_;
  std::map<RegisterKey, Published> registers_;
  std::deque<std::pair<int64_t, RegisterKey>> held_;  // (due, register), due ascending
  std::optional<int64_t> health_sent_ns_;
  int64_t last_ns_ = 0;
  uint64_t not_published_ = 0;  // values of registers beyond BusStatistics::kept_registers
  fmt::memory_buffer payload_;
};

}  // namespace modtap::output
