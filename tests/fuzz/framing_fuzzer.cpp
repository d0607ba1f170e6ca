// The RTU or ASCII framer behind the whole analyzer, fed in random chunks at random times on
// one or two channels. Properties: every byte is in exactly one frame or noise record, in
// order; every frame is well formed with its check verdict right; no latency is negative; the
// JSON Lines output parses.
#include <cstdio>
#include <map>
#include <vector>

#include <nlohmann/json.hpp>

#include "captures/output_file.hpp"
#include "decoder/models/model_interpreter.hpp"
#include "decoder/protocol/analyzer.hpp"
#include "decoder/protocol/checksum.hpp"
#include "output/json_sink.hpp"
#include "output/output.hpp"
#include "output/text_sink.hpp"
#include "tests/fuzz/fuzz_input.hpp"
#include "tools/modtap/model_catalog.hpp"

namespace modtap::fuzz {
namespace {

// Checks each record as it comes, then passes it on to the sinks that render it.
class PropertySink final : public RecordSink {
 public:
  explicit PropertySink(std::vector<RecordSink*> next) : next_(std::move(next)) {}

  void on_frame(const Frame& f) override {
    record(f.index, f.channel, f.offset, f.raw.size());
    FUZZ_EXPECT(f.adu.size() >= 1 + f.check_size());
    if (f.mode == Mode::rtu) FUZZ_EXPECT(f.raw.size() == f.adu.size());
    // A frame cut short has no check to expect; any other says whether its own check holds.
    if (f.damage == Damage::cut) {
      FUZZ_EXPECT(!f.check_ok);
    } else {
      FUZZ_EXPECT(f.check_ok == (f.expected_check == f.wire_check()));
    }
    FUZZ_EXPECT(!f.latency_ns || *f.latency_ns >= 0);
    FUZZ_EXPECT(!f.request || *f.request < f.index);
    if (f.role == Role::request) requests_.push_back(f.index);
    for (auto* n : next_) n->on_frame(f);
  }
  void on_noise(const Noise& n) override {
    record(n.index, n.channel, n.offset, n.raw.size());
    for (auto* s : next_) s->on_noise(n);
  }
  void on_timeout(const Timeout& t) override {
    FUZZ_EXPECT(t.waited_ns >= 0);
    FUZZ_EXPECT(std::find(requests_.begin(), requests_.end(), t.request) != requests_.end());
    for (auto* s : next_) s->on_timeout(t);
  }
  uint64_t consumed(uint16_t channel) const {
    const auto it = next_offset_.find(channel);
    return it == next_offset_.end() ? 0 : it->second;
  }

 private:
  void record(uint64_t index, uint16_t channel, uint64_t offset, size_t size) {
    FUZZ_EXPECT(size > 0);
    FUZZ_EXPECT(index > last_index_);
    last_index_ = index;
    FUZZ_EXPECT(offset == next_offset_[channel]);  // nothing skipped, nothing twice
    next_offset_[channel] = offset + size;
  }

  std::vector<RecordSink*> next_;
  std::map<uint16_t, uint64_t> next_offset_;
  std::vector<uint64_t> requests_;
  uint64_t last_index_ = 0;
};

const tools::ModelCatalog& catalog() {
  static const tools::ModelCatalog models = [] {
    tools::ModelCatalog c;
    c.load_builtin();
    return c;
  }();
  return models;
}

void expect_json_lines(const char* text, size_t size) {
  const std::string_view all(text, size);
  size_t begin = 0;
  while (begin < all.size()) {
    const size_t end = all.find('\n', begin);
    FUZZ_EXPECT(end != std::string_view::npos);
    FUZZ_EXPECT(nlohmann::json::accept(all.substr(begin, end - begin)));
    begin = end + 1;
  }
}

}  // namespace
}  // namespace modtap::fuzz

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace modtap;
  fuzz::FuzzInput in(data, size);
  const uint8_t setup = in.byte();
  AnalyzerOptions options;
  options.mode = FUZZ_MODE;
  options.clock = setup & 1 ? ClockQuality::per_byte : ClockQuality::per_chunk;
  options.format.baud = (setup & 2) ? 9600 : 115200;
  const bool two_channels = setup & 4;
  std::vector<ChannelInfo> channels{{"a", ChannelRole::bus}};
  if (two_channels) channels = {{"tx", ChannelRole::master}, {"rx", ChannelRole::slave}};

  char* json_text = nullptr;
  size_t json_size = 0;
  FILE* json_stream = open_memstream(&json_text, &json_size);
  FILE* null_stream = std::fopen("/dev/null", "w");
  uint64_t pushed[2] = {0, 0};
  {
    captures::OutputFile json_file(json_stream, "json"), text_file(null_stream, "text");
    output::Output json_out(json_file), text_out(text_file);
    output::JsonSink json(json_out, channels);
    output::TextSink text(text_out, channels, {.verbose = (setup & 8) != 0});
    fuzz::PropertySink properties({&json, &text});
    // Every frame read through one of the drives' models too, as --model does.
    const auto models = fuzz::catalog().all();
    ModelChoice choice;
    choice.bus = models[(setup >> 4) % models.size()];
    ModelInterpreter interpreter(models, choice, options.clock, properties);
    Analyzer analyzer(options, channels, interpreter);
    int64_t t = 1'000'000'000;
    while (!in.empty()) {
      const uint8_t control = in.byte();
      const uint16_t channel = two_channels ? control >> 7 : 0;
      const uint8_t gap = in.byte();
      // A clock that mostly runs on, sometimes stands still or steps back.
      t += gap == 0xFF ? -5'000'000 : static_cast<int64_t>(gap) * 50'000;
      const auto bytes = in.take((control & 0x7F) + 1u);
      analyzer.push({channel, t, bytes});
      pushed[channel] += bytes.size();
    }
    analyzer.finish();
    for (uint16_t c = 0; c < channels.size(); ++c) FUZZ_EXPECT(properties.consumed(c) == pushed[c]);
    json_out.flush();
    text_out.flush();
  }
  std::fclose(json_stream);
  std::fclose(null_stream);
  fuzz::expect_json_lines(json_text, json_size);
  std::free(json_text);
  return 0;
}
