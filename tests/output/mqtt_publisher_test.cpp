// What --mqtt publishes and when, with a broker that records: the real broker's part is
// tested against mosquitto by tests/tools/mqtt_publish.py.
#include "output/mqtt_publisher.hpp"

#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "output/network/mosquitto_broker.hpp"

namespace modtap::output {
namespace {
using ::testing::ElementsAre;
using ::testing::HasSubstr;

constexpr int64_t second = 1'000'000'000;

struct Message {
  std::string topic, payload;
};

class RecordingBroker final : public MessageBroker {
 public:
  void publish(std::string_view topic, std::string_view payload, bool retain) override {
    EXPECT_TRUE(retain) << topic;
    messages.push_back({std::string(topic), std::string(payload)});
  }
  bool take_reconnected() override { return std::exchange(reconnected, false); }

  // The payloads published on `topic`.
  std::vector<std::string> on(const std::string& topic) const {
    std::vector<std::string> payloads;
    for (const auto& m : messages)
      if (m.topic == topic) payloads.push_back(m.payload);
    return payloads;
  }
  // The "raw" of each payload on `topic`.
  std::vector<int> raws(const std::string& topic) const {
    std::vector<int> values;
    for (const auto& payload : on(topic)) {
      const auto at = payload.find("\"raw\":") + 6;
      values.push_back(std::stoi(payload.substr(at)));
    }
    return values;
  }

  std::vector<Message> messages;
  bool reconnected = false;
};

// A response of slave 1 that read `reg`, at second `t`.
class Bus {
 public:
  Bus(RecordingBroker& broker, MqttOptions options)
      : statistics_({}, ClockQuality::per_chunk),
        publisher_(broker, statistics_, std::move(options),
                   [this] { return find_problems(statistics_, evidence_); }) {}

  void read(RegisterValue reg, double t_s, uint8_t slave = 1) {
    see(reg, t_s, slave, Role::response);
  }
  // A write request carrying `reg`: what the master asks, not yet what the device holds.
  void ask(RegisterValue reg, double t_s, uint8_t slave = 1) {
    see(reg, t_s, slave, Role::request);
  }
  void see(RegisterValue reg, double t_s, uint8_t slave, Role role) {
    Meaning meaning;
    meaning.registers.push_back(reg);
    const uint8_t adu[] = {slave, 3, 2, 0, 0, 0, 0};
    Frame frame;
    frame.role = role;
    frame.adu = adu;
    frame.raw = adu;
    frame.check_ok = true;
    frame.t_ns = static_cast<int64_t>(t_s * second);
    frame.end_ns = frame.t_ns + 1000;
    frame.meaning = &meaning;
    statistics_.on_frame(frame);
    evidence_.on_frame(frame);
    publisher_.on_frame(frame);
  }
  // A read of slave `slave` that no answer follows.
  void ask_in_vain(double t_s, uint8_t slave) {
    const uint8_t adu[] = {slave, 3, 0, 0, 0, 1, 0, 0};
    Frame frame;
    frame.index = ++index_;
    frame.role = Role::request;
    frame.adu = adu;
    frame.raw = adu;
    frame.check_ok = true;
    frame.t_ns = static_cast<int64_t>(t_s * second);
    frame.end_ns = frame.t_ns + 1000;
    statistics_.on_frame(frame);
    evidence_.on_frame(frame);
    publisher_.on_frame(frame);
    Timeout timeout;
    timeout.request = frame.index;
    timeout.slave = slave;
    timeout.function = 3;
    timeout.t_ns = frame.end_ns + second / 2;
    timeout.waited_ns = second / 2;
    timeout.reason = TimeoutReason::silence;
    statistics_.on_timeout(timeout);
    evidence_.on_timeout(timeout);
    publisher_.on_timeout(timeout);
  }
  MqttPublisher& publisher() { return publisher_; }

