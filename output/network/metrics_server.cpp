#include "output/network/metrics_server.hpp"

#include <microhttpd.h>
#include <netdb.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <string_view>

#include <fmt/format.h>

#include "output/network/shared_library.hpp"

namespace modtap::output {

namespace {

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

}  // namespace

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
