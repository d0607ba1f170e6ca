// A serial port opened only to listen: read-only, raw, with the line's character format.
// modtap never writes to it and never sets RTS or DTR itself.
#pragma once

#include <termios.h>

#include <cstdint>
#include <span>
#include <string>

#include "captures/tap_port.hpp"
#include "decoder/protocol/serial_format.hpp"

namespace modtap::captures {

class SerialPort final : public TapPort {
 public:
  // Throws CaptureError naming the port: missing, busy (another program holds it), not a tty.
  SerialPort(const std::string& path, const SerialFormat& format);
  ~SerialPort() override;
  SerialPort(const SerialPort&) = delete;
  SerialPort& operator=(const SerialPort&) = delete;

  int fd() const override { return fd_; }
  const std::string& path() const { return path_; }
  // Bytes that arrived, 0 if none yet. Throws CaptureError when the port is gone (unplugged).
  size_t read(std::span<uint8_t> into) override;
  // How the port's time stamps can be trusted: low-latency mode, the FTDI latency timer.
  const std::string& clock_note() const override { return clock_note_; }

 private:
  void configure(const SerialFormat& format);
  bool is_pty() const;
  bool set_pty(termios tio);
  void lower_latency();

  std::string path_;
  int fd_ = -1;
  std::string clock_note_;
};

}  // namespace modtap::captures
