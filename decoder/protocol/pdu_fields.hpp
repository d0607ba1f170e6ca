// A PDU's fields, as the function-code table decodes them. A field holds no copy of its bytes:
// values point into the PDU, so decoding allocates nothing once a DecodedPdu has grown to fit.
#pragma once

#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "decoder/protocol/bytes.hpp"
#include "decoder/protocol/field_registry.hpp"
#include "decoder/protocol/records.hpp"

namespace modtap {

struct Field {
  FieldId id = FieldId::data;
  uint8_t item = 0;    // 0: a field of the PDU; k: of the k-th item of the list before it
  uint16_t count = 0;  // registers: words; bits: bits; a list: its items
  int64_t number = 0;
  std::string_view text;           // a name field's fixed text
  std::span<const uint8_t> bytes;  // bytes, string, registers and bits: where they are

  const FieldInfo& info() const { return field_info(id); }
  std::string_view name() const { return info().name; }
  FieldType type() const { return info().type; }
  uint16_t word(size_t i) const { return be16(bytes, 2 * i); }
  bool bit(size_t i) const { return (bytes[i / 8] >> (i % 8)) & 1; }
};

struct DecodedPdu {
  std::vector<Field> fields;
  bool truncated = false;  // the PDU ended before its fields did (a damaged frame)

  // The field after the one at `at`, past a list's items.
  size_t next(size_t at) const {
    do ++at;
    while (at < fields.size() && fields[at].item != 0);
    return at;
  }
  const Field* find(FieldId id) const {
    for (const Field& f : fields)
      if (f.id == id) return &f;
    return nullptr;
  }
};

// Reads big-endian values off a PDU; past the end it yields zeros and remembers it did. Bytes
// taken past the end are as many as came; a value read past it is none the wire carried, and
// `overran` (shared by the readers of one PDU's parts) says so.
class PduReader {
 public:
  explicit PduReader(std::span<const uint8_t> bytes, bool* overran = nullptr)
      : bytes_(bytes), overran_(overran) {}
  uint8_t u8();
  uint16_t u16();
  std::span<const uint8_t> take(size_t n);
  // A reader of the next `n` bytes (a part of the PDU with a length of its own).
  PduReader sub(size_t n) { return PduReader(take(n), overran_); }
  std::span<const uint8_t> rest() { return take(left()); }
  size_t left() const { return bytes_.size() - at_; }
  bool short_read() const { return short_; }

 private:
  std::span<const uint8_t> bytes_;
  size_t at_ = 0;
  bool short_ = false;
  bool* overran_;
};

// Appends fields to a DecodedPdu; the function-code table's decoders write through it. Once a
// value was read past the PDU's end (a frame cut short), numbers and names are no fields: their
// values would be the reader's zeros, not the wire's.
class FieldWriter {
 public:
  FieldWriter(DecodedPdu& out, const bool& overran) : out_(out), overran_(overran) {}
  void number(FieldId id, int64_t v) {
    if (!overran_) add(id).number = v;
  }
  void name(FieldId id, std::string_view text) {
    if (!overran_) add(id).text = text;
  }
  void bytes(FieldId id, std::span<const uint8_t> v) { add(id).bytes = v; }
  // Up to `count` 16-bit values, as many as the reader still holds whole.
  void registers(FieldId id, PduReader& r, size_t count);
  // `count` bits packed LSB first, as many as `packed` holds.
  void bits(FieldId id, std::span<const uint8_t> packed, size_t count);
  // A list: the fields written between begin_item() calls and end_list() are its items.
  void begin_list(FieldId id);
  void begin_item();
  void end_list() { item_ = 0; }

 private:
  Field& add(FieldId id) {
    Field& f = out_.fields.emplace_back();
    f.id = id;
    f.item = item_;
    return f;
  }
  DecodedPdu& out_;
  const bool& overran_;
  size_t list_ = 0;
  uint8_t item_ = 0;
};

// Fills `out` (cleared first). `request_pdu` is the matched request's PDU for a response
// (quantities, addresses), or empty.
void decode_pdu(Role role, std::span<const uint8_t> pdu, std::span<const uint8_t> request_pdu,
                DecodedPdu& out);
DecodedPdu decode_pdu(Role role, std::span<const uint8_t> pdu,
                      std::span<const uint8_t> request_pdu);

}  // namespace modtap
