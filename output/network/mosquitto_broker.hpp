// The MQTT broker --mqtt publishes to, through libmosquitto (Debian's, from the Mosquitto
// project): its own network thread, reconnecting by itself after 1 s, then up to 30 s apart;
// modtap's status topic says online on every connection and offline at the end, and is the
// last will the broker publishes if modtap dies.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <unordered_map>
#include <unordered_set>

#include "output/mqtt_publisher.hpp"

struct mosquitto;

namespace modtap::output {

// mqtt://[USER[:PASSWORD]@]HOST[:PORT][/PREFIX], or mqtts:// for MQTT over TLS (port 8883).
struct MqttUrl {
  bool tls = false;
  std::string host;
  int port = 1883;
  std::string user, password;
  std::string prefix = "modtap";
};
// For mqtts://: the CA that signs the broker's certificate (none: the system's store), and a
// certificate of modtap's own where the broker asks for one. The broker's name is checked
// against its certificate unless `insecure` (for tests only).
struct MqttTls {
  std::string ca_file, cert_file, key_file;
  bool insecure = false;
};
// Throws std::invalid_argument naming the URL.
MqttUrl parse_mqtt_url(const std::string& url);

class MosquittoBroker final : public MessageBroker {
 public:
  MosquittoBroker(const MqttUrl& url, const MqttTls& tls, std::string status_topic);
  ~MosquittoBroker() override;
  MosquittoBroker(const MosquittoBroker&) = delete;
  MosquittoBroker& operator=(const MosquittoBroker&) = delete;

  // Waits up to `seconds` for a connection; false if none came.
  bool wait_connected(double seconds);
  // Why there is no connection, as far as libmosquitto told.
  std::string connect_error() const;
  const std::string& name() const { return name_; }

  void publish(std::string_view topic, std::string_view payload, bool retain) override;
  bool take_reconnected() override { return reconnected_.exchange(false); }

  // Says offline, waits (up to 5 s) until the broker has taken everything before it, and
  // disconnects.
  void close();
  uint64_t dropped() const { return dropped_; }  // messages not sent: the broker was away

 private:
  static void on_connect(mosquitto* client, void* self, int code);
  static void on_disconnect(mosquitto* client, void* self, int code);
  static void on_publish(mosquitto* client, void* self, int message_id);
  static void on_log(mosquitto* client, void* self, int level, const char* message);
  void set_up_tls(const MqttTls& tls);
  // Waits (a while) until libmosquitto has written out half of what it holds.
  bool wait_for_room();
  bool over_bound();

  // Bytes handed to libmosquitto and not yet written to the broker: bounded, so that a capture
  // read faster than the broker takes messages cannot queue them without limit (a health
  // summary of 247 slaves is 34 KB).
  static constexpr size_t max_unsent_bytes = size_t{4} << 20;
  // And in messages: libmosquitto's ids are 16 bits, so more than 65,535 in flight would reuse
  // an id still in the table (and each queued message costs libmosquitto a packet of its own).
  static constexpr size_t max_unsent_messages = 16384;
  void count_sent(int message_id);

  mosquitto* client_ = nullptr;
  std::string name_;  // mqtt://HOST:PORT, for messages
  std::string host_;
  std::string status_topic_;
  std::atomic<bool> connected_{false};
  std::atomic<bool> reconnected_{false};
  std::atomic<int> refused_{0};  // the broker's CONNACK code when it turned modtap away
  int start_error_ = 0;          // errno of the first attempt
  std::string log_error_;        // under mutex_: libmosquitto's last error (a TLS handshake's)
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  int offline_id_ = -1;
  bool offline_taken_ = false;
  bool stopped_ = false;
  uint64_t dropped_ = 0;
  // Under mutex_: each unsent message's size by its id, their sum, and the ids whose
  // on_publish came before mosquitto_publish returned them (the network thread is quick).
  std::unordered_map<int, size_t> unsent_;
  std::unordered_set<int> sent_early_;
  size_t unsent_bytes_ = 0;
  bool stalled_ = false;  // it took nothing for the last wait
};

}  // namespace modtap::output
