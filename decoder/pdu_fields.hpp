// Turns a frame's PDU into named fields for every public function code. Sinks render them;
// nothing here prints.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "decoder/records.hpp"

namespace modtap::decoder {

struct Field {
  enum class Kind : uint8_t { number, hex, text, numbers, bits, bytes, items };
  std::string_view key;  // JSON key and -V label
  Kind kind = Kind::number;
  int64_t number = 0;
  std::string text;
  std::vector<int64_t> numbers;
  std::vector<uint8_t> bytes;
  std::vector<std::vector<Field>> items;  // sub-requests, objects: each a list of fields
};

struct DecodedPdu {
  std::vector<Field> fields;
  bool truncated = false;  // the PDU ended before its fields did (a damaged frame)
};

// `request_pdu` is the matched request's PDU for a response (quantities, addresses), or empty.
DecodedPdu decode_pdu(Role role, std::span<const uint8_t> pdu,
                      std::span<const uint8_t> request_pdu);

// The start address a response's values belong to, from its request (FC01-04, 17).
bool response_start_address(std::span<const uint8_t> request_pdu, uint16_t& address);

}  // namespace modtap::decoder
