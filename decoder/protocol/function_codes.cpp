#include "decoder/protocol/function_codes.hpp"

#include <algorithm>
#include <array>
#include <string>

#include <fmt/format.h>

namespace modtap {
namespace {

using L = BodyLength;
using F = FieldId;
using Bytes = std::span<const uint8_t>;

constexpr bool in_range(unsigned v, unsigned lo, unsigned hi) {
  return v >= lo && v <= hi;
}

// ---- Lengths: `p` starts at the slave address -------------------------------------------

template <unsigned n>
L fixed(Bytes) {
  return L::known(n);
}

L searched(Bytes) {
  return L::variable(2);
}

// A length carried in a byte count at `at`: body = at + 1 + count.
L counted(Bytes p, size_t at, unsigned lo = 0, unsigned hi = 252) {
  if (p.size() <= at) return L::need_more();
  const unsigned count = p[at];
  if (!in_range(count, lo, hi)) return L::invalid();
  return L::known(at + 1 + count);
}

template <size_t at, unsigned lo = 0, unsigned hi = 252>
L counted_at(Bytes p) {
  return counted(p, at, lo, hi);
}

// FC03/04: a byte count of whole registers.
L register_count(Bytes p) {
  const L l = counted(p, 2, 2, 250);
  return (l.kind == L::Kind::known && p[2] % 2 != 0) ? L::invalid() : l;
}

// FC08: Return Query Data echoes data of any length; every other sub-function carries 2 bytes.
L diagnostics_length(Bytes p) {
  if (p.size() < 4) return L::need_more();
  return be16(p, 2) == 0x0000 ? L::public_variable(4) : L::known(6);
}

L fifo_length(Bytes p) {
  if (p.size() < 4) return L::need_more();
  const unsigned count = be16(p, 2);
  if (!in_range(count, 2, 64)) return L::invalid();
  return L::known(4 + count);
}

// FC2B: Read Device Identification (MEI 0E) has a structure; CANopen General Reference (MEI
// 0D) carries data of any length, and other MEI types are reserved.
L mei_other_length(Bytes p) {
  return p[2] == 0x0D ? L::public_variable(3) : L::variable(3);
}

L mei_request_length(Bytes p) {
  if (p.size() < 3) return L::need_more();
  return p[2] == 0x0E ? L::known(5) : mei_other_length(p);
}

// FC2B/0E response: a header of 8 bytes, then objects {id, length, value}.
L mei_response_length(Bytes p) {
  if (p.size() < 3) return L::need_more();
  if (p[2] != 0x0E) return mei_other_length(p);
  if (p.size() < 8) return L::need_more();
  size_t at = 8;
  for (unsigned objects = p[7]; objects > 0; --objects) {
    if (p.size() < at + 2) return L::need_more();
    at += 2 + p[at + 1];
    if (at > max_rtu_adu - 2) return L::invalid();
  }
  return L::known(at);
}

// ---- Limits a request may break (Modbus Application Protocol V1.1b3, 6.x) -----------------

uint32_t within_spec(Bytes) {
  return finding_none;
}

// A quantity at `quantity_at` of 1..max; with `count_at`, a byte count that must match it.
template <size_t quantity_at, unsigned max, size_t count_at = 0, unsigned bits_per_item = 16>
uint32_t quantity_limits(Bytes pdu) {
  if (pdu.size() < quantity_at + 2) return finding_none;
  const unsigned quantity = be16(pdu, quantity_at);
  uint32_t found = in_range(quantity, 1, max) ? finding_none : finding_quantity_out_of_spec;
  if (count_at && pdu.size() > count_at && pdu[count_at] != (quantity * bits_per_item + 7) / 8)
    found |= finding_byte_count_mismatch;
  return found;
}

uint32_t coil_value_limits(Bytes pdu) {
  const uint16_t v = be16(pdu, 3);
  return pdu.size() >= 5 && v != 0xFF00 && v != 0x0000 ? finding_value_out_of_spec : finding_none;
}

// FC08: each sub-function but Return Query Data says what its request's data is (Application
// Protocol 6.8.1): 0000 for the counters and most others, FF00 too to restart, a character and
// 00 to change the ASCII delimiter. A sub-function the standard does not name has no rule.
uint32_t diagnostics_limits(Bytes pdu) {
  if (pdu.size() != 5) return finding_none;
  const uint16_t sub = be16(pdu, 1), data = be16(pdu, 3);
  bool in_spec = true;
  if (sub == 0x01)
    in_spec = data == 0x0000 || data == 0xFF00;
  else if (sub == 0x03)
    in_spec = (data & 0xFF) == 0;
  else if (sub == 0x02 || sub == 0x04 || (sub >= 0x0A && sub <= 0x14 && sub != 0x13))
    in_spec = data == 0x0000;
  return in_spec ? finding_none : finding_value_out_of_spec;
}

// FC17: the write quantity and its byte count, and the read quantity like FC03's.
uint32_t read_write_limits(Bytes pdu) {
  uint32_t found = quantity_limits<7, 121, 9>(pdu);
  if (pdu.size() >= 5 && !in_range(be16(pdu, 3), 1, 125)) found |= finding_quantity_out_of_spec;
  return found;
}

// ---- Whether a response fits its request -------------------------------------------------

Finding fits_anything(Bytes, Bytes) {
  return finding_none;
}

Finding byte_count_is(Bytes rsp, unsigned expected) {
  return rsp.size() >= 2 && rsp[1] == expected && rsp.size() == 2u + expected
             ? finding_none
             : finding_length_mismatch;
}

Finding bit_count_fits(Bytes req, Bytes rsp) {
  return byte_count_is(rsp, (be16(req, 3) + 7u) / 8u);
}

Finding register_count_fits(Bytes req, Bytes rsp) {
  return byte_count_is(rsp, be16(req, 3) * 2u);
}

Finding echoes_whole(Bytes req, Bytes rsp) {
  return std::equal(req.begin(), req.end(), rsp.begin(), rsp.end()) ? finding_none
                                                                    : finding_echo_mismatch;
}

template <size_t n>
Finding echoes_first(Bytes req, Bytes rsp) {
  return req.size() >= n && rsp.size() >= n && std::equal(req.begin(), req.begin() + n, rsp.begin())
             ? finding_none
             : finding_echo_mismatch;
}

// Return Query Data echoes everything; the counters return their value instead.
Finding diagnostics_fit(Bytes req, Bytes rsp) {
  return be16(req, 1) == 0 ? echoes_whole(req, rsp) : echoes_first<3>(req, rsp);
}

// FC14: one sub-response to each sub-request, in order, of the records it asked for
// (Application Protocol 6.14): its length byte counts the reference type 6 and 2 bytes a
// register. Another slave's or request's records are no answer to it.
Finding file_read_fits(Bytes req, Bytes rsp) {
  PduReader asked(req.subspan(std::min<size_t>(req.size(), 2)));
  PduReader got(rsp.subspan(std::min<size_t>(rsp.size(), 2)));
  if (rsp.size() < 2 || rsp[1] != rsp.size() - 2) return finding_length_mismatch;
  while (asked.left() >= 7 && got.left() >= 2) {
    asked.take(5);  // reference type, file, record
    const unsigned registers = asked.u16();
    if (got.u8() != 1 + 2 * registers || got.u8() != 6 ||
        got.take(2 * registers).size() != 2 * registers)
      return finding_length_mismatch;
  }
  return asked.left() == 0 && got.left() == 0 ? finding_none : finding_length_mismatch;
}

// ---- What a response starts with, told by its request --------------------------------------

ResponsePrefix prefix_of(Bytes bytes) {
  ResponsePrefix prefix;
  prefix.size = static_cast<uint8_t>(std::min(bytes.size(), prefix.pdu.size()));
  std::copy_n(bytes.begin(), prefix.size, prefix.pdu.begin());
  return prefix;
}

ResponsePrefix code_only(Bytes req) {
  return prefix_of(req.first(1));
}

template <size_t n>
ResponsePrefix echo_prefix(Bytes req) {
  return prefix_of(req.first(std::min(n, req.size())));
}

ResponsePrefix whole_echo_prefix(Bytes req) {
  ResponsePrefix prefix = prefix_of(req);
  prefix.echoes_request = true;
  return prefix;
}

// The byte count a read's response carries, from the quantity at PDU offset `at`.
template <size_t at, unsigned bits_per_item>
ResponsePrefix byte_count_prefix(Bytes req) {
  if (req.size() < at + 2) return code_only(req);
  const unsigned count = (be16(req, at) * bits_per_item + 7u) / 8u;
  if (count == 0 || count > 250) return code_only(req);
  const uint8_t bytes[2] = {req[0], static_cast<uint8_t>(count)};
  return prefix_of(bytes);
}

ResponsePrefix diagnostics_prefix(Bytes req) {
  return req.size() >= 3 && be16(req, 1) == 0 ? whole_echo_prefix(req) : echo_prefix<3>(req);
}

// ---- Fields ------------------------------------------------------------------------------

void no_fields(PduReader&, FieldWriter&) {}

void data_fields(PduReader& r, FieldWriter& out) {
  if (r.left()) out.bytes(F::data, r.rest());
}

void unknown_response(PduReader& r, Bytes, FieldWriter& out) {
  data_fields(r, out);
}

// The address a read response's values start at, from its request (FC01-04, 17).
std::optional<uint16_t> read_start(Bytes req) {
  if (req.size() < 5 || !(in_range(req[0], 0x01, 0x04) || req[0] == 0x17)) return std::nullopt;
  return be16(req, 1);
}

void address_quantity(PduReader& r, FieldWriter& out) {
  out.number(F::address, r.u16());
  out.number(F::quantity, r.u16());
}

void bits_read(PduReader& r, Bytes req, FieldWriter& out) {
  const uint8_t count = r.u8();
  out.number(F::byte_count, count);
  const size_t quantity = req.size() >= 5 ? be16(req, 3) : size_t{count} * 8;
  if (const auto start = read_start(req)) out.number(F::address, *start);
  out.bits(F::bit_values, r.take(count), quantity);
}

void registers_read(PduReader& r, Bytes req, FieldWriter& out) {
  const uint8_t count = r.u8();
  out.number(F::byte_count, count);
  if (const auto start = read_start(req)) out.number(F::address, *start);
  out.registers(F::register_values, r, count / 2);
}

void coil_write(PduReader& r, FieldWriter& out) {
  out.number(F::address, r.u16());
  const uint16_t v = r.u16();
  out.number(F::coil_value, v);
  out.name(F::state, v == 0xFF00 ? "on" : v == 0 ? "off" : "invalid");
}

void register_write(PduReader& r, FieldWriter& out) {
  out.number(F::address, r.u16());
  out.number(F::value, r.u16());
}

void diagnostics(PduReader& r, FieldWriter& out) {
  const uint16_t sub = r.u16();
  out.number(F::sub_function, sub);
  if (const auto name = diagnostic_name(sub); !name.empty()) out.name(F::sub_function_name, name);
  out.bytes(F::data, r.rest());
}

void exception_status(PduReader& r, Bytes, FieldWriter& out) {
  out.number(F::status, r.u8());
}

void event_counter(PduReader& r, Bytes, FieldWriter& out) {
  out.number(F::status, r.u16());
  out.number(F::event_count, r.u16());
}

void event_log(PduReader& r, Bytes, FieldWriter& out) {
  const uint8_t count = r.u8();
  out.number(F::byte_count, count);
  out.number(F::status, r.u16());
  out.number(F::event_count, r.u16());
  out.number(F::message_count, r.u16());
  out.bytes(F::events, r.take(count >= 6 ? count - 6u : 0u));
}

void coils_write(PduReader& r, FieldWriter& out) {
  out.number(F::address, r.u16());
  const uint16_t quantity = r.u16();
  out.number(F::quantity, quantity);
  const uint8_t count = r.u8();
  out.number(F::byte_count, count);
  out.bits(F::bit_values, r.take(count), quantity);
}

void registers_write(PduReader& r, FieldWriter& out) {
  out.number(F::address, r.u16());
  const uint16_t quantity = r.u16();
  out.number(F::quantity, quantity);
  out.number(F::byte_count, r.u8());
  out.registers(F::register_values, r, quantity);
}

void server_id(PduReader& r, Bytes, FieldWriter& out) {
  const uint8_t count = r.u8();
  out.number(F::byte_count, count);
  out.bytes(F::data, r.take(count));
}

// FC14 and FC15 requests: sub-requests {reference type, file, record, length[, values]}.
template <bool with_values>
void file_records(PduReader& r, FieldWriter& out) {
  const uint8_t count = r.u8();
  out.number(F::byte_count, count);
  out.begin_list(F::sub_requests);
  PduReader sub = r.sub(count);
  while (sub.left() >= 7) {
    out.begin_item();
    out.number(F::reference_type, sub.u8());
    out.number(F::file, sub.u16());
    out.number(F::record, sub.u16());
    const uint16_t length = sub.u16();
    out.number(F::length, length);
    if (with_values) out.registers(F::record_values, sub, length);
  }
  out.end_list();
}

void file_read(PduReader& r, Bytes, FieldWriter& out) {
  const uint8_t count = r.u8();
  out.number(F::byte_count, count);
  out.begin_list(F::sub_responses);
  PduReader sub = r.sub(count);
  while (sub.left() >= 2) {
    const uint8_t length = sub.u8();
    out.begin_item();
    out.number(F::length, length);
    out.number(F::reference_type, sub.u8());
    PduReader data = sub.sub(length > 0 ? length - 1u : 0u);
    out.registers(F::record_values, data, data.left() / 2);
  }
  out.end_list();
}

void mask_write(PduReader& r, FieldWriter& out) {
  out.number(F::address, r.u16());
  out.number(F::and_mask, r.u16());
  out.number(F::or_mask, r.u16());
}

void read_write_request(PduReader& r, FieldWriter& out) {
  out.number(F::read_address, r.u16());
  out.number(F::read_quantity, r.u16());
  out.number(F::write_address, r.u16());
  const uint16_t quantity = r.u16();
  out.number(F::write_quantity, quantity);
  out.number(F::byte_count, r.u8());
  out.registers(F::register_values, r, quantity);
}

void fifo_request(PduReader& r, FieldWriter& out) {
  out.number(F::fifo_address, r.u16());
}

void fifo_response(PduReader& r, Bytes, FieldWriter& out) {
  out.number(F::byte_count, r.u16());
  const uint16_t count = r.u16();
  out.number(F::fifo_count, count);
  out.registers(F::register_values, r, count);
}

std::string_view object_name(uint8_t id) {
  static constexpr std::string_view basic[] = {
      "VendorName",  "ProductCode", "MajorMinorRevision", "VendorUrl",
      "ProductName", "ModelName",   "UserApplicationName"};
  if (id < std::size(basic)) return basic[id];
  return id < 0x80 ? "Reserved" : "Private";
}

// The MEI type; for Read Device Identification (0E) its code, then the header and objects.
bool mei_header(PduReader& r, FieldWriter& out) {
  const uint8_t mei = r.u8();
  out.number(F::mei_type, mei);
  if (mei != 0x0E) {
    out.bytes(F::data, r.rest());
    return false;
  }
  out.number(F::read_device_id_code, r.u8());
  return true;
}

void mei_request(PduReader& r, FieldWriter& out) {
  if (mei_header(r, out)) out.number(F::object_id, r.u8());
}

void mei_response(PduReader& r, Bytes, FieldWriter& out) {
  if (!mei_header(r, out)) return;
  out.number(F::conformity_level, r.u8());
  out.number(F::more_follows, r.u8());
  out.number(F::next_object_id, r.u8());
  const uint8_t objects = r.u8();
  out.number(F::number_of_objects, objects);
  out.begin_list(F::objects);
  for (unsigned i = 0; i < objects && r.left() >= 2; ++i) {
    const uint8_t id = r.u8();
    const auto value = r.take(r.u8());
    out.begin_item();
    out.number(F::object_number, id);
    out.name(F::object_name, object_name(id));
    out.bytes(F::object_value, value);
  }
  out.end_list();
}

// An echo's response reads as its request does.
template <void (*request)(PduReader&, FieldWriter&)>
void echo(PduReader& r, Bytes, FieldWriter& out) {
  request(r, out);
}

// ---- Registers read and written ----------------------------------------------------------

using A = RegisterAccess;

A read_of(Table table, uint16_t start, uint16_t count) {
  return {table, start, count, false, A::Data::none, {}};
}

RegisterAccesses no_access(Bytes) {
  return {};
}

template <Table table>
RegisterAccesses reads(Bytes pdu) {
  if (pdu.size() < 5) return {};
  return {{read_of(table, be16(pdu, 1), be16(pdu, 3))}, 1};
}

RegisterAccesses coil_write_access(Bytes pdu) {
  if (pdu.size() < 5) return {};
  return {{A{Table::coil, be16(pdu, 1), 1, true, A::Data::coil_state, pdu.subspan(3, 2)}}, 1};
}

RegisterAccesses register_write_access(Bytes pdu) {
  if (pdu.size() < 5) return {};
  return {{A{Table::holding, be16(pdu, 1), 1, true, A::Data::words, pdu.subspan(3, 2)}}, 1};
}

RegisterAccesses coils_write_access(Bytes pdu) {
  if (pdu.size() < 5) return {};
  return {{A{Table::coil, be16(pdu, 1), be16(pdu, 3), true, A::Data::bits, bytes_from(pdu, 6)}}, 1};
}

RegisterAccesses registers_write_access(Bytes pdu) {
  if (pdu.size() < 5) return {};
  return {{A{Table::holding, be16(pdu, 1), be16(pdu, 3), true, A::Data::words, bytes_from(pdu, 6)}},
          1};
}

// The value a mask write leaves depends on the register's old one: only the address is known.
RegisterAccesses mask_write_access(Bytes pdu) {
  if (pdu.size() < 5) return {};
  return {{A{Table::holding, be16(pdu, 1), 1, true, A::Data::none, {}}}, 1};
}

RegisterAccesses read_write_access(Bytes pdu) {
  if (pdu.size() < 5) return {};
  return {
      {read_of(Table::holding, be16(pdu, 1), be16(pdu, 3)),
       A{Table::holding, be16(pdu, 5), be16(pdu, 7), true, A::Data::words, bytes_from(pdu, 10)}},
      2};
}

std::optional<A> no_values(Bytes, Bytes) {
  return std::nullopt;
}

// The data after a response's byte count, as far as the count and the PDU both go.
Bytes counted_data(Bytes pdu) {
  return pdu.subspan(2, std::min<size_t>(pdu[1], pdu.size() - 2));
}

template <Table table>
std::optional<A> bits_read_values(Bytes pdu, Bytes req) {
  const auto start = read_start(req);
  if (pdu.size() < 2 || !start) return std::nullopt;
  return A{table, *start, be16(req, 3), false, A::Data::bits, counted_data(pdu)};
}

template <Table table>
std::optional<A> registers_read_values(Bytes pdu, Bytes req) {
  const auto start = read_start(req);
  if (pdu.size() < 2 || !start) return std::nullopt;
  const Bytes data = counted_data(pdu);
  return A{table, *start, static_cast<uint16_t>(data.size() / 2), false, A::Data::words, data};
}

// An echo tells what was written.
template <RegisterAccesses (*written)(Bytes)>
std::optional<A> echoed_values(Bytes pdu, Bytes) {
  const RegisterAccesses accesses = written(pdu);
  if (accesses.size == 0) return std::nullopt;
  return accesses.list[0];
}

// ---- The table ---------------------------------------------------------------------------

using Row = FunctionCode;

constexpr std::array public_codes{
    Row{.code = 0x01,
        .name = "Read Coils",
        .broadcast = false,
        .request_length = fixed<6>,
        .response_length = counted_at<2, 1, 250>,
        .request_findings = quantity_limits<3, 2000>,
        .response_fit = bit_count_fits,
        .request_fields = address_quantity,
        .response_fields = bits_read,
        .request_accesses = reads<Table::coil>,
        .response_values = bits_read_values<Table::coil>,
        .response_prefix = byte_count_prefix<3, 1>},
    Row{.code = 0x02,
        .name = "Read Discrete Inputs",
        .broadcast = false,
        .request_length = fixed<6>,
        .response_length = counted_at<2, 1, 250>,
        .request_findings = quantity_limits<3, 2000>,
        .response_fit = bit_count_fits,
        .request_fields = address_quantity,
        .response_fields = bits_read,
        .request_accesses = reads<Table::discrete>,
        .response_values = bits_read_values<Table::discrete>,
        .response_prefix = byte_count_prefix<3, 1>},
    Row{.code = 0x03,
        .name = "Read Holding Registers",
        .broadcast = false,
        .request_length = fixed<6>,
        .response_length = register_count,
        .request_findings = quantity_limits<3, 125>,
        .response_fit = register_count_fits,
        .request_fields = address_quantity,
        .response_fields = registers_read,
        .request_accesses = reads<Table::holding>,
        .response_values = registers_read_values<Table::holding>,
        .response_prefix = byte_count_prefix<3, 16>},
    Row{.code = 0x04,
        .name = "Read Input Registers",
        .broadcast = false,
        .request_length = fixed<6>,
        .response_length = register_count,
        .request_findings = quantity_limits<3, 125>,
        .response_fit = register_count_fits,
        .request_fields = address_quantity,
        .response_fields = registers_read,
        .request_accesses = reads<Table::input>,
        .response_values = registers_read_values<Table::input>,
        .response_prefix = byte_count_prefix<3, 16>},
    Row{.code = 0x05,
        .name = "Write Single Coil",
        .broadcast = true,
        .request_length = fixed<6>,
        .response_length = fixed<6>,
        .request_findings = coil_value_limits,
        .response_fit = echoes_whole,
        .request_fields = coil_write,
        .response_fields = echo<coil_write>,
        .request_accesses = coil_write_access,
        .response_values = echoed_values<coil_write_access>,
        .response_prefix = whole_echo_prefix},
    Row{.code = 0x06,
        .name = "Write Single Register",
        .broadcast = true,
        .request_length = fixed<6>,
        .response_length = fixed<6>,
        .request_findings = within_spec,
        .response_fit = echoes_whole,
        .request_fields = register_write,
        .response_fields = echo<register_write>,
        .request_accesses = register_write_access,
        .response_values = echoed_values<register_write_access>,
        .response_prefix = whole_echo_prefix},
    Row{.code = 0x07,
        .name = "Read Exception Status",
        .broadcast = false,
        .request_length = fixed<2>,
        .response_length = fixed<3>,
        .request_findings = within_spec,
        .response_fit = fits_anything,
        .request_fields = no_fields,
        .response_fields = exception_status,
        .request_accesses = no_access,
        .response_values = no_values,
        .response_prefix = code_only},
    Row{.code = 0x08,
        .name = "Diagnostics",
        .broadcast = true,
        .request_length = diagnostics_length,
        .response_length = diagnostics_length,
        .request_findings = diagnostics_limits,
        .response_fit = diagnostics_fit,
        .request_fields = diagnostics,
        .response_fields = echo<diagnostics>,
        .request_accesses = no_access,
        .response_values = no_values,
        .response_prefix = diagnostics_prefix},
    Row{.code = 0x0B,
        .name = "Get Comm Event Counter",
        .broadcast = false,
        .request_length = fixed<2>,
        .response_length = fixed<6>,
        .request_findings = within_spec,
        .response_fit = fits_anything,
        .request_fields = no_fields,
        .response_fields = event_counter,
        .request_accesses = no_access,
        .response_values = no_values,
        .response_prefix = code_only},
    Row{.code = 0x0C,
        .name = "Get Comm Event Log",
        .broadcast = false,
        .request_length = fixed<2>,
        .response_length = counted_at<2, 1>,
        .request_findings = within_spec,
        .response_fit = fits_anything,
        .request_fields = no_fields,
        .response_fields = event_log,
        .request_accesses = no_access,
        .response_values = no_values,
        .response_prefix = code_only},
    Row{.code = 0x0F,
        .name = "Write Multiple Coils",
        .broadcast = true,
        .request_length = counted_at<6, 1>,
        .response_length = fixed<6>,
        .request_findings = quantity_limits<3, 1968, 5, 1>,
        .response_fit = echoes_first<5>,
        .request_fields = coils_write,
        .response_fields = echo<address_quantity>,
        .request_accesses = coils_write_access,
        .response_values = no_values,
        .response_prefix = echo_prefix<5>},
    Row{.code = 0x10,
        .name = "Write Multiple Registers",
        .broadcast = true,
        .request_length = counted_at<6, 1>,
        .response_length = fixed<6>,
        .request_findings = quantity_limits<3, 123, 5>,
        .response_fit = echoes_first<5>,
        .request_fields = registers_write,
        .response_fields = echo<address_quantity>,
        .request_accesses = registers_write_access,
        .response_values = no_values,
        .response_prefix = echo_prefix<5>},
    Row{.code = 0x11,
        .name = "Report Server ID",
        .broadcast = false,
        .request_length = fixed<2>,
        .response_length = counted_at<2, 1>,
        .request_findings = within_spec,
        .response_fit = fits_anything,
        .request_fields = no_fields,
        .response_fields = server_id,
        .request_accesses = no_access,
        .response_values = no_values,
        .response_prefix = code_only},
    Row{.code = 0x14,
        .name = "Read File Record",
        .broadcast = false,
        .request_length = counted_at<2, 7, 245>,
        .response_length = counted_at<2, 1>,
        .request_findings = within_spec,
        .response_fit = file_read_fits,
        .request_fields = file_records<false>,
        .response_fields = file_read,
        .request_accesses = no_access,
        .response_values = no_values,
        .response_prefix = code_only},
    Row{.code = 0x15,
        .name = "Write File Record",
        .broadcast = true,
        .request_length = counted_at<2, 7, 245>,
        .response_length = counted_at<2, 1>,
        .request_findings = within_spec,
        .response_fit = echoes_whole,
        .request_fields = file_records<true>,
        .response_fields = echo<file_records<true>>,
        .request_accesses = no_access,
        .response_values = no_values,
        .response_prefix = whole_echo_prefix},
    Row{.code = 0x16,
        .name = "Mask Write Register",
        .broadcast = true,
        .request_length = fixed<8>,
        .response_length = fixed<8>,
        .request_findings = within_spec,
        .response_fit = echoes_whole,
        .request_fields = mask_write,
        .response_fields = echo<mask_write>,
        .request_accesses = mask_write_access,
        .response_values = no_values,
        .response_prefix = whole_echo_prefix},
    Row{.code = 0x17,
        .name = "Read/Write Multiple Registers",
        .broadcast = false,
        .request_length = counted_at<10, 1>,
        .response_length = counted_at<2, 1>,
        .request_findings = read_write_limits,
        .response_fit = register_count_fits,
        .request_fields = read_write_request,
        .response_fields = registers_read,
        .request_accesses = read_write_access,
        .response_values = registers_read_values<Table::holding>,
        .response_prefix = byte_count_prefix<3, 16>},
    Row{.code = 0x18,
        .name = "Read FIFO Queue",
        .broadcast = false,
        .request_length = fixed<4>,
        .response_length = fifo_length,
        .request_findings = within_spec,
        .response_fit = fits_anything,
        .request_fields = fifo_request,
        .response_fields = fifo_response,
        .request_accesses = no_access,
        .response_values = no_values,
        .response_prefix = code_only},
    Row{.code = 0x2B,
        .name = "Encapsulated Interface Transport",
        .broadcast = false,
        .request_length = mei_request_length,
        .response_length = mei_response_length,
        .request_findings = within_spec,
        .response_fit = echoes_first<2>,
        .request_fields = mei_request,
        .response_fields = mei_response,
        .request_accesses = no_access,
        .response_values = no_values,
        .response_prefix = echo_prefix<2>},
};

// A code the standard does not define: its length only the CRC can tell.
constexpr Row unknown_code{.code = 0x00,
                           .name = "",
                           .broadcast = true,
                           .request_length = searched,
                           .response_length = searched,
                           .request_findings = within_spec,
                           .response_fit = fits_anything,
                           .request_fields = data_fields,
                           .response_fields = unknown_response,
                           .request_accesses = no_access,
                           .response_values = no_values,
                           .response_prefix = code_only};

// Row by code, so a lookup is one load.
constexpr std::array<const Row*, 128> rows_by_code = [] {
  std::array<const Row*, 128> rows{};
  for (const Row& row : public_codes) rows[row.code] = &row;
  return rows;
}();

}  // namespace

const FunctionCode& function_code(uint8_t fc) {
  const Row* row = rows_by_code[fc & 0x7F];
  return row ? *row : unknown_code;
}

std::span<const FunctionCode> public_function_codes() {
  return public_codes;
}

BodyLength body_length(Role role, std::span<const uint8_t> p) {
  if (p.size() < 2) return BodyLength::need_more();
  const uint8_t fc = p[1];
  if (fc & 0x80) {  // the exception bit: only responses carry it, never to slave 0
    return role == Role::response && p[0] != 0 ? L::known(3) : L::invalid();
  }
  const FunctionCode& row = function_code(fc);
  return role == Role::request ? row.request_length(p) : row.response_length(p);
}

uint32_t request_spec_findings(std::span<const uint8_t> pdu) {
  return pdu.empty() ? finding_none : function_code(pdu[0]).request_findings(pdu);
}

ResponsePrefix response_prefix(std::span<const uint8_t> req) {
  return req.empty() ? ResponsePrefix{} : function_code(req[0]).response_prefix(req);
}

Finding check_response_fit(std::span<const uint8_t> req, std::span<const uint8_t> rsp) {
  if (req.empty() || rsp.empty() || (rsp[0] & 0x80)) return finding_none;
  return function_code(rsp[0]).response_fit(req, rsp);
}

void decode_pdu(Role role, std::span<const uint8_t> pdu, std::span<const uint8_t> request,
                DecodedPdu& out) {
  out.fields.clear();
  out.truncated = false;
  if (pdu.empty()) return;
  bool overran = false;
  PduReader r(pdu.subspan(1), &overran);
  FieldWriter fields(out, overran);
  const uint8_t fc = pdu[0];
  if (fc & 0x80) {
    const uint8_t code = r.u8();
    fields.number(F::exception_code, code);
    if (const auto name = exception_name(code); !name.empty()) fields.name(F::exception_name, name);
  } else if (role == Role::response) {
    function_code(fc).response_fields(r, request, fields);
  } else if (role == Role::request) {
    function_code(fc).request_fields(r, fields);
  } else {
    data_fields(r, fields);
  }
  out.truncated = r.short_read() || overran;
}

DecodedPdu decode_pdu(Role role, std::span<const uint8_t> pdu, std::span<const uint8_t> request) {
  DecodedPdu out;
  decode_pdu(role, pdu, request, out);
  return out;
}

std::string_view exception_name(uint8_t code) {
  switch (code) {
    case 0x01:
      return "Illegal Function";
    case 0x02:
      return "Illegal Data Address";
    case 0x03:
      return "Illegal Data Value";
    case 0x04:
      return "Server Device Failure";
    case 0x05:
      return "Acknowledge";
    case 0x06:
      return "Server Device Busy";
    case 0x07:
      return "Negative Acknowledge";
    case 0x08:
      return "Memory Parity Error";
    case 0x0A:
      return "Gateway Path Unavailable";
    case 0x0B:
      return "Gateway Target Device Failed to Respond";
    default:
      return {};
  }
}

std::string_view diagnostic_name(uint16_t sub) {
  switch (sub) {
    case 0x00:
      return "Return Query Data";
    case 0x01:
      return "Restart Communications Option";
    case 0x02:
      return "Return Diagnostic Register";
    case 0x03:
      return "Change ASCII Input Delimiter";
    case 0x04:
      return "Force Listen Only Mode";
    case 0x0A:
      return "Clear Counters and Diagnostic Register";
    case 0x0B:
      return "Return Bus Message Count";
    case 0x0C:
      return "Return Bus Communication Error Count";
    case 0x0D:
      return "Return Bus Exception Error Count";
    case 0x0E:
      return "Return Server Message Count";
    case 0x0F:
      return "Return Server No Response Count";
    case 0x10:
      return "Return Server NAK Count";
    case 0x11:
      return "Return Server Busy Count";
    case 0x12:
      return "Return Bus Character Overrun Count";
    case 0x14:
      return "Clear Overrun Counter and Flag";
    default:
      return {};
  }
}

std::string_view function_label(uint8_t fc) {
  static const std::array<std::string, 256> labels = [] {
    std::array<std::string, 256> made;
    for (size_t code = 0; code < made.size(); ++code) {
      const std::string_view name = function_name(static_cast<uint8_t>(code));
      made[code] = name.empty() ? fmt::format("Function 0x{:02X}", code & 0x7F) : std::string(name);
    }
    return made;
  }();
  return labels[fc];
}

uint16_t told_answer_size(uint8_t slave, std::span<const uint8_t> request_pdu) {
  const ResponsePrefix prefix = response_prefix(request_pdu);
  std::array<uint8_t, 1 + sizeof(prefix.pdu)> head{slave};
  std::copy_n(prefix.pdu.begin(), prefix.size, head.begin() + 1);
  const BodyLength body = body_length(Role::response, {head.data(), prefix.size + 1u});
  return body.kind == BodyLength::Kind::known ? body.bytes : 0;
}

}  // namespace modtap
