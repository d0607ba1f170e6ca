#include "captures/com_port_option.hpp"

#include <algorithm>
#include <array>

namespace modtap::captures {
namespace {

// Telnet (RFC 854) and its options.
constexpr uint8_t iac = 255, dont = 254, do_ = 253, wont = 252, will = 251, sb = 250, se = 240;
constexpr uint8_t binary = 0, com_port = 44;
// COM-PORT-OPTION's commands, client to server; the server answers each plus 100.
constexpr uint8_t set_baud = 1, set_data_size = 2, set_parity = 3, set_stop_size = 4;
constexpr uint8_t server_reply = 100;
// SET-PARITY's values 1, 2 and 3 (mark and space, 4 and 5, no Modbus line uses).
constexpr std::array<Parity, 3> parity_of_value = {Parity::none, Parity::odd, Parity::even};

constexpr uint8_t parity_value(Parity p) {
  return static_cast<uint8_t>(1 + std::find(parity_of_value.begin(), parity_of_value.end(), p) -
                              parity_of_value.begin());
}

// A subnegotiation: IAC SB COM-PORT-OPTION command value... IAC SE, a value's 0xFF doubled.
void put_sub(std::vector<uint8_t>& out, uint8_t command, std::span<const uint8_t> value) {
  out.insert(out.end(), {iac, sb, com_port, command});
  for (const uint8_t b : value) {
    out.push_back(b);
    if (b == iac) out.push_back(iac);
  }
  out.insert(out.end(), {iac, se});
}

}  // namespace

std::vector<uint8_t> ComPortOption::opening(const SerialFormat& f) {
  std::vector<uint8_t> out{iac, will, com_port, iac, will, binary, iac, do_, binary};
  const uint8_t baud[] = {static_cast<uint8_t>(f.baud >> 24), static_cast<uint8_t>(f.baud >> 16),
                          static_cast<uint8_t>(f.baud >> 8), static_cast<uint8_t>(f.baud)};
  put_sub(out, set_baud, baud);
  put_sub(out, set_data_size, std::span<const uint8_t>(&f.data_bits, 1));
  const uint8_t parity = parity_value(f.parity);
  put_sub(out, set_parity, std::span<const uint8_t>(&parity, 1));
  put_sub(out, set_stop_size, std::span<const uint8_t>(&f.stop_bits, 1));
  return out;
}

void ComPortOption::take(std::span<const uint8_t> received, std::vector<uint8_t>& data,
                         std::vector<uint8_t>& replies) {
  for (const uint8_t b : received) {
    switch (state_) {
      case State::data:
        if (b == iac)
          state_ = State::command;
        else
          data.push_back(b);
        break;
      case State::command:
        state_ = State::data;
        if (b == iac) {
          data.push_back(iac);  // a data byte 0xFF, doubled
        } else if (b == will || b == wont || b == do_ || b == dont) {
          verb_ = b;
          state_ = State::option;
        } else if (b == sb) {
          sub_.clear();
          state_ = State::sub;
        }  // any other command (NOP, a break, a mark) carries no data
        break;
      case State::option:
        on_option(verb_, b, replies);
        state_ = State::data;
        break;
      case State::sub:
        if (b == iac)
          state_ = State::sub_command;
        else if (sub_.size() < 64)
          sub_.push_back(b);
        break;
      case State::sub_command:
        if (b == se) {
          on_subnegotiation();
          state_ = State::data;
        } else {
          if (b == iac && sub_.size() < 64) sub_.push_back(iac);
          state_ = State::sub;
        }
        break;
    }
  }
}

// The server's answers to what was asked need none; every other option it offers or asks for
// is refused, once each time it does (a refusal is never answered again, so nothing loops).
void ComPortOption::on_option(uint8_t verb, uint8_t option, std::vector<uint8_t>& replies) {
  if (option == com_port && (verb == dont || verb == wont)) refused_ |= verb == dont;
  const bool ours = option == com_port || option == binary;
  if (ours) return;
  if (verb == do_) replies.insert(replies.end(), {iac, wont, option});
  if (verb == will) replies.insert(replies.end(), {iac, dont, option});
}

void ComPortOption::on_subnegotiation() {
  if (sub_.size() < 3 || sub_[0] != com_port) return;
  const uint8_t command = sub_[1];
  const uint8_t value = sub_[2];
  if (command == server_reply + set_baud && sub_.size() >= 6)
    reported_.baud =
        uint32_t{sub_[2]} << 24 | uint32_t{sub_[3]} << 16 | uint32_t{sub_[4]} << 8 | sub_[5];
  if (command == server_reply + set_data_size) reported_.data_bits = value;
  if (command == server_reply + set_parity && value >= 1 && value <= 3)
    reported_.parity = parity_of_value[value - 1u];
  if (command == server_reply + set_stop_size) reported_.stop_bits = value == 2 ? 2 : 1;
}

}  // namespace modtap::captures
