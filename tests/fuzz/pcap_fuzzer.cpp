// pcap and pcapng input through libpcap and modtap's reader. Properties: it reads to the end or
// stops with a CaptureError naming the file; it never gives more bytes than the file holds.
#include <string>

#include "captures/pcap_reader.hpp"
#include "tests/fuzz/file_fuzzer.hpp"
#include "tests/fuzz/fuzz_input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace modtap;
  const std::string path = fuzz::write_temp_file(data, size, ".pcap");
  uint64_t bytes = 0;
  try {
    captures::PcapReader reader(path);
    decoder::Chunk chunk;
    while (reader.next(chunk)) {
      FUZZ_EXPECT(chunk.channel < reader.channels().size());
      bytes += chunk.bytes.size();
    }
  } catch (const captures::CaptureError& e) {
    FUZZ_EXPECT(std::string(e.what()).find(path) != std::string::npos);
  }
  FUZZ_EXPECT(bytes <= size);
  return 0;
}
