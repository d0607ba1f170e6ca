#include "output/metrics.hpp"

#include <microhttpd.h>
#include <netdb.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <string_view>

#include "decoder/protocol/records.hpp"
#include "output/shared_library.hpp"
#include "output/web_config.hpp"

namespace modtap::output {

namespace {

constexpr double ns_per_s = 1e9;

// Upper bounds of the latency buckets, in seconds: a turnaround of a few characters at
// 115200 baud up to the seconds a slow drive or a gateway takes.
constexpr double latency_bounds_s[] = {0.0005, 0.001, 0.002, 0.005, 0.01, 0.02, 0.05,
                                       0.1,    0.2,   0.5,   1,     2,    5};

class Exposition {
 public:
  explicit Exposition(fmt::memory_buffer& out) : out_(out) {}

  void family(std::string_view name, std::string_view type, std::string_view help) {
    fmt::format_to(fmt::appender(out_), "# HELP {} {}\n# TYPE {} {}\n", name, help, name, type);
  }
  // `labels` is already in the exposition's form: slave="3",fc="6" (or empty).
  template <typename Value>
  void sample(std::string_view name, std::string_view labels, Value value) {
    if (labels.empty()) {
      fmt::format_to(fmt::appender(out_), "{} {}\n", name, value);
    } else {
      fmt::format_to(fmt::appender(out_), "{}{{{}}} {}\n", name, labels, value);
    }
  }

