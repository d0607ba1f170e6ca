#include "captures/network_tap.hpp"

#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <memory>

#include <fmt/format.h>

#include "captures/chunk_source.hpp"
#include "decoder/protocol/format_probe.hpp"

namespace modtap::captures {
namespace {

constexpr std::string_view tcp_scheme = "tcp://";
constexpr std::string_view rfc2217_scheme = "rfc2217://";
constexpr int connect_timeout_ms = 5000;

struct HostPort {
  std::string host, port;
};

// HOST:PORT after the scheme; an IPv6 host in brackets ([::1]:2000).
HostPort split_host_port(const std::string& url) {
  const std::string rest = url.substr(url.find("://") + 3);
  const bool bracketed = rest.starts_with('[');
  const size_t close = bracketed ? rest.find(']') : std::string::npos;
  const size_t colon =
      bracketed ? (close == std::string::npos ? close : rest.find(':', close)) : rest.rfind(':');
  HostPort hp;
  if (colon != std::string::npos) {
    hp.host = bracketed ? rest.substr(1, close - 1) : rest.substr(0, colon);
    hp.port = rest.substr(colon + 1);
  }
  if (hp.host.empty() || hp.port.empty() ||
      hp.port.find_first_not_of("0123456789") != std::string::npos)
    throw CaptureError(
        fmt::format("{}: a device server is tcp://HOST:PORT or rfc2217://HOST:PORT", url));
  return hp;
}

// Whether the socket is connected to itself: with no server on a local port of the ephemeral
// range, Linux may join a connect to that very port (a simultaneous open), which reads as a
// server that sends nothing. Taken as the refusal it is.
bool connected_to_itself(int fd) {
  sockaddr_storage mine{}, theirs{};
  socklen_t mine_size = sizeof mine, theirs_size = sizeof theirs;
  return getsockname(fd, reinterpret_cast<sockaddr*>(&mine), &mine_size) == 0 &&
         getpeername(fd, reinterpret_cast<sockaddr*>(&theirs), &theirs_size) == 0 &&
         mine_size == theirs_size && std::memcmp(&mine, &theirs, mine_size) == 0;
}

// Connects to one of the host's addresses within the time-out; the error of the last try where
// none answers.
int connect_to(const addrinfo* address, int& error) {
  const int fd = ::socket(address->ai_family, address->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC,
                          address->ai_protocol);
  if (fd < 0) {
    error = errno;
    return -1;
  }
  error = ::connect(fd, address->ai_addr, address->ai_addrlen) == 0 ? 0 : errno;
  if (error == EINPROGRESS) {
    pollfd p{fd, POLLOUT, 0};
    error = ETIMEDOUT;
    socklen_t size = sizeof error;
    if (::poll(&p, 1, connect_timeout_ms) == 1 &&
        getsockopt(fd, SOL_SOCKET, SO_ERROR, &error, &size) != 0)
      error = errno;
  }
  if (error == 0 && connected_to_itself(fd)) error = ECONNREFUSED;
  if (error == 0) return fd;
  ::close(fd);
  return -1;
}

// A network cut sends no end: keep-alive probes (empty segments, no data byte) notice one on a
// silent bus within about 20 seconds.
void notice_cuts(int fd) {
  const int on = 1, idle_s = 10, interval_s = 3, probes = 3;
  setsockopt(fd, SOL_SOCKET, SO_KEEPALIVE, &on, sizeof on);
  setsockopt(fd, IPPROTO_TCP, TCP_KEEPIDLE, &idle_s, sizeof idle_s);
  setsockopt(fd, IPPROTO_TCP, TCP_KEEPINTVL, &interval_s, sizeof interval_s);
  setsockopt(fd, IPPROTO_TCP, TCP_KEEPCNT, &probes, sizeof probes);
}

}  // namespace

bool is_network_tap(std::string_view path) {
  return path.starts_with(tcp_scheme) || sets_server_port(path);
}

bool sets_server_port(std::string_view path) {
  return path.starts_with(rfc2217_scheme);
}

NetworkTap::NetworkTap(const std::string& url, const SerialFormat& format)
    : url_(url),
      clock_note_(
          "time stamped per network packet as it arrives, after the server's packing and the "
          "network's delay") {
  const HostPort hp = split_host_port(url);
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* found = nullptr;
  if (const int rc = getaddrinfo(hp.host.c_str(), hp.port.c_str(), &hints, &found); rc != 0)
    throw CaptureError(fmt::format("{}: unknown host {}: {}", url, hp.host, gai_strerror(rc)));
  const std::unique_ptr<addrinfo, decltype(&freeaddrinfo)> addresses(found, freeaddrinfo);
  int error = 0;
  for (const addrinfo* a = found; a && fd_ < 0; a = a->ai_next) fd_ = connect_to(a, error);
  if (fd_ < 0) throw CaptureError(fmt::format("{}: cannot connect: {}", url, std::strerror(error)));
  notice_cuts(fd_);
  if (!sets_server_port(url)) return;
  telnet_.emplace();
  try {
    send_commands(ComPortOption::opening(format));
  } catch (...) {
    ::close(fd_);  // no destructor runs for a constructor that throws: --reconnect retries
    throw;
  }
}

// Telnet's commands to an RFC 2217 server, never a data byte; a few dozen bytes, which a
// connected socket takes at once (a second at most).
void NetworkTap::send_commands(std::span<const uint8_t> commands) {
  while (!commands.empty()) {
    const ssize_t n = ::send(fd_, commands.data(), commands.size(), MSG_NOSIGNAL);
    if (n > 0) {
      commands = commands.subspan(static_cast<size_t>(n));
      continue;
    }
    pollfd p{fd_, POLLOUT, 0};
    if ((n < 0 && errno != EAGAIN && errno != EINTR) || ::poll(&p, 1, 1000) != 1)
      throw CaptureError(
          fmt::format("{}: cannot set the server's port: {}", url_, std::strerror(errno)));
  }
}

std::optional<std::string> NetworkTap::take_notice() {
  if (!telnet_) return std::nullopt;
  if (telnet_->refused() && !settings_told_) {
    settings_told_ = true;
    return "the server refuses RFC 2217: its port keeps the settings it has";
  }
  const ReportedSettings& r = telnet_->reported();
  if (settings_told_ || !r.baud || !r.data_bits || !r.parity || !r.stop_bits) return std::nullopt;
  settings_told_ = true;
  return fmt::format("the server set its port to {}",
                     describe(SerialFormat{*r.baud, *r.data_bits, *r.parity, *r.stop_bits}));
}

NetworkTap::~NetworkTap() {
  if (fd_ >= 0) ::close(fd_);
}

size_t NetworkTap::read(std::span<uint8_t> into) {
  const ssize_t n = ::recv(fd_, into.data(), into.size(), MSG_DONTWAIT);
  if (n > 0 && telnet_) {
    // Telnet's commands out, its doubled 0xFF undone: what is left is the line's bytes.
    received_.clear();
    replies_.clear();
    telnet_->take(into.first(static_cast<size_t>(n)), received_, replies_);
    if (!replies_.empty()) send_commands(replies_);
    std::copy(received_.begin(), received_.end(), into.begin());
    return received_.size();
  }
  if (n > 0) return static_cast<size_t>(n);
  if (n < 0 && (errno == EAGAIN || errno == EINTR)) return 0;
  throw CaptureError(fmt::format("{}: the connection is gone: {}", url_,
                                 n == 0 ? "the server closed it" : std::strerror(errno)));
}

}  // namespace modtap::captures
