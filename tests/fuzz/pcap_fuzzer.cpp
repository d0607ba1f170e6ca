// pcap and pcapng (modtap's own record and block readers) as modtap opens them.
// Properties: it reads to the end or stops with a CaptureError naming the file; it never gives
// more bytes than the file holds; every chunk is on a channel the reader announced.
#include <string>

#include "captures/open_capture.hpp"
#include "tests/fuzz/file_fuzzer.hpp"
#include "tests/fuzz/fuzz_input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace modtap;
  const std::string path = fuzz::write_temp_file(data, size);
  uint64_t bytes = 0;
  try {
    captures::OpenOptions options;
    options.format = captures::Format::pcap;
    const auto reader = captures::open_capture(path, options);
    Chunk chunk;
    while (reader->next(chunk)) {
      FUZZ_EXPECT(chunk.channel < reader->channels().size());
      bytes += chunk.bytes.size();
    }
  } catch (const captures::CaptureError& e) {
    FUZZ_EXPECT(std::string(e.what()).find(path) != std::string::npos);
  }
  FUZZ_EXPECT(bytes <= size);
  return 0;
}
