// The timed hex log reader (jpnevulator's format) on any text. Properties: it reads to the end
// or stops with a CaptureError naming the file; it never gives more bytes than the text holds.
#include <string>

#include "captures/hexlog_reader.hpp"
#include "tests/fuzz/file_fuzzer.hpp"
#include "tests/fuzz/fuzz_input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace modtap;
  const std::string path = fuzz::write_temp_file(data, size);
  uint64_t bytes = 0;
  try {
    captures::HexlogReader reader(path, 1'000'000);
    Chunk chunk;
    while (reader.next(chunk)) {
      FUZZ_EXPECT(chunk.channel < reader.channels().size() || reader.channels().empty());
      bytes += chunk.bytes.size();
    }
  } catch (const captures::CaptureError& e) {
    FUZZ_EXPECT(std::string(e.what()).find(path) != std::string::npos);
  }
  FUZZ_EXPECT(bytes * 2 <= size);  // two hex digits a byte at least
  return 0;
}
