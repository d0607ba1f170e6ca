#include "decoder/records.hpp"

#include "decoder/checksum.hpp"

namespace modtap::decoder {

uint16_t Frame::wire_check() const {
  if (adu.size() < check_size()) return 0;
  return mode == Mode::rtu ? wire_crc(adu) : adu.back();
}

const char* to_string(NoiseReason reason) {
  switch (reason) {
    case NoiseReason::junk:
      return "junk";
    case NoiseReason::truncated:
      return "truncated";
    case NoiseReason::glitch:
      return "glitch";
    case NoiseReason::overlong:
      return "overlong";
    case NoiseReason::bad_hex:
      return "bad-hex";
  }
  return "?";
}

const char* to_string(TimeoutReason reason) {
  switch (reason) {
    case TimeoutReason::next_request:
      return "next-request";
    case TimeoutReason::silence:
      return "silence";
    case TimeoutReason::end_of_capture:
      return "end-of-capture";
  }
  return "?";
}

const char* to_string(Role role) {
  switch (role) {
    case Role::request:
      return "request";
    case Role::response:
      return "response";
    case Role::unknown:
      return "unknown";
  }
  return "?";
}

const char* to_string(ClockQuality clock) {
  switch (clock) {
    case ClockQuality::per_byte:
      return "per-byte";
    case ClockQuality::none:
      return "none";
    case ClockQuality::per_chunk:
      break;
  }
  return "per-chunk";
}

const char* to_string(Damage damage) {
  switch (damage) {
    case Damage::corrupted:
      return "corrupted";
    case Damage::cut:
      return "cut";
    case Damage::collision:
      return "collision";
    case Damage::none:
      break;
  }
  return nullptr;
}

const char* to_string(ChannelRole role) {
  switch (role) {
    case ChannelRole::master:
      return "master";
    case ChannelRole::slave:
      return "slave";
    case ChannelRole::bus:
      break;
  }
  return "bus";
}

const char* to_string(Mode mode) {
  return mode == Mode::rtu ? "rtu" : "ascii";
}

}  // namespace modtap::decoder
