// The /metrics endpoint: an HTTP server on its own thread, HTTPS and users where a web
// configuration asks for them (Prometheus' exporter toolkit's format).
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>

#include "output/network/web_config.hpp"

struct MHD_Connection;

namespace modtap::output {

// An HTTP server (libmicrohttpd, on its own thread) that answers GET /metrics with what
// `render` returns. `address` is HOST:PORT, [IPV6]:PORT, or :PORT for every interface.
// Throws std::runtime_error naming the address when it cannot listen there.
// With a WebConfig: HTTPS, and only its users (HTTP basic authentication) get an answer.
class MetricsServer {
 public:
  MetricsServer(const std::string& address, std::function<std::string()> render,
                WebConfig config = {});
  ~MetricsServer();
  MetricsServer(const MetricsServer&) = delete;
  MetricsServer& operator=(const MetricsServer&) = delete;

  const std::function<std::string()>& render() const { return render_; }
  // Whether the request's user and password are one of the configuration's (all, without users).
  bool admits(MHD_Connection* connection);
  bool verify(const std::string& user, std::string_view password);

 private:
  struct Daemon;
  std::function<std::string()> render_;
  WebConfig config_;
  std::mutex verified_mutex_;
  std::map<std::string, std::string> verified_;  // the password that last matched, per user
  std::unique_ptr<Daemon> daemon_;
};

}  // namespace modtap::output
