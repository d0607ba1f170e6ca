// The -Y filter parser and evaluator on any text. Properties: the text parses or gives a
// FilterError whose column lies within it (or just past its end); a parsed filter evaluates
// on a frame, a noise record and a time-out without failing, and `!(F)` is always F's opposite
// (for texts without a ')' of their own, which could close the wrapping parenthesis early).
#include <string>

#include "decoder/filter/display_filter.hpp"
#include "decoder/models/register_meaning.hpp"
#include "tests/fuzz/fuzz_input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace modtap;
  const std::string text(reinterpret_cast<const char*>(data), size);
  auto is_register = [](std::string_view name) { return name == "frequency_command"; };
  try {
    const DisplayFilter filter(text, is_register);
    static const uint8_t adu[] = {0x01, 0x03, 0x02, 0x17, 0x70, 0xB6, 0x50};
    static const uint8_t request[] = {0x03, 0x25, 0x02, 0x00, 0x01};
    Frame frame;
    frame.raw = frame.adu = adu;
    frame.role = Role::response;
    frame.check_ok = true;
    frame.request_pdu = request;
    frame.latency_ns = 4'000'000;
    frame.findings = finding_fast_turnaround;
    const DecodedPdu pdu = decode_pdu(frame.role, frame.pdu(), frame.request_pdu);
    Noise noise;
    noise.raw = adu;
    const Timeout timeout;
    const bool on_frame = filter.matches(frame, pdu), on_noise = filter.matches(noise),
               on_timeout = filter.matches(timeout);
    if (text.find(')') != std::string::npos) return 0;
    const DisplayFilter negated("!(" + text + ")", is_register);
    FUZZ_EXPECT(negated.matches(frame, pdu) != on_frame);
    FUZZ_EXPECT(negated.matches(noise) != on_noise);
    FUZZ_EXPECT(negated.matches(timeout) != on_timeout);
  } catch (const FilterError& e) {
    FUZZ_EXPECT(e.column() >= 1 && e.column() <= text.size() + 3);
  }
  return 0;
}
