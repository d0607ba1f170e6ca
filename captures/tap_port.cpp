#include "captures/tap_port.hpp"

#include "captures/network_tap.hpp"
#include "captures/serial_port.hpp"

namespace modtap::captures {

std::unique_ptr<TapPort> open_tap(const std::string& path, const SerialFormat& format) {
  if (is_network_tap(path)) return std::make_unique<NetworkTap>(path, format);
  return std::make_unique<SerialPort>(path, format);
}

}  // namespace modtap::captures
