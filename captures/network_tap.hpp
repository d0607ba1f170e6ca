// A serial device server's byte stream, read over TCP (ser2net `accepter: tcp,PORT`, an NPort or
// USR box in TCP-server mode, an ESP32 stream server): the bytes of the RS-485 line as the
// server hands them on, in packets of its own making. Read only: no data byte is ever sent; to
// an RFC 2217 server (ser2net `telnet(rfc2217)`), Telnet's commands that set its port.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "captures/com_port_option.hpp"
#include "captures/tap_port.hpp"

namespace modtap::captures {

class NetworkTap final : public TapPort {
 public:
  // `url`: tcp://HOST:PORT or rfc2217://HOST:PORT, HOST a name, an IPv4 address or an IPv6 one
  // in brackets; an RFC 2217 server's port is set to `format`. Throws CaptureError naming it
  // where it is malformed, the host unknown, or no connection is made.
  NetworkTap(const std::string& url, const SerialFormat& format);
  ~NetworkTap() override;
  NetworkTap(const NetworkTap&) = delete;
  NetworkTap& operator=(const NetworkTap&) = delete;

  int fd() const override { return fd_; }
  size_t read(std::span<uint8_t> into) override;
  const std::string& clock_note() const override { return clock_note_; }
  std::optional<std::string> take_notice() override;

 private:
  void send_commands(std::span<const uint8_t> commands);

  std::string url_;
  int fd_ = -1;
  std::string clock_note_;
  // An RFC 2217 server's Telnet, taken out of its stream.
  std::optional<ComPortOption> telnet_;
  std::vector<uint8_t> received_, replies_;
  bool settings_told_ = false;
};

}  // namespace modtap::captures
