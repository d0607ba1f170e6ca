#include "decoder/protocol/pdu_fields.hpp"

#include <algorithm>

namespace modtap {

uint8_t PduReader::u8() {
  if (at_ >= bytes_.size()) {
    short_ = true;
    if (overran_) *overran_ = true;
    return 0;
  }
  return bytes_[at_++];
}

uint16_t PduReader::u16() {
  const uint8_t hi = u8();
  return static_cast<uint16_t>(hi << 8 | u8());
}

std::span<const uint8_t> PduReader::take(size_t n) {
  if (n > left()) {
    short_ = true;
    n = left();
  }
  const auto out = bytes_.subspan(at_, n);
  at_ += n;
  return out;
}

// Values cut short are as many as came whole; where none did, there is no field, not an empty
// list.
void FieldWriter::registers(FieldId id, PduReader& r, size_t count) {
  const size_t words = std::min(count, r.left() / 2);
  if (words == 0 && count > 0) return;
  Field& f = add(id);
  f.count = static_cast<uint16_t>(words);
  f.bytes = r.take(2 * words);
}

void FieldWriter::bits(FieldId id, std::span<const uint8_t> packed, size_t count) {
  const size_t n = std::min(count, packed.size() * 8);
  if (n == 0 && count > 0) return;
  Field& f = add(id);
  f.count = static_cast<uint16_t>(n);
  f.bytes = packed;
}

void FieldWriter::begin_list(FieldId id) {
  list_ = out_.fields.size();
  item_ = 0;
  add(id);
}

void FieldWriter::begin_item() {
  Field& list = out_.fields[list_];
  if (list.count < 255) ++list.count;  // an ADU holds fewer items than that
  item_ = static_cast<uint8_t>(list.count);
}

}  // namespace modtap
