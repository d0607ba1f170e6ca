#include "decoder/models/record_fields.hpp"

#include <algorithm>

namespace modtap {

// Only an exception read through a model that gives its code a meaning differs from the PDU's
// own decoding: every other frame pays nothing more.
void decode_frame(const Frame& frame, DecodedPdu& out) {
  decode_pdu(frame.role, frame.pdu(), frame.request_pdu, out);
  const std::string_view name = model_exception_meaning(frame);
  if (name.empty()) return;
  auto& fields = out.fields;
  const auto code = std::find_if(fields.begin(), fields.end(),
                                 [](const Field& f) { return f.id == FieldId::exception_code; });
  if (code == fields.end()) return;
  const auto after = std::next(code);
  if (after != fields.end() && after->id == FieldId::exception_name) {
    after->text = name;
    return;
  }
  Field named;
  named.id = FieldId::exception_name;
  named.text = name;
  fields.insert(after, named);
}

}  // namespace modtap
