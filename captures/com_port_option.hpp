// Telnet's COM-PORT-OPTION (RFC 2217), as a listener needs it: the opening that sets the
// server's serial port to the line's settings, and a reader that takes Telnet's commands out
// of the stream, undoes its doubled 0xFF, refuses every option but the two asked for, and keeps
// the settings the server reports back. Pure: the socket is the caller's.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "decoder/protocol/serial_format.hpp"

namespace modtap::captures {

// What a server said of its port, as it answered the settings asked.
struct ReportedSettings {
  std::optional<uint32_t> baud;
  std::optional<uint8_t> data_bits;
  std::optional<Parity> parity;
  std::optional<uint8_t> stop_bits;
};

class ComPortOption {
 public:
  // Telnet commands only, never a data byte: WILL COM-PORT-OPTION, binary both ways (the
  // line's bytes pass untranslated), and the port's baud, data bits, parity and stop bits.
  static std::vector<uint8_t> opening(const SerialFormat& format);

  // Takes what the server sent: appends its data bytes to `data`, the replies it needs (a
  // refusal of each option not asked for) to `replies`.
  void take(std::span<const uint8_t> received, std::vector<uint8_t>& data,
            std::vector<uint8_t>& replies);

  const ReportedSettings& reported() const { return reported_; }
  // The server refused COM-PORT-OPTION (DONT): it cannot set its port.
  bool refused() const { return refused_; }

 private:
  enum class State : uint8_t { data, command, option, sub, sub_command };
  void on_option(uint8_t verb, uint8_t option, std::vector<uint8_t>& replies);
  void on_subnegotiation();

  State state_ = State::data;
  uint8_t verb_ = 0;
  std::vector<uint8_t> sub_;  // a subnegotiation's bytes, IAC IAC undone
  ReportedSettings reported_;
  bool refused_ = false;
};

}  // namespace modtap::captures