 private:
  BusStatistics statistics_;
  ProblemEvidence evidence_;
  MqttPublisher publisher_;
  uint64_t index_ = 0;
};

RegisterValue frequency(uint32_t raw) {
  RegisterValue reg;
  reg.address = 0x2524;
  reg.name = "output_frequency";
  reg.unit = "Hz";
  reg.raw = raw;
  reg.value = raw * 0.01;
  reg.decimals = 2;
  return reg;
}

MqttOptions options(double interval_s) {
  MqttOptions o;
  o.prefix = "plant";
  o.bus = "line 3";
  o.interval_ns = static_cast<int64_t>(interval_s * second);
  return o;
}

const std::string topic = "plant/line_3/1/output_frequency";

TEST(MqttPublisher, PublishesEachChangeWithTheModelsNameUnitAndScaledValue) {
  RecordingBroker broker;
  Bus bus(broker, options(0));
  bus.read(frequency(6000), 1.0);
  bus.read(frequency(6000), 1.1);  // unchanged: the retained message holds it
  bus.read(frequency(5000), 1.2);
  EXPECT_THAT(broker.raws(topic), ElementsAre(6000, 5000));
  EXPECT_EQ(broker.on(topic)[0],
            "{\"addr\":9508,\"name\":\"output_frequency\",\"raw\":6000,\"value\":60.00,"
            "\"unit\":\"Hz\",\"text\":null,\"time\":\"1970-01-01T00:00:01.000Z\"}");
}

// A write's request is published only once the device's answer confirms it: a refused or
// unanswered write leaves no retained topic behind.
TEST(MqttPublisher, AWriteRequestIsNoValue) {
  RecordingBroker broker;
  Bus bus(broker, options(0));
  bus.ask(frequency(6000), 1.0);
  EXPECT_TRUE(broker.on(topic).empty());
  bus.read(frequency(5000), 1.1);
  EXPECT_THAT(broker.raws(topic), ElementsAre(5000));
}

// A broadcast write (slave 0) is a request no device answers: no topic, and no Home Assistant
// device for a slave 0 that does not exist.
TEST(MqttPublisher, ABroadcastMakesNoTopicAndNoDevice) {
  RecordingBroker broker;
  MqttOptions o = options(0);
  o.discovery_prefix = "homeassistant";
  Bus bus(broker, o);
  bus.ask(frequency(6000), 1.0, 0);
  bus.publisher().finish();
  for (const Message& m : broker.messages) {
    EXPECT_EQ(m.topic.find("/0/"), std::string::npos) << m.topic;
    EXPECT_EQ(m.topic.find("homeassistant/"), std::string::npos) << m.topic;
  }
}

TEST(MqttPublisher, AValueChangingFasterThanTheIntervalGoesOutOncePerIntervalAndLastAtTheEnd) {
  RecordingBroker broker;
  Bus bus(broker, options(1));
  for (int i = 0; i < 25; ++i) bus.read(frequency(1000 + i), 10 + 0.1 * i);  // 10.0 .. 12.4 s
  // At 10.0 at once; 10.1's change waits for 11.0, which sends 11.0's value; then 12.0.
  EXPECT_THAT(broker.raws(topic), ElementsAre(1000, 1010, 1020));
  bus.publisher().finish();
  EXPECT_THAT(broker.raws(topic), ElementsAre(1000, 1010, 1020, 1024));
}

TEST(MqttPublisher, AHeldValueThatWentBackIsNotSentAgain) {
  RecordingBroker broker;
  Bus bus(broker, options(1));
  bus.read(frequency(1000), 0.0);
  bus.read(frequency(1001), 0.3);
  bus.read(frequency(1000), 0.6);
  bus.publisher().tick(2 * second);
  EXPECT_THAT(broker.raws(topic), ElementsAre(1000));
}

TEST(MqttPublisher, TheBrokerBackGetsEveryRetainedTopicAgain) {
  RecordingBroker broker;
  MqttOptions o = options(0);
  o.discovery_prefix = "homeassistant";
  Bus bus(broker, o);
  bus.read(frequency(6000), 1.0);
  const size_t before = broker.messages.size();
  broker.reconnected = true;
  bus.publisher().tick(second + second / 2);  // no summary due yet
  std::vector<std::string> again;
  for (size_t i = before; i < broker.messages.size(); ++i)
    again.push_back(broker.messages[i].topic);
  EXPECT_THAT(again,
              ElementsAre("homeassistant/sensor/modtap_line_3_1_holding_9508_output_frequency/"
                          "config",
                          topic, "plant/line_3/health"));
  EXPECT_THAT(broker.on(topic).back(), HasSubstr("\"raw\":6000"));
}

TEST(MqttPublisher, DiscoveryPointsHomeAssistantAtTheValueAndTheStatus) {
  RecordingBroker broker;
  MqttOptions o = options(0);
  o.discovery_prefix = "homeassistant";
  Bus bus(broker, o);
  bus.read(frequency(6000), 1.0);
  const auto config =
      broker.on("homeassistant/sensor/modtap_line_3_1_holding_9508_output_frequency/config");
  ASSERT_EQ(config.size(), 1u);
  EXPECT_THAT(config[0], HasSubstr("\"state_topic\":\"" + topic + "\""));
  EXPECT_THAT(config[0], HasSubstr("\"unit_of_measurement\":\"Hz\""));
  EXPECT_THAT(config[0], HasSubstr("\"availability_topic\":\"plant/line_3/status\""));
  EXPECT_THAT(config[0], HasSubstr("\"value_template\":\"{{ value_json.value }}\""));
}

TEST(MqttPublisher, ARegisterNoModelNamesIsNamedByTableAndAddress) {
  RecordingBroker broker;
  MqttOptions o = options(0);
  o.base = RegisterBase::modicon;
  Bus bus(broker, o);
  RegisterValue reg;
  reg.table = Table::input;
  reg.address = 7;
  reg.raw = 12;
  reg.value = 12;
  bus.read(reg, 1.0, 9);
  EXPECT_THAT(broker.raws("plant/line_3/9/input_30008"), ElementsAre(12));
}

TEST(MqttPublisher, FollowLimitsWhatIsPublished) {
  RecordingBroker broker;
  MqttOptions o = options(0);
  o.follow = {{"output_current", std::nullopt}};
  Bus bus(broker, o);
  bus.read(frequency(6000), 1.0);
  EXPECT_TRUE(broker.on(topic).empty());
}

TEST(MqttPublisher, TheHealthSummaryCountsWhatTheStatisticsCount) {
  RecordingBroker broker;
  Bus bus(broker, options(5));
  for (int i = 0; i < 12; ++i) bus.read(frequency(6000), i);
  const auto health = broker.on("plant/line_3/health");
  ASSERT_EQ(health.size(), 3u);  // at 0, 5 and 10 s
  EXPECT_THAT(health[2], HasSubstr("\"frames\":11,"));
  bus.publisher().finish();
  EXPECT_THAT(broker.on("plant/line_3/health").back(), HasSubstr("\"frames\":12,"));
  EXPECT_THAT(broker.on("plant/line_3/health").back(), HasSubstr("\"slaves\":{\"1\":{"));
}

// A dashboard reads the diagnosis with the counts: a slave that never answers is named.
TEST(MqttPublisher, TheHealthSummaryNamesTheProblemsFound) {
  RecordingBroker broker;
  Bus bus(broker, options(5));
  bus.read(frequency(6000), 0);
  EXPECT_THAT(broker.on("plant/line_3/health").back(), HasSubstr("\"problems\":[]}"));
  for (int i = 1; i <= 6; ++i) bus.ask_in_vain(i, 7);
  bus.publisher().finish();
  EXPECT_THAT(broker.on("plant/line_3/health").back(),
              HasSubstr("\"problems\":[{\"problem\":\"no-response\",\"slave\":7,"));
}

TEST(MqttPublisher, TopicLevelsCarryNoWildcardsOrSeparators) {
  EXPECT_EQ(topic_level("a/b+c#d e"), "a_b_c_d_e");
  EXPECT_EQ(topic_level(""), "_");
}

TEST(MqttUrl, ReadsSchemeHostPortCredentialsAndPrefix) {
  const MqttUrl url = parse_mqtt_url("mqtt://me:secret@broker.local:1884/site/a/");
  EXPECT_EQ(url.host, "broker.local");
  EXPECT_EQ(url.port, 1884);
  EXPECT_EQ(url.user, "me");
  EXPECT_EQ(url.password, "secret");
  EXPECT_EQ(url.prefix, "site/a");
  const MqttUrl plain = parse_mqtt_url("mqtt://[::1]");
  EXPECT_EQ(plain.host, "::1");
  EXPECT_EQ(plain.port, 1883);
  EXPECT_EQ(plain.prefix, "modtap");
  EXPECT_FALSE(plain.tls);
  const MqttUrl tls = parse_mqtt_url("mqtts://me@broker.plant/p");
  EXPECT_TRUE(tls.tls);
  EXPECT_EQ(tls.port, 8883);
  EXPECT_EQ(tls.host, "broker.plant");
  EXPECT_EQ(parse_mqtt_url("mqtts://broker.plant:18883").port, 18883);
  for (const char* bad : {"tcp://x", "mqtt://", "mqtt://x:0", "mqtt://x:70000", "mqtt://x:1a",
                          "mqtts://", "mqttss://x"})
    EXPECT_THROW(parse_mqtt_url(bad), std::invalid_argument) << bad;
}

}  // namespace
}  // namespace modtap::output
