#include "captures/sigrok_reader.hpp"

#include <algorithm>
#include <cinttypes>
#include <cstdio>
#include <sstream>
#include <stdexcept>
#include <string_view>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "captures/subprocess.hpp"

namespace modtap::captures {

struct SigrokReader::Stream {
  std::unique_ptr<Subprocess> process;
  uint16_t channel = 0;
  std::string name;
  bool has_byte = false;
  uint64_t sample = 0;  // first sample of the data bits
  uint8_t byte = 0;
  uint64_t line = 0;
};

// `sigrok-cli --show` on an input file prints "Samplerate: N" and "- NAME: logic" lines.
SigrokShape parse_sigrok_show(const std::string& text, const std::string& path) {
  SigrokShape shape;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("Samplerate: ", 0) == 0) {
      shape.samplerate = std::strtoull(line.c_str() + 12, nullptr, 10);
    } else if (line.rfind("- ", 0) == 0 && line.size() > 2) {
      const auto colon = line.rfind(": logic");
      if (colon != std::string::npos) shape.channels.push_back(line.substr(2, colon - 2));
    }
  }
  if (shape.samplerate == 0)
    throw CaptureError(fmt::format("{}: sigrok-cli reports no sample rate", path));
  return shape;
}

// Lines look like "31179-31597 uart-1: 01": the sample range of the data bits, then the byte.
std::optional<SigrokByte> parse_sigrok_byte(const char* line) {
  uint64_t first = 0, last = 0;
  unsigned value = 0;
  char tag[64];
  if (std::sscanf(line, "%" SCNu64 "-%" SCNu64 " %63s %x", &first, &last, tag, &value) != 4 ||
      value > 0xFF)
    return std::nullopt;
  return SigrokByte{first, static_cast<uint8_t>(value)};
}

namespace {

const char* parity_name(Parity p) {
  switch (p) {
    case Parity::none:
      return "none";
    case Parity::even:
      return "even";
    case Parity::odd:
      return "odd";
  }
  return "none";
}

ChannelRole role_of(const std::string& role) {
  if (role == "tx") return ChannelRole::master;
  if (role == "rx") return ChannelRole::slave;
  return ChannelRole::bus;
}

}  // namespace

std::vector<SigrokLine> parse_sigrok_channels(const std::string& spec) {
  std::vector<SigrokLine> lines;
  std::istringstream in(spec);
  for (std::string item; std::getline(in, item, ',');) {
    const auto eq = item.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == item.size())
      throw std::invalid_argument("expected ROLE=NAME, got \"" + item + "\"");
    SigrokLine line{item.substr(0, eq), item.substr(eq + 1)};
    if (line.role != "tx" && line.role != "rx" && line.role != "bus")
      throw std::invalid_argument("a sigrok line is tx, rx or bus, not \"" + line.role + "\"");
    lines.push_back(std::move(line));
  }
  const bool has_bus =
      std::any_of(lines.begin(), lines.end(), [](const SigrokLine& l) { return l.role == "bus"; });
  if (lines.empty() || (has_bus && lines.size() > 1))
    throw std::invalid_argument("give tx=NAME,rx=NAME or a single bus=NAME");
  return lines;
}

std::vector<std::string> sigrok_channel_names(const std::string& path, const std::string& program) {
  return parse_sigrok_show(run_to_string({program, "-i", path, "--show"}, path), path).channels;
}

SigrokReader::SigrokReader(const std::string& path, const SigrokOptions& options)
    : path_(path), options_(options) {
  const SigrokShape shape =
      parse_sigrok_show(run_to_string({options.program, "-i", path, "--show"}, path), path);
  samplerate_ = shape.samplerate;
  std::vector<SigrokLine> lines = options.lines;
  if (lines.empty()) {
    if (shape.channels.empty()) throw CaptureError(fmt::format("{}: no logic channels", path));
    lines.push_back({"bus", shape.channels.front()});
  }
  const auto& f = options.format;
  for (const auto& line : lines) {
    // sigrok-cli quietly decodes a default channel when a name is wrong, so check first.
    if (std::find(shape.channels.begin(), shape.channels.end(), line.name) == shape.channels.end())
      throw CaptureError(fmt::format("{}: no channel named \"{}\" (the capture has: {})", path,
                                     line.name, fmt::join(shape.channels, ", ")));
    std::string decoder = fmt::format("uart:rx={}:baudrate={}:parity={}:data_bits={}", line.name,
                                      f.baud, parity_name(f.parity), f.data_bits);
    if (f.stop_bits != 1) decoder += fmt::format(":stop_bits={}.0", f.stop_bits);
    if (options.invert) decoder += ":invert_rx=yes";
    auto stream = std::make_unique<Stream>();
    stream->channel = static_cast<uint16_t>(channels_.size());
    stream->name = line.name;
    stream->process = std::make_unique<Subprocess>(
        std::vector<std::string>{options.program, "-i", path, "-P", decoder, "-A",
                                 "uart=rx-data:rx-parity-err", "--protocol-decoder-samplenum"});
    channels_.push_back({line.role + ":" + line.name, role_of(line.role)});
    streams_.push_back(std::move(stream));
  }
  for (auto& s : streams_) refill(*s);
}

SigrokReader::~SigrokReader() = default;

bool SigrokReader::refill(Stream& s) {
  s.has_byte = false;
  if (!s.process) return false;
  char text[256];
  if (!std::fgets(text, sizeof text, s.process->output())) {
    std::string error_text;
    const int status = s.process->wait(error_text);
    s.process.reset();
    if (status != 0)
      throw CaptureError(
          fmt::format("{}: sigrok-cli failed on channel {}: {}", path_, s.name, error_text));
    return false;
  }
  ++s.line;
  // The decoder's verdict on the byte that follows: evidence for --parity auto.
  if (std::string_view(text).find(": Parity error") != std::string_view::npos) {
    ++parity_errors_;
    return refill(s);
  }
  const std::optional<SigrokByte> byte = parse_sigrok_byte(text);
  if (!byte)
    throw CaptureError(
        fmt::format("{}: sigrok-cli output line {} on channel {} is not a UART byte: {}", path_,
                    s.line, s.name, text));
  s.has_byte = true;
  s.sample = byte->sample;
  s.byte = byte->value;
  return true;
}

bool SigrokReader::next(Chunk& chunk) {
  Stream* earliest = nullptr;
  for (auto& s : streams_)
    if (s->has_byte && (!earliest || s->sample < earliest->sample)) earliest = s.get();
  if (!earliest) return false;
  const auto& f = options_.format;
  // The decoder reports where the data bits start; the byte ended one character after its
  // start bit, one bit earlier.
  const int64_t data_start_ns =
      static_cast<int64_t>(static_cast<__int128>(earliest->sample) * 1'000'000'000 / samplerate_);
  const int64_t bit_ns = 1'000'000'000 / f.baud;
  byte_ = earliest->byte;
  chunk = {earliest->channel, data_start_ns - bit_ns + f.char_time_ns(), {&byte_, 1}};
  refill(*earliest);
  return true;
}

}  // namespace modtap::captures
