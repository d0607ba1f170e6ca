#include "decoder/pdu_fields.hpp"

#include "decoder/function_codes.hpp"

namespace modtap::decoder {
namespace {

// Reads big-endian values off a PDU; past the end it yields zeros and remembers it did.
class Reader {
 public:
  explicit Reader(std::span<const uint8_t> bytes) : bytes_(bytes) {}
  uint8_t u8() {
    if (at_ >= bytes_.size()) {
      short_ = true;
      return 0;
    }
    return bytes_[at_++];
  }
  uint16_t u16() {
    const uint8_t hi = u8();
    return static_cast<uint16_t>(hi << 8 | u8());
  }
  std::span<const uint8_t> take(size_t n) {
    if (n > left()) {
      short_ = true;
      n = left();
    }
    auto out = bytes_.subspan(at_, n);
    at_ += n;
    return out;
  }
  size_t left() const { return bytes_.size() - at_; }
  bool short_read() const { return short_; }

 private:
  std::span<const uint8_t> bytes_;
  size_t at_ = 0;
  bool short_ = false;
};

Field make(std::string_view key, Field::Kind kind, int64_t v = 0) {
  Field f;
  f.key = key;
  f.kind = kind;
  f.number = v;
  return f;
}
Field number(std::string_view key, int64_t v) {
  return make(key, Field::Kind::number, v);
}
Field hex(std::string_view key, int64_t v) {
  return make(key, Field::Kind::hex, v);
}
Field text(std::string_view key, std::string v) {
  Field f = make(key, Field::Kind::text);
  f.text = std::move(v);
  return f;
}
Field bytes(std::string_view key, std::span<const uint8_t> v) {
  Field f = make(key, Field::Kind::bytes);
  f.bytes.assign(v.begin(), v.end());
  return f;
}
Field registers(std::string_view key, Reader& r, size_t count) {
  Field f = make(key, Field::Kind::numbers);
  for (size_t i = 0; i < count && r.left() >= 2; ++i) f.numbers.push_back(r.u16());
  return f;
}
// Coils and inputs: LSB of the first byte is the first bit.
Field bits(std::string_view key, std::span<const uint8_t> packed, size_t count) {
  Field f = make(key, Field::Kind::bits);
  for (size_t i = 0; i < count && i / 8 < packed.size(); ++i)
    f.numbers.push_back((packed[i / 8] >> (i % 8)) & 1);
  return f;
}

uint16_t request_u16(std::span<const uint8_t> req, size_t at) {
  return req.size() < at + 2 ? 0 : static_cast<uint16_t>(req[at] << 8 | req[at + 1]);
}

void address_quantity(Reader& r, std::vector<Field>& out) {
  out.push_back(number("address", r.u16()));
  out.push_back(number("quantity", r.u16()));
}

void diagnostics(Reader& r, std::vector<Field>& out) {
  const uint16_t sub = r.u16();
  out.push_back(number("sub_function", sub));
  if (const char* name = diagnostic_name(sub)) out.push_back(text("sub_function_name", name));
  out.push_back(bytes("data", r.take(r.left())));
}

void file_records(Reader& r, std::vector<Field>& out, bool with_data) {
  const uint8_t count = r.u8();
  out.push_back(number("byte_count", count));
  Field list = make("sub_requests", Field::Kind::items);
  Reader sub(r.take(count));
  while (sub.left() >= 7) {
    std::vector<Field> item;
    item.push_back(number("reference_type", sub.u8()));
    item.push_back(number("file", sub.u16()));
    item.push_back(number("record", sub.u16()));
    const uint16_t length = sub.u16();
    item.push_back(number("length", length));
    if (with_data) item.push_back(registers("values", sub, length));
    list.items.push_back(std::move(item));
  }
  out.push_back(std::move(list));
}

void read_file_response(Reader& r, std::vector<Field>& out) {
  const uint8_t count = r.u8();
  out.push_back(number("byte_count", count));
  Field list = make("sub_responses", Field::Kind::items);
  Reader sub(r.take(count));
  while (sub.left() >= 2) {
    const uint8_t length = sub.u8();
    std::vector<Field> item;
    item.push_back(number("length", length));
    item.push_back(number("reference_type", sub.u8()));
    Reader data(sub.take(length > 0 ? length - 1u : 0u));
    item.push_back(registers("values", data, data.left() / 2));
    list.items.push_back(std::move(item));
  }
  out.push_back(std::move(list));
}

const char* object_name(uint8_t id) {
  switch (id) {
    case 0x00:
      return "VendorName";
    case 0x01:
      return "ProductCode";
    case 0x02:
      return "MajorMinorRevision";
    case 0x03:
      return "VendorUrl";
    case 0x04:
      return "ProductName";
    case 0x05:
      return "ModelName";
    case 0x06:
      return "UserApplicationName";
    default:
      return id < 0x80 ? "Reserved" : "Private";
  }
}

void device_identification(Role role, Reader& r, std::vector<Field>& out) {
  const uint8_t mei = r.u8();
  out.push_back(hex("mei_type", mei));
  if (mei != 0x0E) {
    out.push_back(bytes("data", r.take(r.left())));
    return;
  }
  out.push_back(number("read_device_id_code", r.u8()));
  if (role == Role::request) {
    out.push_back(number("object_id", r.u8()));
    return;
  }
  out.push_back(number("conformity_level", r.u8()));
  out.push_back(number("more_follows", r.u8()));
  out.push_back(number("next_object_id", r.u8()));
  const uint8_t objects = r.u8();
  out.push_back(number("number_of_objects", objects));
  Field list = make("objects", Field::Kind::items);
  for (unsigned i = 0; i < objects && r.left() >= 2; ++i) {
    const uint8_t id = r.u8();
    auto value = r.take(r.u8());
    list.items.push_back({number("id", id), text("name", object_name(id)),
                          text("value", std::string(value.begin(), value.end()))});
  }
  out.push_back(std::move(list));
}

void decode_request(uint8_t fc, Reader& r, std::vector<Field>& out) {
  switch (fc) {
    case 0x01:
    case 0x02:
    case 0x03:
    case 0x04:
      address_quantity(r, out);
      break;
    case 0x05: {
      out.push_back(number("address", r.u16()));
      const uint16_t v = r.u16();
      out.push_back(hex("value", v));
      out.push_back(text("state", v == 0xFF00 ? "on" : v == 0 ? "off" : "invalid"));
      break;
    }
    case 0x06:
      out.push_back(number("address", r.u16()));
      out.push_back(number("value", r.u16()));
      break;
    case 0x08:
      diagnostics(r, out);
      break;
    case 0x0F: {
      out.push_back(number("address", r.u16()));
      const uint16_t qty = r.u16();
      out.push_back(number("quantity", qty));
      const uint8_t count = r.u8();
      out.push_back(number("byte_count", count));
      out.push_back(bits("values", r.take(count), qty));
      break;
    }
    case 0x10: {
      out.push_back(number("address", r.u16()));
      const uint16_t qty = r.u16();
      out.push_back(number("quantity", qty));
      out.push_back(number("byte_count", r.u8()));
      out.push_back(registers("values", r, qty));
      break;
    }
    case 0x14:
      file_records(r, out, false);
      break;
    case 0x15:
      file_records(r, out, true);
      break;
    case 0x16:
      out.push_back(number("address", r.u16()));
      out.push_back(hex("and_mask", r.u16()));
      out.push_back(hex("or_mask", r.u16()));
      break;
    case 0x17: {
      out.push_back(number("read_address", r.u16()));
      out.push_back(number("read_quantity", r.u16()));
      out.push_back(number("write_address", r.u16()));
      const uint16_t qty = r.u16();
      out.push_back(number("write_quantity", qty));
      out.push_back(number("byte_count", r.u8()));
      out.push_back(registers("values", r, qty));
      break;
    }
    case 0x18:
      out.push_back(number("fifo_address", r.u16()));
      break;
    case 0x2B:
      device_identification(Role::request, r, out);
      break;
    case 0x07:
    case 0x0B:
    case 0x0C:
    case 0x11:
      break;
    default:
      if (r.left()) out.push_back(bytes("data", r.take(r.left())));
  }
}

void decode_response(uint8_t fc, Reader& r, std::span<const uint8_t> req, std::vector<Field>& out) {
  switch (fc) {
    case 0x01:
    case 0x02: {
      const uint8_t count = r.u8();
      out.push_back(number("byte_count", count));
      const size_t qty = req.size() >= 5 ? request_u16(req, 3) : size_t{count} * 8;
      if (uint16_t first = 0; response_start_address(req, first))
        out.push_back(number("address", first));
      out.push_back(bits("values", r.take(count), qty));
      break;
    }
    case 0x03:
    case 0x04:
    case 0x17: {
      const uint8_t count = r.u8();
      out.push_back(number("byte_count", count));
      if (uint16_t first = 0; response_start_address(req, first))
        out.push_back(number("address", first));
      out.push_back(registers("values", r, count / 2));
      break;
    }
    case 0x07:
      out.push_back(hex("status", r.u8()));
      break;
    case 0x0B:
      out.push_back(hex("status", r.u16()));
      out.push_back(number("event_count", r.u16()));
      break;
    case 0x0C: {
      const uint8_t count = r.u8();
      out.push_back(number("byte_count", count));
      out.push_back(hex("status", r.u16()));
      out.push_back(number("event_count", r.u16()));
      out.push_back(number("message_count", r.u16()));
      out.push_back(bytes("events", r.take(count >= 6 ? count - 6u : 0u)));
      break;
    }
    case 0x0F:
    case 0x10:
      address_quantity(r, out);
      break;
    case 0x11: {
      const uint8_t count = r.u8();
      out.push_back(number("byte_count", count));
      out.push_back(bytes("data", r.take(count)));
      break;
    }
    case 0x14:
      read_file_response(r, out);
      break;
    case 0x18: {
      out.push_back(number("byte_count", r.u16()));
      const uint16_t count = r.u16();
      out.push_back(number("fifo_count", count));
      out.push_back(registers("values", r, count));
      break;
    }
    case 0x2B:
      device_identification(Role::response, r, out);
      break;
    case 0x05:
    case 0x06:
    case 0x08:
    case 0x15:
    case 0x16:
      decode_request(fc, r, out);
      break;  // echoes
    default:
      if (r.left()) out.push_back(bytes("data", r.take(r.left())));
  }
}

}  // namespace

bool response_start_address(std::span<const uint8_t> req, uint16_t& address) {
  if (req.size() < 5) return false;
  switch (req[0]) {
    case 0x01:
    case 0x02:
    case 0x03:
    case 0x04:
    case 0x17:
      address = request_u16(req, 1);
      return true;
    default:
      return false;
  }
}

DecodedPdu decode_pdu(Role role, std::span<const uint8_t> pdu, std::span<const uint8_t> request) {
  DecodedPdu out;
  if (pdu.empty()) return out;
  Reader r(pdu.subspan(1));
  const uint8_t fc = pdu[0];
  if (fc & 0x80) {
    const uint8_t code = r.u8();
    out.fields.push_back(number("exception_code", code));
    if (const char* name = exception_name(code)) out.fields.push_back(text("exception_name", name));
  } else if (role == Role::response) {
    decode_response(fc, r, request, out.fields);
  } else if (role == Role::request) {
    decode_request(fc, r, out.fields);
  } else if (r.left()) {
    out.fields.push_back(bytes("data", r.take(r.left())));
  }
  out.truncated = r.short_read();
  return out;
}

}  // namespace modtap::decoder