 private:
  fmt::memory_buffer& out_;
};

// The slaves, with what each exchange count of theirs is, per function code.
void exchange_family(Exposition& e, const BusStatistics& s, std::string_view name,
                     std::string_view help, uint64_t ExchangeCounts::*count) {
  e.family(name, "counter", help);
  s.for_each_slave([&](uint8_t address, const SlaveStatistics& slave) {
    for (const auto& [fc, counts] : slave.by_function)
      e.sample(name, fmt::format("slave=\"{}\",fc=\"{}\"", address, fc), counts.*count);
  });
}

void latency_histogram(Exposition& e, const BusStatistics& s) {
  constexpr std::string_view name = "modtap_response_latency_seconds";
  e.family(name, "histogram",
           "Time from the end of a request to the start of its good response, per slave");
  s.for_each_slave([&](uint8_t address, const SlaveStatistics& slave) {
    const auto& latency = slave.latency_ns;
    for (double bound : latency_bounds_s)
      e.sample("modtap_response_latency_seconds_bucket",
               fmt::format("slave=\"{}\",le=\"{}\"", address, bound),
               latency.count_at_most(static_cast<uint64_t>(bound * ns_per_s)));
    e.sample("modtap_response_latency_seconds_bucket",
             fmt::format("slave=\"{}\",le=\"+Inf\"", address), latency.count());
    e.sample("modtap_response_latency_seconds_sum", fmt::format("slave=\"{}\"", address),
             static_cast<double>(latency.sum()) / ns_per_s);
    e.sample("modtap_response_latency_seconds_count", fmt::format("slave=\"{}\"", address),
             latency.count());
  });
}

void per_slave(Exposition& e, const BusStatistics& s) {
  exchange_family(e, s, "modtap_requests_total",
                  "Requests to a slave with a good check, per function code",
                  &ExchangeCounts::requests);
  exchange_family(e, s, "modtap_responses_total",
                  "Responses from a slave with a good check, per function code",
                  &ExchangeCounts::responses);
  exchange_family(e, s, "modtap_timeouts_total",
                  "Requests a slave left unanswered past the time-out, per function code",
                  &ExchangeCounts::timeouts);
  exchange_family(e, s, "modtap_retries_total",
                  "Requests sent again after no answer, per slave and function code",
                  &ExchangeCounts::retries);
  // A frame's function code may be as corrupted as its check: bad checks are counted per slave.
  e.family("modtap_bad_checks_total", "counter",
           "Frames to or from a slave with a wrong CRC or LRC");
  s.for_each_slave([&](uint8_t address, const SlaveStatistics& slave) {
    e.sample("modtap_bad_checks_total", fmt::format("slave=\"{}\"", address),
             slave.counts.bad_checks);
  });
  e.family("modtap_exceptions_total", "counter", "Exception responses of a slave, per code");
  s.for_each_slave([&](uint8_t address, const SlaveStatistics& slave) {
    for (const auto& [code, count] : slave.exceptions_by_code)
      e.sample("modtap_exceptions_total", fmt::format("slave=\"{}\",code=\"{}\"", address, code),
               count);
  });
  latency_histogram(e, s);
  e.family("modtap_last_frame_timestamp_seconds", "gauge",
           "When the last frame to or from a slave began, in seconds since the Unix epoch");
  s.for_each_slave([&](uint8_t address, const SlaveStatistics& slave) {
    e.sample("modtap_last_frame_timestamp_seconds", fmt::format("slave=\"{}\"", address),
             static_cast<double>(slave.last_frame_ns) / ns_per_s);
  });
}

void bus_wide(Exposition& e, const BusStatistics& s) {
  e.family("modtap_frames_total", "counter", "Frames seen, with a good check or not");
  e.sample("modtap_frames_total", "", s.frames);
  e.family("modtap_frame_bytes_total", "counter", "Bytes in frames");
  e.sample("modtap_frame_bytes_total", "", s.frame_bytes);
  e.family("modtap_noise_bytes_total", "counter", "Bytes that were no frame");
  e.sample("modtap_noise_bytes_total", "", s.noise_bytes);
  e.family("modtap_noise_records_total", "counter", "Runs of noise, by why they are noise");
  for (size_t reason = 0; reason < s.noise_by_reason.size(); ++reason)
    e.sample("modtap_noise_records_total",
             fmt::format("reason=\"{}\"", to_string(static_cast<NoiseReason>(reason))),
             s.noise_by_reason[reason]);
  e.family("modtap_line_busy_seconds_total", "counter",
           "Wire time of every byte seen, from the character format: its rate is the bus load");
  const auto bytes = static_cast<double>(s.frame_bytes + s.noise_bytes);
  e.sample("modtap_line_busy_seconds_total", "",
           bytes * static_cast<double>(s.format().char_time_ns()) / ns_per_s);
  if (const auto load = s.bus_load()) {
    e.family("modtap_bus_load_ratio", "gauge",
             "Share of the time since the first byte the wire carried characters");
    e.sample("modtap_bus_load_ratio", "", *load);
  }
  e.family("modtap_broadcasts_total", "counter", "Requests to slave 0, which no slave answers");
  e.sample("modtap_broadcasts_total", "", s.broadcasts);
  e.family("modtap_stray_bad_checks_total", "counter",
           "Frames with a bad check at addresses no good frame ever named (a corrupted address)");
  e.sample("modtap_stray_bad_checks_total", "", s.stray_bad_checks());
  e.family("modtap_findings_total", "counter",
           "Records with each finding (docs/output.md lists them), frames and noise alike");
  const auto registry = finding_registry();
  for (size_t slot = 0; slot < registry.size(); ++slot)
    e.sample("modtap_findings_total", fmt::format("finding=\"{}\"", registry[slot].name),
             s.findings[slot].count);
}

// The listening socket, made here so a failure says exactly why (in use, no such address).
int listen_on(const std::string& address, bool& ipv6) {
  const auto colon = address.rfind(':');
  if (colon == std::string::npos || colon + 1 == address.size())
    throw std::runtime_error(
        fmt::format("--metrics {}: give HOST:PORT, [IPV6]:PORT or :PORT", address));
  std::string host = address.substr(0, colon);
  const std::string port = address.substr(colon + 1);
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']')
    host = host.substr(1, host.size() - 2);
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE | AI_NUMERICSERV;
  addrinfo* found = nullptr;
  if (const int error =
          getaddrinfo(host.empty() ? nullptr : host.c_str(), port.c_str(), &hints, &found))
    throw std::runtime_error(fmt::format("--metrics {}: {}", address, gai_strerror(error)));
  const std::unique_ptr<addrinfo, void (*)(addrinfo*)> addresses(found, freeaddrinfo);
  const int fd = socket(found->ai_family, found->ai_socktype | SOCK_CLOEXEC, found->ai_protocol);
  if (fd < 0) throw std::runtime_error(fmt::format("--metrics {}: {}", address, strerror(errno)));
  const int on = 1;
  setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &on, sizeof on);
  if (bind(fd, found->ai_addr, found->ai_addrlen) != 0 || listen(fd, 16) != 0) {
    const int error = errno;
    close(fd);
    throw std::runtime_error(fmt::format("--metrics {}: {}", address, strerror(error)));
  }
  ipv6 = found->ai_family == AF_INET6;
  return fd;
}

