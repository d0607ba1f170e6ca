#include "output/network/mosquitto_broker.hpp"

#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <stdexcept>

#include <fmt/format.h>
#include <mosquitto.h>

#include "output/network/shared_library.hpp"

namespace modtap::output {

namespace {

constexpr int keepalive_s = 30;
const char* const online = "online";
const char* const offline = "offline";

// The libmosquitto functions modtap calls, loaded and initialised on the first --mqtt.
struct Mosquitto {
  decltype(&::mosquitto_new) new_client;
  decltype(&::mosquitto_destroy) destroy;
  decltype(&::mosquitto_username_pw_set) username_pw_set;
  decltype(&::mosquitto_will_set) will_set;
  decltype(&::mosquitto_reconnect_delay_set) reconnect_delay_set;
  decltype(&::mosquitto_connect_callback_set) connect_callback_set;
  decltype(&::mosquitto_disconnect_callback_set) disconnect_callback_set;
  decltype(&::mosquitto_publish_callback_set) publish_callback_set;
  decltype(&::mosquitto_connect_async) connect_async;
  decltype(&::mosquitto_loop_start) loop_start;
  decltype(&::mosquitto_loop_stop) loop_stop;
  decltype(&::mosquitto_disconnect) disconnect;
  decltype(&::mosquitto_publish) publish;
  decltype(&::mosquitto_connack_string) connack_string;
  decltype(&::mosquitto_tls_set) tls_set;
  decltype(&::mosquitto_tls_insecure_set) tls_insecure_set;
  decltype(&::mosquitto_log_callback_set) log_callback_set;
  decltype(&::mosquitto_strerror) strerror;
};

const Mosquitto& libmosquitto() {
  static const Mosquitto loaded = [] {
    const SharedLibrary library("libmosquitto.so.1", "--mqtt", "libmosquitto1");
    MODTAP_SYMBOL(library, mosquitto_lib_init)();
    return Mosquitto{
        .new_client = MODTAP_SYMBOL(library, mosquitto_new),
        .destroy = MODTAP_SYMBOL(library, mosquitto_destroy),
        .username_pw_set = MODTAP_SYMBOL(library, mosquitto_username_pw_set),
        .will_set = MODTAP_SYMBOL(library, mosquitto_will_set),
        .reconnect_delay_set = MODTAP_SYMBOL(library, mosquitto_reconnect_delay_set),
        .connect_callback_set = MODTAP_SYMBOL(library, mosquitto_connect_callback_set),
        .disconnect_callback_set = MODTAP_SYMBOL(library, mosquitto_disconnect_callback_set),
        .publish_callback_set = MODTAP_SYMBOL(library, mosquitto_publish_callback_set),
        .connect_async = MODTAP_SYMBOL(library, mosquitto_connect_async),
        .loop_start = MODTAP_SYMBOL(library, mosquitto_loop_start),
        .loop_stop = MODTAP_SYMBOL(library, mosquitto_loop_stop),
        .disconnect = MODTAP_SYMBOL(library, mosquitto_disconnect),
        .publish = MODTAP_SYMBOL(library, mosquitto_publish),
        .connack_string = MODTAP_SYMBOL(library, mosquitto_connack_string),
        .tls_set = MODTAP_SYMBOL(library, mosquitto_tls_set),
        .tls_insecure_set = MODTAP_SYMBOL(library, mosquitto_tls_insecure_set),
        .log_callback_set = MODTAP_SYMBOL(library, mosquitto_log_callback_set),
        .strerror = MODTAP_SYMBOL(library, mosquitto_strerror),
    };
  }();
  return loaded;
}

}  // namespace

MqttUrl parse_mqtt_url(const std::string& url) {
  auto bad = [&](const std::string& why) {
    return std::invalid_argument(fmt::format(
        "--mqtt {}: {}; give mqtt[s]://[USER[:PASSWORD]@]HOST[:PORT][/PREFIX]", url, why));
  };
  MqttUrl parsed;
  std::string rest;
  if (url.rfind("mqtt://", 0) == 0) {
    rest = url.substr(7);
  } else if (url.rfind("mqtts://", 0) == 0) {
    rest = url.substr(8);
    parsed.tls = true;
    parsed.port = 8883;
  } else {
    throw bad("not an mqtt:// or mqtts:// URL");
  }
  if (const auto slash = rest.find('/'); slash != std::string::npos) {
    if (slash + 1 < rest.size()) parsed.prefix = rest.substr(slash + 1);
    rest.resize(slash);
    while (!parsed.prefix.empty() && parsed.prefix.back() == '/') parsed.prefix.pop_back();
    if (parsed.prefix.empty()) parsed.prefix = "modtap";
  }
  if (const auto at = rest.rfind('@'); at != std::string::npos) {
    const std::string credentials = rest.substr(0, at);
    rest = rest.substr(at + 1);
    const auto colon = credentials.find(':');
    parsed.user = credentials.substr(0, colon);
    if (colon != std::string::npos) parsed.password = credentials.substr(colon + 1);
  }
  const auto colon = rest.rfind(':');
  const bool has_port = colon != std::string::npos && rest.find(']', colon) == std::string::npos;
  parsed.host = has_port ? rest.substr(0, colon) : rest;
  if (parsed.host.size() > 2 && parsed.host.front() == '[' && parsed.host.back() == ']')
    parsed.host = parsed.host.substr(1, parsed.host.size() - 2);
  if (parsed.host.empty()) throw bad("no host");
  if (has_port) {
    const std::string port = rest.substr(colon + 1);
    char* end = nullptr;
    const long number = std::strtol(port.c_str(), &end, 10);
    if (port.empty() || *end != '\0' || number < 1 || number > 65535)
      throw bad("the port is not a number from 1 to 65535");
    parsed.port = static_cast<int>(number);
  }
  return parsed;
}

MosquittoBroker::MosquittoBroker(const MqttUrl& url, const MqttTls& tls, std::string status_topic)
    : name_(fmt::format("{}://{}:{}", url.tls ? "mqtts" : "mqtt", url.host, url.port)),
      host_(url.host),
      status_topic_(std::move(status_topic)) {
  const Mosquitto& m = libmosquitto();
  char host[256] = "";
  gethostname(host, sizeof host - 1);
  const std::string id = fmt::format("modtap-{}-{}", host, getpid());
  client_ = m.new_client(id.c_str(), true, this);
  if (!client_) throw std::runtime_error(fmt::format("{}: cannot make an MQTT client", name_));
  if (!url.user.empty())
    m.username_pw_set(client_, url.user.c_str(),
                      url.password.empty() ? nullptr : url.password.c_str());
  m.will_set(client_, status_topic_.c_str(), static_cast<int>(std::strlen(offline)), offline, 1,
             true);
  m.log_callback_set(client_, on_log);
  if (url.tls) set_up_tls(tls);
  m.reconnect_delay_set(client_, 1, 30, true);
  m.connect_callback_set(client_, on_connect);
  m.disconnect_callback_set(client_, on_disconnect);
  m.publish_callback_set(client_, on_publish);
  // A broker not there yet is tried again by the network thread: a service may start first.
  if (m.connect_async(client_, url.host.c_str(), url.port, keepalive_s) == MOSQ_ERR_ERRNO)
    start_error_ = errno;
  if (m.loop_start(client_) != MOSQ_ERR_SUCCESS) {
    m.destroy(client_);
    throw std::runtime_error(fmt::format("{}: cannot start the MQTT client's thread", name_));
  }
}

// libmosquitto checks the broker's certificate against the CA and its name against the host
// asked for; without a CA file, against the system's store (Debian's ca-certificates).
void MosquittoBroker::set_up_tls(const MqttTls& tls) {
  const Mosquitto& m = libmosquitto();
  auto file = [](const std::string& path) { return path.empty() ? nullptr : path.c_str(); };
  const int set =
      m.tls_set(client_, file(tls.ca_file), tls.ca_file.empty() ? "/etc/ssl/certs" : nullptr,
                file(tls.cert_file), file(tls.key_file), nullptr);
  if (set == MOSQ_ERR_SUCCESS && tls.insecure) m.tls_insecure_set(client_, true);
  if (set != MOSQ_ERR_SUCCESS) {
    m.destroy(client_);
    throw std::runtime_error(
        fmt::format("{}: TLS settings refused ({}): check --mqtt-ca, --mqtt-cert "
                    "and --mqtt-key",
                    name_, m.strerror(set)));
  }
}

MosquittoBroker::~MosquittoBroker() {
  if (!stopped_) {
    libmosquitto().disconnect(client_);
    libmosquitto().loop_stop(client_, false);
  }
  libmosquitto().destroy(client_);
}

void MosquittoBroker::on_connect(mosquitto* client, void* self, int code) {
  auto& broker = *static_cast<MosquittoBroker*>(self);
  if (code != 0) {
    {
      std::lock_guard lock(broker.mutex_);
      broker.refused_ = code;
    }
    broker.changed_.notify_all();
    return;
  }
  libmosquitto().publish(client, nullptr, broker.status_topic_.c_str(),
                         static_cast<int>(std::strlen(online)), online, 1, true);
  broker.reconnected_ = true;
  {
    std::lock_guard lock(broker.mutex_);
    broker.connected_ = true;
  }
  broker.changed_.notify_all();
}

void MosquittoBroker::on_disconnect(mosquitto*, void* self, int) {
  auto& broker = *static_cast<MosquittoBroker*>(self);
  {
    std::lock_guard lock(broker.mutex_);
    broker.connected_ = false;
  }
  broker.changed_.notify_all();
}

// Why a connection failed is only logged (a TLS handshake's certificate error): keep the last.
void MosquittoBroker::on_log(mosquitto*, void* self, int level, const char* message) {
  if (!(level & MOSQ_LOG_ERR) || !message) return;
  auto& broker = *static_cast<MosquittoBroker*>(self);
  {
    std::lock_guard lock(broker.mutex_);
    broker.log_error_ = message;
  }
  broker.changed_.notify_all();
}

void MosquittoBroker::on_publish(mosquitto*, void* self, int message_id) {
  auto& broker = *static_cast<MosquittoBroker*>(self);
  {
    std::lock_guard lock(broker.mutex_);
    if (message_id == broker.offline_id_)
      broker.offline_taken_ = true;
    else
      broker.count_sent(message_id);
  }
  broker.changed_.notify_all();
}

// Under mutex_. The status messages (QoS 1, acknowledged) are never in the table; the online
// message's id is not known, so it may wait in sent_early_ until its id comes round again
// (one message then escapes the count).
void MosquittoBroker::count_sent(int message_id) {
  const auto it = unsent_.find(message_id);
  if (it == unsent_.end()) {
    sent_early_.insert(message_id);
    return;
  }
  unsent_bytes_ -= it->second;
  unsent_.erase(it);
}

bool MosquittoBroker::wait_connected(double seconds) {
  std::unique_lock lock(mutex_);
  // A broker that refused modtap, or a TLS handshake that failed, will say the same again:
  // no use waiting for it. A broker not there yet may still come.
  changed_.wait_for(lock, std::chrono::duration<double>(seconds), [this] {
    return connected_ || refused_ || log_error_.find("OpenSSL Error") != std::string::npos;
  });
  return connected_;
}

std::string MosquittoBroker::connect_error() const {
  if (refused_) return libmosquitto().connack_string(refused_);
  {
    std::lock_guard lock(mutex_);
    if (log_error_.find("certificate verify failed") != std::string::npos)
      return log_error_ + fmt::format(
                              ": the broker's certificate is not signed by the CA given "
                              "(--mqtt-ca, else the system's store), or does not name {}",
                              host_);
    if (!log_error_.empty()) return log_error_;
  }
  if (start_error_) return std::strerror(start_error_);
  return "no answer";
}

void MosquittoBroker::publish(std::string_view topic, std::string_view payload, bool retain) {
  if (!connected_) {
    ++dropped_;
    return;
  }
  if (over_bound()) {
    // Waits once; while the broker stays stalled, the messages go without waiting again.
    if (stalled_ || !wait_for_room()) {
      stalled_ = true;
      ++dropped_;
      return;
    }
  }
  stalled_ = false;
  const std::string name(topic);
  int id = 0;
  if (libmosquitto().publish(client_, &id, name.c_str(), static_cast<int>(payload.size()),
                             payload.data(), 0, retain) != MOSQ_ERR_SUCCESS) {
    ++dropped_;
    return;
  }
  std::lock_guard lock(mutex_);
  if (sent_early_.erase(id)) return;
  const size_t bytes = name.size() + payload.size();
  unsent_[id] = bytes;
  unsent_bytes_ += bytes;
}

bool MosquittoBroker::over_bound() {
  std::lock_guard lock(mutex_);
  return unsent_bytes_ >= max_unsent_bytes || unsent_.size() >= max_unsent_messages;
}

// A broker that takes messages slower than a capture file is read holds the reading back; one
// that takes none for seconds (stalled, or gone without a word) loses messages instead, so
// that a live port is still read.
bool MosquittoBroker::wait_for_room() {
  std::unique_lock lock(mutex_);
  return changed_.wait_for(lock, std::chrono::seconds(5), [this] {
    return (unsent_bytes_ < max_unsent_bytes / 2 && unsent_.size() < max_unsent_messages / 2) ||
           !connected_;
  }) && connected_;
}

void MosquittoBroker::close() {
  if (stopped_) return;
  bool taken = false;
  {
    std::unique_lock lock(mutex_);
    if (connected_ && libmosquitto().publish(client_, &offline_id_, status_topic_.c_str(),
                                             static_cast<int>(std::strlen(offline)), offline, 1,
                                             true) == MOSQ_ERR_SUCCESS)
      taken = changed_.wait_for(lock, std::chrono::seconds(5), [this] { return offline_taken_; });
  }
  libmosquitto().disconnect(client_);
  // A broker that took nothing for 5 s would hold the network thread until its keep-alive
  // ran out: it is stopped instead (its last will says offline when the broker wakes).
  libmosquitto().loop_stop(client_, !taken);
  stopped_ = true;
}

}  // namespace modtap::output
