#include "decoder/protocol/awaited_answer.hpp"

#include <algorithm>
#include <array>

#include "decoder/protocol/checksum.hpp"
#include "decoder/protocol/function_codes.hpp"

namespace modtap {
namespace {

constexpr uint16_t crc_size = 2;

}  // namespace

std::optional<uint16_t> AwaitedAnswer::length(std::span<const uint8_t> bytes) const {
  if (bytes.size() < 3 || !carries_answers_ || !expected_.pending || expected_.slave != bytes[0] ||
      expected_.function != (bytes[1] & 0x7F))
    return std::nullopt;
  const BodyLength body = body_length(Role::response, bytes);
  if (body.kind == BodyLength::Kind::need_more) return static_cast<uint16_t>(bytes.size() + 1);
  if (body.kind != BodyLength::Kind::known) return std::nullopt;
  return static_cast<uint16_t>(body.bytes + crc_size);
}

bool AwaitedAnswer::starts(std::span<const uint8_t> bytes) const {
  return length(bytes) || (bytes.size() > 3 && length(bytes.first(bytes.size() - 1)));
}

bool AwaitedAnswer::begins(std::span<const uint8_t> bytes) const {
  if (!expected_.pending || bytes.size() < 2 || bytes[0] != expected_.slave ||
      bytes[1] != expected_.function)
    return false;
  const ResponsePrefix prefix = response_prefix(expected_.request_pdu);
  return prefix.size >= 2 && 1u + prefix.size <= bytes.size() &&
         std::equal(prefix.pdu.begin() + 1, prefix.pdu.begin() + prefix.size, bytes.begin() + 2);
}

std::optional<bool> AwaitedAnswer::byte(std::span<const uint8_t> bytes, size_t pos) const {
  const auto request = expected_.request_pdu;
  // An exception echoes nothing.
  if (pos < 2 || pos >= bytes.size() || bytes[1] != expected_.function) return std::nullopt;
  const ResponsePrefix prefix = response_prefix(request);
  if (pos - 1 < prefix.size) return prefix.pdu[pos - 1] == bytes[pos];
  if (!prefix.echoes_request) return std::nullopt;
  // An echo repeats the whole request, its CRC too.
  if (pos - 1 < request.size()) return request[pos - 1] == bytes[pos];
  const size_t crc_at = 1 + request.size();
  if (pos >= crc_at + crc_size) return std::nullopt;
  return request_crc()[pos - crc_at] == bytes[pos];
}

bool AwaitedAnswer::tells_every_byte(std::span<const uint8_t> bytes, size_t pos) const {
  for (; pos < bytes.size(); ++pos)
    if (byte(bytes, pos) != true) return false;
  return true;
}

// Any good frame and a 0x00 pass a CRC, so FC07's answer whose status equals the request's CRC
// low byte (1 in 256) is its request and a 0x00; a read's answer would need all its data to
// repeat the request.
bool AwaitedAnswer::may_begin_with_copy(std::span<const uint8_t> copy, uint16_t length) const {
  const ResponsePrefix prefix = response_prefix(expected_.request_pdu);
  if (length > 1 + prefix.size + 1 + crc_size) return false;
  for (size_t pos = 2; pos < copy.size(); ++pos)
    if (byte(copy, pos) == false) return false;
  return true;
}

bool AwaitedAnswer::copies_request(std::span<const uint8_t> bytes, size_t size) const {
  return size == request_size() && size <= bytes.size() && repeats_request(bytes.first(size));
}

bool AwaitedAnswer::repeats_request(std::span<const uint8_t> bytes) const {
  const size_t size = request_size();
  if (size == 0 || bytes.empty() || bytes.size() > size || bytes[0] != expected_.slave)
    return false;
  const auto request = expected_.request_pdu;
  const size_t pdu = std::min(bytes.size() - 1, request.size());
  if (!std::equal(request.begin(), request.begin() + pdu, bytes.begin() + 1)) return false;
  const std::array<uint8_t, crc_size> crc = request_crc();
  return std::equal(bytes.begin() + 1 + pdu, bytes.end(), crc.begin());
}

std::array<uint8_t, 2> AwaitedAnswer::request_crc() const {
  const uint16_t crc = crc16(expected_.request_pdu, crc16_step(0xFFFF, expected_.slave));
  return {static_cast<uint8_t>(crc & 0xFF), static_cast<uint8_t>(crc >> 8)};
}

}  // namespace modtap
