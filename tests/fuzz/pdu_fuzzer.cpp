// The field decoder and every built-in model's reading of any PDU, as a request or as a
// response to any request. Properties: no crash, and a register's value text renders.
#include <fmt/format.h>

#include "decoder/models/register_meaning.hpp"
#include "decoder/protocol/pdu_fields.hpp"
#include "tests/fuzz/fuzz_input.hpp"
#include "tools/modtap/model_catalog.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace modtap;
  static const tools::ModelCatalog catalog = [] {
    tools::ModelCatalog c;
    c.load_builtin();
    return c;
  }();
  fuzz::FuzzInput in(data, size);
  const uint8_t setup = in.byte();
  const Role role = setup & 1 ? Role::response : Role::request;
  const Mode mode = setup & 2 ? Mode::ascii : Mode::rtu;
  const auto request_pdu = in.take(in.byte() % 64);
  const auto pdu = in.rest();

  const DecodedPdu decoded = decode_pdu(role, pdu, role == Role::response ? request_pdu : pdu);
  // Every field's values lie inside the PDU, and a list's items follow it.
  for (size_t at = 0; at < decoded.fields.size(); ++at) {
    const Field& field = decoded.fields[at];
    FUZZ_EXPECT(field.bytes.empty() ||
                (field.bytes.data() >= pdu.data() &&
                 field.bytes.data() + field.bytes.size() <= pdu.data() + pdu.size()));
    FUZZ_EXPECT(field.type() != FieldType::registers || field.bytes.size() == 2u * field.count);
    FUZZ_EXPECT(field.type() != FieldType::bits || field.count <= 8 * field.bytes.size());
    FUZZ_EXPECT(field.item == 0 || at > 0);
  }

  // The same PDU in a frame: slave (from setup) + PDU + a check the model does not look at.
  std::vector<uint8_t> adu{static_cast<uint8_t>(setup >> 2)};
  adu.insert(adu.end(), pdu.begin(), pdu.end());
  adu.insert(adu.end(), mode == Mode::rtu ? 2u : 1u, 0);
  Frame frame;
  frame.mode = mode;
  frame.role = role;
  frame.raw = frame.adu = adu;
  frame.check_ok = true;
  frame.retries = setup & 0x80 ? 3 : 0;
  if (role == Role::response) frame.request_pdu = request_pdu;
  fmt::memory_buffer text;
  for (const DeviceModel* model : catalog.all()) {
    const Meaning meaning = interpret(*model, frame);
    for (const RegisterValue& reg : meaning.registers) append_value_text(text, reg);
    for (const RuleFinding& finding : meaning.findings) FUZZ_EXPECT(!finding.text.empty());
    text.clear();
  }
  return 0;
}