// The libmicrohttpd functions modtap calls, loaded on the first --metrics.
struct Microhttpd {
  decltype(&::MHD_start_daemon) start_daemon;
  decltype(&::MHD_stop_daemon) stop_daemon;
  decltype(&::MHD_create_response_from_buffer) create_response_from_buffer;
  decltype(&::MHD_add_response_header) add_response_header;
  decltype(&::MHD_queue_response) queue_response;
  decltype(&::MHD_destroy_response) destroy_response;
  decltype(&::MHD_basic_auth_get_username_password) basic_auth_get_username_password;
  decltype(&::MHD_queue_basic_auth_fail_response) queue_basic_auth_fail_response;
  decltype(&::MHD_free) free;
};

const Microhttpd& libmicrohttpd() {
  static const Microhttpd loaded = [] {
    const SharedLibrary library("libmicrohttpd.so.12", "--metrics", "libmicrohttpd12");
    return Microhttpd{
        .start_daemon = MODTAP_SYMBOL(library, MHD_start_daemon),
        .stop_daemon = MODTAP_SYMBOL(library, MHD_stop_daemon),
        .create_response_from_buffer = MODTAP_SYMBOL(library, MHD_create_response_from_buffer),
        .add_response_header = MODTAP_SYMBOL(library, MHD_add_response_header),
        .queue_response = MODTAP_SYMBOL(library, MHD_queue_response),
        .destroy_response = MODTAP_SYMBOL(library, MHD_destroy_response),
        .basic_auth_get_username_password =
            MODTAP_SYMBOL(library, MHD_basic_auth_get_username_password),
        .queue_basic_auth_fail_response =
            MODTAP_SYMBOL(library, MHD_queue_basic_auth_fail_response),
        .free = MODTAP_SYMBOL(library, MHD_free),
    };
  }();
  return loaded;
}

MHD_Result respond(MHD_Connection* connection, unsigned status, std::string_view type,
                   const std::string& body) {
  MHD_Response* response = libmicrohttpd().create_response_from_buffer(
      body.size(), const_cast<char*>(body.data()), MHD_RESPMEM_MUST_COPY);
  if (!response) return MHD_NO;
  libmicrohttpd().add_response_header(response, MHD_HTTP_HEADER_CONTENT_TYPE,
                                      std::string(type).c_str());
  const MHD_Result queued = libmicrohttpd().queue_response(connection, status, response);
  libmicrohttpd().destroy_response(response);
  return queued;
}

// 401 with the realm, and nothing of the metrics.
MHD_Result refuse(MHD_Connection* connection) {
  const std::string_view body = "modtap's metrics need a user and password\n";
  MHD_Response* response = libmicrohttpd().create_response_from_buffer(
      body.size(), const_cast<char*>(body.data()), MHD_RESPMEM_PERSISTENT);
  if (!response) return MHD_NO;
  const MHD_Result queued =
      libmicrohttpd().queue_basic_auth_fail_response(connection, "modtap metrics", response);
  libmicrohttpd().destroy_response(response);
  return queued;
}

MHD_Result answer(void* server, MHD_Connection* connection, const char* url, const char* method,
                  const char*, const char*, size_t*, void**) {
  if (!static_cast<MetricsServer*>(server)->admits(connection)) return refuse(connection);
  if (std::string_view(method) != MHD_HTTP_METHOD_GET &&
      std::string_view(method) != MHD_HTTP_METHOD_HEAD)
    return respond(connection, MHD_HTTP_METHOD_NOT_ALLOWED, "text/plain", "GET only\n");
  if (std::string_view(url) != "/metrics")
    return respond(connection, MHD_HTTP_NOT_FOUND, "text/plain",
                   "modtap serves its metrics on /metrics\n");
  const auto& render = static_cast<const MetricsServer*>(server)->render();
  return respond(connection, MHD_HTTP_OK, "text/plain; version=0.0.4; charset=utf-8", render());
}

