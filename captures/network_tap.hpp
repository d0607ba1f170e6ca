// A serial device server's byte stream, read over TCP (ser2net `accepter: tcp,PORT`, an NPort or
// USR box in TCP-server mode, an ESP32 stream server): the bytes of the RS-485 line as the
// server hands them on, in packets of its own making. Read only: nothing is ever sent.
#pragma once

#include <string>

#include "captures/tap_port.hpp"

namespace modtap::captures {

class NetworkTap final : public TapPort {
 public:
  // `url`: tcp://HOST:PORT, HOST a name, an IPv4 address or an IPv6 one in brackets. Throws
  // CaptureError naming it where it is malformed, the host unknown, or no connection is made.
  explicit NetworkTap(const std::string& url);
  ~NetworkTap() override;
  NetworkTap(const NetworkTap&) = delete;
  NetworkTap& operator=(const NetworkTap&) = delete;

  int fd() const override { return fd_; }
  size_t read(std::span<uint8_t> into) override;
  const std::string& clock_note() const override { return clock_note_; }

 private:
  std::string url_;
  int fd_ = -1;
  std::string clock_note_;
};

}  // namespace modtap::captures
