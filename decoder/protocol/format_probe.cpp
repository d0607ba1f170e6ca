#include "decoder/protocol/format_probe.hpp"

#include <fmt/format.h>

namespace modtap {

void LineHealth::on_frame(const Frame& frame) {
  bytes += frame.raw.size();
  ++frames;
  if (frame.check_ok) {
    ++good_frames;
    good_frame_bytes += frame.raw.size();
  }
  if (next_) next_->on_frame(frame);
}

void LineHealth::on_noise(const Noise& noise) {
  bytes += noise.raw.size();
  if (next_) next_->on_noise(noise);
}

void LineHealth::on_timeout(const Timeout& timeout) {
  if (next_) next_->on_timeout(timeout);
}

void ChunkPace::add(const Chunk& chunk) {
  if (last_ns_.size() <= chunk.channel) last_ns_.resize(chunk.channel + 1u, INT64_MIN);
  int64_t& last = last_ns_[chunk.channel];
  if (last != INT64_MIN && !chunk.bytes.empty()) {
    ++reads;
    // Half the time the bytes need on the wire: slack for a clock that stamps reads late. A
    // read of one byte is most often a clock per byte's (a sniffer's pcap), stamped as the byte
    // ended: three quarters of its time, so that a line at twice the baud shows.
    const auto size = static_cast<int64_t>(chunk.bytes.size());
    const int64_t needed = size == 1 ? char_ns_ * 3 / 4 : size * char_ns_ / 2;
    if (chunk.t_ns - last < needed) ++fast_reads;
  }
  last = chunk.t_ns;
}

std::vector<SerialFormat> candidate_formats(std::optional<uint32_t> baud,
                                            std::optional<Parity> parity, uint8_t data_bits,
                                            uint8_t stop_bits) {
  static constexpr uint32_t common_bauds[] = {19200, 9600, 115200, 38400, 57600, 4800, 2400, 1200};
  static constexpr Parity parities[] = {Parity::even, Parity::none, Parity::odd};
  std::vector<SerialFormat> out;
  for (uint32_t b : common_bauds) {
    if (baud && b != *baud) continue;
    for (Parity p : parities) {
      if (parity && p != *parity) continue;
      out.push_back({b, data_bits, p, stop_bits});
    }
  }
  if (out.empty() && baud) {  // an uncommon fixed baud
    for (Parity p : parities)
      if (!parity || p == *parity) out.push_back({*baud, data_bits, p, stop_bits});
  }
  return out;
}

FormatTrial try_format(const AnalyzerOptions& options, const std::vector<ChannelInfo>& channels,
                       const std::function<bool(Chunk&)>& next, uint64_t byte_budget) {
  LineHealth health;
  {
    Analyzer bus(options, channels, health);
    Chunk chunk;
    uint64_t fed = 0;
    while (fed < byte_budget && next(chunk)) {
      bus.push(chunk);
      fed += chunk.bytes.size();
    }
    bus.finish();
  }
  return {options.format, health.bytes, health.good_frame_bytes, health.frames, health.good_frames};
}

const FormatTrial& best_trial(const std::vector<FormatTrial>& trials) {
  const FormatTrial* best = &trials.front();
  for (const auto& t : trials)
    if (t.good_frame_bytes > best->good_frame_bytes ||
        (t.good_frame_bytes == best->good_frame_bytes && t.parity_errors < best->parity_errors))
      best = &t;
  return *best;
}

std::string describe(const SerialFormat& f) {
  const char parity = f.parity == Parity::none ? 'N' : f.parity == Parity::even ? 'E' : 'O';
  return fmt::format("{} {}{}{}", f.baud, f.data_bits, parity, f.stop_bits);
}

std::string describe(const FormatTrial& t) {
  const double share = t.bytes ? 100.0 * static_cast<double>(t.good_frame_bytes) / t.bytes : 0;
  std::string text = fmt::format("{}: {} of {} frames good, {:.0f}% of {} bytes",
                                 describe(t.format), t.good_frames, t.frames, share, t.bytes);
  if (t.parity_errors) text += fmt::format(", {} parity errors", t.parity_errors);
  return text;
}

}  // namespace modtap