// One sample a problem found now: a series that appears when the diagnosis finds it and goes
// when it no longer does, so an alert rule is `modtap_problem > 0`.
void problems_family(Exposition& e, std::span<const Problem> problems) {
  e.family("modtap_problem", "gauge",
           "A problem the diagnosis finds now, per kind and slave (none: the whole bus); "
           "1 while found (docs/output.md)");
  for (const Problem& p : problems) {
    const std::string slave = p.slave ? fmt::format("slave=\"{}\",", *p.slave) : "";
    e.sample("modtap_problem",
             fmt::format("kind=\"{}\",{}severity=\"{}\"", problem_info(p.kind).name, slave,
                         to_string(p.severity)),
             1);
  }
}

}  // namespace

void append_metrics(fmt::memory_buffer& out, std::string_view version,
                    const BusStatistics& statistics, std::span<const Problem> problems,
                    const PortHealth& ports) {
  Exposition e(out);
  e.family("modtap_build_info", "gauge", "modtap's version, as a label; always 1");
  e.sample("modtap_build_info", fmt::format("version=\"{}\"", version), 1);
  bus_wide(e, statistics);
  per_slave(e, statistics);
  problems_family(e, problems);
  if (ports.ports.load() > 0) {
    e.family("modtap_ports_open", "gauge",
             "Ports modtap reads now, of those it listens on (an unplugged one is not)");
    e.sample("modtap_ports_open", "", ports.open.load());
  }
  e.family("modtap_port_read_errors_total", "counter",
           "Reads from a port that failed (an adapter unplugged)");
  e.sample("modtap_port_read_errors_total", "", ports.read_errors.load());
  e.family("modtap_port_reconnects_total", "counter", "Ports that came back (--reconnect)");
  e.sample("modtap_port_reconnects_total", "", ports.reconnects.load());
}

struct MetricsServer::Daemon {
  MHD_Daemon* daemon = nullptr;
  ~Daemon() {
    if (daemon) libmicrohttpd().stop_daemon(daemon);  // closes the listening socket too
  }
};

MetricsServer::MetricsServer(const std::string& address, std::function<std::string()> render,
                             WebConfig config)
    : render_(std::move(render)), config_(std::move(config)), daemon_(std::make_unique<Daemon>()) {
  bool ipv6 = false;
  const int fd = listen_on(address, ipv6);
  unsigned flags = MHD_USE_INTERNAL_POLLING_THREAD;
  if (ipv6) flags |= MHD_USE_IPv6;
  if (config_.tls()) {
    daemon_->daemon = libmicrohttpd().start_daemon(
        flags | MHD_USE_TLS, 0, nullptr, nullptr, &answer, this, MHD_OPTION_LISTEN_SOCKET, fd,
        MHD_OPTION_HTTPS_MEM_KEY, config_.key_pem.c_str(), MHD_OPTION_HTTPS_MEM_CERT,
        config_.cert_pem.c_str(), MHD_OPTION_END);
  } else {
    daemon_->daemon = libmicrohttpd().start_daemon(flags, 0, nullptr, nullptr, &answer, this,
                                                   MHD_OPTION_LISTEN_SOCKET, fd, MHD_OPTION_END);
  }
  if (!daemon_->daemon) {
    close(fd);
    throw std::runtime_error(fmt::format("--metrics {}: the HTTP server did not start", address));
  }
}

MetricsServer::~MetricsServer() = default;

bool MetricsServer::admits(MHD_Connection* connection) {
  if (config_.users.empty()) return true;
  char* password = nullptr;
  char* user = libmicrohttpd().basic_auth_get_username_password(connection, &password);
  const bool admitted = user && password && verify(user, password);
  if (user) libmicrohttpd().free(user);
  if (password) libmicrohttpd().free(password);
  return admitted;
}

// bcrypt takes tens of milliseconds by design; Prometheus sends the same user and password at
// every scrape, so the password that last matched a configured user is kept and compared as
// it is. Only configured users get an entry: a stranger's names cannot grow the table. A name
// no user has costs a bcrypt check all the same (stand_in_hash).
bool MetricsServer::verify(const std::string& user, std::string_view password) {
  const auto it = config_.users.find(user);
  if (it == config_.users.end()) {
    static_cast<void>(password_matches(password, config_.stand_in_hash));  // the same time
    return false;
  }
  std::lock_guard lock(verified_mutex_);
  std::string& verified = verified_[it->first];
  if (!verified.empty() && same_secret(verified, password)) return true;
  if (!password_matches(password, it->second)) return false;
  verified = password;
  return true;
}

}  // namespace modtap::output
