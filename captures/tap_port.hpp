// A port modtap listens on: a local serial port, or a serial device server's byte stream over
// TCP (docs/live.md, "A bus behind a device server"). Either is only read: modtap holds no
// descriptor it writes with on a serial port, and sends nothing on a socket.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "decoder/protocol/serial_format.hpp"

namespace modtap::captures {

class TapPort {
 public:
  virtual ~TapPort() = default;
  // For poll(): readable when bytes came, or the port is gone.
  virtual int fd() const = 0;
  // Bytes that arrived, 0 if none yet. Throws CaptureError naming the port when it is gone
  // (unplugged, the server closed the connection or the network cut it).
  virtual size_t read(std::span<uint8_t> into) = 0;
  // How its time stamps can be trusted, for the start-up line.
  virtual const std::string& clock_note() const = 0;
  // Something the port learned that the user should hear once (a device server's report of the
  // settings it set its port to), or nothing.
  virtual std::optional<std::string> take_notice() { return std::nullopt; }
};

// tcp://HOST:PORT, the raw byte stream of a device server in TCP-server mode, or
// rfc2217://HOST:PORT, a Telnet COM-PORT-OPTION server whose port modtap sets.
bool is_network_tap(std::string_view path);
bool sets_server_port(std::string_view path);  // rfc2217://

// How late a device server's packet may bring a byte, where --chunk-jitter is not given: it
// packs what its port read for up to some tens of milliseconds (an NPort's force-transmit time,
// ser2net's reads), and the network adds its own; 30 ms, a USB adapter's, would take a frame
// split over two packets for two.
inline constexpr double network_read_jitter_ms = 100;

// Opens `path` to listen: a device server's stream where it is one, else a serial port set to
// `format`. Throws CaptureError naming it: missing, busy, refused, an unknown host.
std::unique_ptr<TapPort> open_tap(const std::string& path, const SerialFormat& format);

}  // namespace modtap::captures
