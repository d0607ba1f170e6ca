#include "tools/modtap/auto_format.hpp"

#include <fmt/format.h>

#include "decoder/protocol/format_probe.hpp"

namespace modtap::tools {

namespace {

constexpr uint64_t probe_bytes = 256 * 1024;  // enough traffic to judge, little enough to be quick

FormatTrial trial(const std::string& path, captures::OpenOptions open, AnalyzerOptions analyzer,
                  const SerialFormat& format) {
  open.serial = format;
  auto source = captures::open_capture(path, open);
  analyzer.format = format;
  analyzer.clock = source->clock();
  FormatTrial t = try_format(
      analyzer, source->channels(), [&](Chunk& chunk) { return source->next(chunk); }, probe_bytes);
  t.parity_errors = source->parity_errors();
  return t;
}

void report(const std::vector<FormatTrial>& trials, const FormatTrial& best) {
  fmt::print(stderr, "modtap: settings tried on the capture's start:\n");
  for (const auto& t : trials)
    fmt::print(stderr, "  {}{}\n", &t == &best ? "* " : "  ", describe(t));
}

}  // namespace

std::optional<ModeChoice> better_mode(const std::string& path, captures::OpenOptions open,
                                      AnalyzerOptions analyzer) {
  if (analyzer.mode == ModeChoice::automatic) return std::nullopt;
  const SerialFormat told = open.serial;
  if (trial(path, open, analyzer, told).convincing()) return std::nullopt;
  const bool ascii = analyzer.mode == ModeChoice::rtu;  // the other one
  analyzer.mode = ascii ? ModeChoice::ascii : ModeChoice::rtu;
  if (!trial(path, open, analyzer, told.with_data_bits_of(ascii)).convincing()) return std::nullopt;
  return analyzer.mode;
}

namespace {

// Each candidate setting read on the capture's start, the common ones first, until one reads
// convincingly, and the other parities at the leading baud (a line with long stop gaps can read
// cleanly under more than one).
std::vector<FormatTrial> try_candidates(const std::string& path, captures::OpenOptions open,
                                        const AnalyzerOptions& analyzer,
                                        std::optional<uint32_t> baud, std::optional<Parity> parity,
                                        Parity fallback_parity, ClockQuality clock) {
  // A logic-analyzer capture is decoded into bytes per format: every candidate matters, and the
  // decoder's parity errors tell the parities apart. Bytes timed per read only move the t3.5
  // gaps, so parity cannot be told from them.
  const auto candidates =
      candidate_formats(baud, clock == ClockQuality::per_byte ? parity : fallback_parity,
                        open.serial.data_bits, open.serial.stop_bits);
  std::vector<FormatTrial> trials;
  for (const auto& format : candidates) {
    trials.push_back(trial(path, open, analyzer, format));
    if (trials.back().convincing()) break;
  }
  const SerialFormat leader = best_trial(trials).format;
  for (const auto& format : candidates) {
    if (format.baud != leader.baud) continue;
    bool tried = false;
    for (const auto& t : trials)
      tried |= t.format.parity == format.parity && t.format.baud == format.baud;
    if (!tried) trials.push_back(trial(path, open, analyzer, format));
  }
  return trials;
}

}  // namespace

SerialFormat choose_file_format(const std::string& path, captures::OpenOptions open,
                                AnalyzerOptions analyzer, std::optional<uint32_t> baud,
                                std::optional<Parity> parity) {
  const SerialFormat fallback{baud.value_or(19200), open.serial.data_bits,
                              parity.value_or(Parity::even), open.serial.stop_bits};
  const ClockQuality clock = captures::open_capture(path, open)->clock();
  if (clock == ClockQuality::none) {
    fmt::print(stderr,
               "modtap: {} has no timing, so every baud and parity read it alike; using {}\n", path,
               describe(fallback));
    return fallback;
  }
  const std::vector<FormatTrial> trials =
      try_candidates(path, open, analyzer, baud, parity, fallback.parity, clock);
  const FormatTrial& best = best_trial(trials);
  report(trials, best);
  for (const auto& t : trials)
    if (&t != &best && t.format.baud == best.format.baud && t.good_frames > 0 &&
        t.good_frame_bytes == best.good_frame_bytes && t.parity_errors == best.parity_errors)
      fmt::print(stderr, "modtap: {} reads as well as {}: this capture cannot tell them apart\n",
                 describe(t.format), describe(best.format));
  if (best.good_frames == 0) {
    fmt::print(stderr, "modtap: no setting gave a frame with a good check; using {}\n",
               describe(fallback));
    return fallback;
  }
  return best.format;
}

std::optional<BetterSettings> better_format(const std::string& path, captures::OpenOptions open,
                                            AnalyzerOptions analyzer) {
  const SerialFormat told = open.serial;
  const ClockQuality clock = captures::open_capture(path, open)->clock();
  if (clock == ClockQuality::none) return std::nullopt;
  const FormatTrial given = trial(path, open, analyzer, told);
  if (given.convincing()) return std::nullopt;
  const std::vector<FormatTrial> trials =
      try_candidates(path, open, analyzer, std::nullopt, std::nullopt, told.parity, clock);
  const FormatTrial& best = best_trial(trials);
  // Convincing where the given settings are not, and twice the bytes making sense: a noisy
  // bus read at its own settings finds no such rival.
  if (!best.convincing() || best.good_frame_bytes < 2 * given.good_frame_bytes ||
      (best.format.baud == told.baud && best.format.parity == told.parity &&
       best.format.stop_bits == told.stop_bits))
    return std::nullopt;
  const auto share = [](const FormatTrial& t) {
    return t.bytes ? static_cast<double>(t.good_frame_bytes) / static_cast<double>(t.bytes) : 0.0;
  };
  return BetterSettings{best.format, share(best), share(given)};
}

}  // namespace modtap::tools
