// What modtap reads of sigrok-cli's output: the --show summary and the UART decoder's lines.
// Properties: a shape has a sample rate or the error names the capture; a parsed byte line
// reads back the same when written as sigrok-cli writes it.
#include <string>

#include <fmt/format.h>

#include "captures/sigrok_reader.hpp"
#include "tests/fuzz/fuzz_input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace modtap::captures;
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const SigrokShape shape = parse_sigrok_show(text, "capture.sr");
    FUZZ_EXPECT(shape.samplerate > 0);
  } catch (const CaptureError& e) {
    FUZZ_EXPECT(std::string(e.what()).find("capture.sr") != std::string::npos);
  }
  // The reader hands lines of at most 255 characters, NUL-terminated.
  const std::string line = text.substr(0, std::min<size_t>(text.find('\0'), 255));
  if (const auto byte = parse_sigrok_byte(line.c_str())) {
    const std::string again =
        fmt::format("{}-{} uart-1: {:02X}", byte->sample, byte->sample + 9, byte->value);
    const auto reread = parse_sigrok_byte(again.c_str());
    FUZZ_EXPECT(reread && reread->sample == byte->sample && reread->value == byte->value);
  }
  return 0;
}
