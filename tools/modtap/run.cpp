#include "tools/modtap/run.hpp"

#include <unistd.h>

#include <cstdio>
#include <filesystem>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "captures/open_capture.hpp"
#include "captures/piped_input.hpp"
#include "captures/sigrok_reader.hpp"
#include "decoder/protocol/format_probe.hpp"
#include "tools/live/live_capture.hpp"
#include "tools/modtap/auto_format.hpp"
#include "tools/modtap/enum_option.hpp"
#include "tools/modtap/progress.hpp"
#include "tools/modtap/session.hpp"
#include "tools/top/top_view.hpp"

namespace modtap::tools {
namespace {

// Whether the terminal is free for a status or progress line: standard error is one, and
// frame lines are not printed on that same terminal.
bool terminal_free_for_status(const RunOptions& o) {
  const bool lines_on_stdout = prints_to_terminal(o.output) && o.output != OutputKind::stats;
  return isatty(STDERR_FILENO) && (!lines_on_stdout || !isatty(STDOUT_FILENO));
}

// A bar for a file read straight through, on a terminal that has room for it.
std::unique_ptr<ProgressBar> progress_bar(const RunOptions& o, const captures::ChunkSource& source,
                                          bool piped) {
  if (o.top || piped || !source.file_position() || !terminal_free_for_status(o)) return nullptr;
  std::error_code error;
  const auto size = std::filesystem::file_size(o.read_file, error);
  if (error) return nullptr;
  return std::make_unique<ProgressBar>(stderr, size);
}

// What a hint after the run knows besides the traffic: the setting the evidence points at.
struct HintContext {
  bool logic_analyzer = false;
  std::vector<std::string> unnamed_lines;  // a logic-analyzer capture read on its first channel
  bool untimed = false;                    // a capture without timing: no baud reads differently
  std::optional<ModeChoice> better_mode;   // the other mode reads the capture where this did not
  uint64_t timed_answers = 0, early_answers = 0;  // the matcher's: answers before their questions
  std::optional<BetterSettings> better{};         // settings found to read the capture
};

// What to do about settings that read the traffic poorly: the ones found to read it, or the
// search for them.
std::string settings_remedy(const SerialFormat& format, const HintContext& context) {
  if (!context.better)
    return fmt::format("are {} the line's settings? try --baud auto", describe(format));
  return read_it_with(*context.better, format);
}

// After a run whose traffic made little sense, or came faster than the baud allows, say so,
// naming the setting the evidence points at.
void hint_settings(const SerialFormat& format, const LineHealth& health, const ChunkPace& pace,
                   const HintContext& context) {
  const bool logic_analyzer = context.logic_analyzer;
  // Nothing at all came of the first channel, read since no line was named: name them.
  if (logic_analyzer && health.bytes == 0 && !context.unnamed_lines.empty()) {
    fmt::print(stderr,
               "modtap: hint: nothing was decoded on channel {}, the capture's first; it has {}: "
               "name the lines with --sigrok-channels tx=NAME,rx=NAME or bus=NAME\n",
               context.unnamed_lines.front(), fmt::join(context.unnamed_lines, ", "));
    return;
  }
  // A logic-analyzer capture that reads as nothing is usually a line inverted (RS-232 levels)
  // or probes swapped, which no baud rate mends.
  if (logic_analyzer && health.looks_wrong() && health.good_frames == 0) {
    fmt::print(stderr,
               "modtap: hint: no frame had a good check; is the line inverted (try "
               "--sigrok-invert), are the channels right (--sigrok-channels tx=NAME,rx=NAME), "
               "or are {} not the line's settings (try --baud auto)?\n",
               describe(format));
    return;
  }
  if (context.better_mode) {
    fmt::print(stderr, "modtap: hint: the traffic reads as Modbus {}: try --mode {} (or auto)\n",
               *context.better_mode == ModeChoice::ascii ? "ASCII" : "RTU",
               to_string(*context.better_mode));
    return;
  }
  if (context.untimed && health.looks_wrong()) {
    fmt::print(stderr,
               "modtap: hint: only {:.0f}% of {} bytes formed frames with a good check; without "
               "timing no baud or parity reads them otherwise: they may be no Modbus, or cut\n",
               100 * health.good_share(), health.bytes);
    return;
  }
  if (mostly_early(context.timed_answers, context.early_answers)) {
    fmt::print(stderr,
               "modtap: hint: {} of {} answers would begin before their request ended at {}; "
               "the line is faster: try --baud auto\n",
               context.early_answers, context.timed_answers, describe(format));
    return;
  }
  if (pace.too_fast())
    fmt::print(stderr,
               "modtap: hint: bytes arrive faster than {} allows ({} of {} reads); "
               "the line is faster: try --baud auto\n",
               describe(format), pace.fast_reads, pace.reads);
  else if (health.looks_wrong())
    fmt::print(stderr,
               "modtap: hint: only {:.0f}% of {} bytes formed frames with a good check; {}\n",
               100 * health.good_share(), health.bytes, settings_remedy(format, context));
}

// modtap top's screen over the session's statistics; none without `top`.
std::unique_ptr<top::TopView> top_view(const RunOptions& o, Session& session,
                                       const SerialFormat& format, ClockQuality clock,
                                       std::function<void()> on_quit = {}) {
  if (!o.top) return nullptr;
  Pipeline& pipeline = session.pipeline();
  top::TopSources sources{*pipeline.shared_statistics(), *pipeline.statistics(),
                          *pipeline.evidence(), *pipeline.top_feed(),
                          [&pipeline] { return pipeline.problems(); }};
  top::TopSettings settings;
  settings.source = o.read_file.empty() ? fmt::format("port {}", fmt::join(o.interfaces, " "))
                                        : fmt::format("file {}", o.read_file);
  settings.settings = fmt::format("{}, {}", describe(format),
                                  o.baud && o.parity ? "as given" : "found by --baud auto");
  settings.clock = std::string(to_string(clock));
  if (!o.read_file.empty()) settings.replay_speed = o.top_speed;
  settings.follow = o.follow;
  settings.register_base = o.register_base;
  settings.on_quit = std::move(on_quit);
  return std::make_unique<top::TopView>(std::move(sources), std::move(settings));
}

// -a frames:N, where the run's record limit (the smaller of it and -c) was it and was reached.
std::optional<std::string> frames_met(const RunOptions& o, const Autostop& stop,
                                      const Session& session) {
  if (!stop.frames || o.max_records != *stop.frames || !session.limit_reached())
    return std::nullopt;
  return fmt::format("frames:{}", *stop.frames);
}

}  // namespace

namespace {

// How to open the capture: its format, and the line's settings, found by --baud auto (a read of
// the capture's start under each) where they are not given.
captures::OpenOptions open_options(const RunOptions& o, bool piped) {
  captures::OpenOptions open;
  open.format = o.format;
  open.serial = serial_format(o);
  if (!o.sigrok_channels.empty())
    open.sigrok.lines = captures::parse_sigrok_channels(o.sigrok_channels);
  open.sigrok.invert = o.sigrok_invert;
  if (!o.baud || !o.parity) {
    if (piped)
      throw std::runtime_error(fmt::format(
          "{}: --baud auto and --parity auto read a capture once per setting; a pipe can be "
          "read only once: give a file",
          o.read_file == "-" ? "standard input" : o.read_file));
    open.serial = choose_file_format(o.read_file, open, analyzer_options(o, {}), o.baud, o.parity);
  }
  return open;
}

// How a read of the capture ended: broken off (a truncated file: everything read before the
// break is in every output, then the error), or at an -a condition.
struct ReadEnd {
  std::optional<captures::CaptureError> broken;
  std::optional<std::string> stopped_by;
};

ReadEnd read_chunks(const RunOptions& o, const Autostop& autostop, captures::ChunkSource& source,
                    Analyzer& bus, Session& session, top::TopView* view, bool piped) {
  ReadEnd end;
  auto progress = progress_bar(o, source, piped);
  Chunk chunk;
  try {
    std::optional<int64_t> first_ns;
    while (!session.limit_reached() && source.next(chunk)) {
      if (view && !view->pace(chunk.t_ns)) break;
      if (!first_ns) first_ns = chunk.t_ns;
      end.stopped_by = autostop_met(autostop, chunk.t_ns - *first_ns, session.pcapng_bytes());
      if (end.stopped_by) break;
      if (progress) progress->update(*source.file_position());
      if (source.clock() != ClockQuality::none) session.pipeline().on_read(chunk);
      if (session.keeps_raw()) session.keep_raw(chunk, bus.between_frames());
      bus.push(chunk);
      if (piped) session.flush_output();
    }
  } catch (const captures::CaptureError& e) {
    end.broken = e;
  }
  return end;  // the progress bar wiped before anything else reaches the terminal
}

// Given settings that read a third of a timed file's bytes as junk or more, or that the line
// outpaces: the settings that read it. A bus that noisy is rarer than a wrong setting; one less
// noisy is not read again under every setting.
std::optional<BetterSettings> settings_that_read(const RunOptions& o,
                                                 const captures::OpenOptions& open,
                                                 ClockQuality clock, bool piped,
                                                 const LineHealth& health, Session& session,
                                                 const Analyzer& bus) {
  const bool doubtful = 3 * health.good_frame_bytes < 2 * health.bytes ||
                        session.pipeline().pace().too_fast() ||
                        mostly_early(bus.matcher().timed_answers(), bus.matcher().early_answers());
  if (!o.baud || !o.parity || piped || clock == ClockQuality::none || health.bytes < 64 ||
      !doubtful)
    return std::nullopt;
  return better_format(o.read_file, open, analyzer_options(o, clock));
}

// What the hint after the run knows besides the traffic. A pipe is not read again: it holds no
// logic-analyzer capture anyway.
HintContext hint_context(const RunOptions& o, const captures::OpenOptions& open, ClockQuality clock,
                         bool piped, const LineHealth& health, const Analyzer& bus,
                         std::optional<BetterSettings> better) {
  const captures::Format format = open.format != captures::Format::automatic ? open.format
                                  : piped                                    ? captures::Format::raw
                                          : captures::detect_format(o.read_file);
  HintContext context{
      format == captures::Format::sigrok, {}, clock == ClockQuality::none, std::nullopt};
  context.better = better;
  context.timed_answers = bus.matcher().timed_answers();
  context.early_answers = bus.matcher().early_answers();
  if (context.logic_analyzer && o.sigrok_channels.empty() && health.bytes == 0)
    context.unnamed_lines = captures::sigrok_channel_names(o.read_file);
  if (health.looks_wrong() && !piped && !context.logic_analyzer)
    context.better_mode = better_mode(o.read_file, open, analyzer_options(o, clock));
  return context;
}

}  // namespace

int read_capture(const RunOptions& o, const Autostop& autostop, const captures::RingLimits& ring) {
  const bool piped = captures::is_piped(o.read_file);
  const captures::OpenOptions open = open_options(o, piped);
  auto source = piped ? captures::open_piped_capture(o.read_file, open)
                      : captures::open_capture(o.read_file, open);
  const ClockQuality clock = source->clock();

  Session session(o, ring, {source->channels(), open.serial, clock, o.read_file, false});
  LineHealth health(&session.records());
  AnalyzerOptions options = analyzer_options(o, clock);
  options.format = open.serial;
  options.slave_timeout_ns = &session.slave_timeouts();
  options.framing_observer = session.explain();
  Analyzer bus(options, source->channels(), health);
  auto view = top_view(o, session, open.serial, clock);
  const ReadEnd end = read_chunks(o, autostop, *source, bus, session, view.get(), piped);
  bus.finish();
  if (view) {
    view->end_of_capture(!end.broken);
    view->close();  // the terminal given back before anything is said on it
  }
  // Before the outputs say their problems.
  const auto better = settings_that_read(o, open, clock, piped, health, session, bus);
  if (better) session.pipeline().found_better_settings(*better);
  session.finish(!end.broken,
                 frames_met(o, autostop, session).value_or(end.stopped_by.value_or("")));
  if (bus.clock_steps_back())
    fmt::print(stderr,
               "modtap: warning: {}: the time stamps go backwards {}; latencies across "
               "those steps are not measured\n",
               o.read_file, output::counted(bus.clock_steps_back(), "time", "times"));
  if (end.broken) throw *end.broken;
  if (session.explain() && !session.explain()->found())
    throw std::runtime_error(
        fmt::format("--explain {}: {} has no record {}", *o.explain, o.read_file, *o.explain));
  const HintContext context = hint_context(o, open, clock, piped, health, bus, better);
  hint_settings(open.serial, health, session.pipeline().pace(), context);
  return 0;
}

int listen(const RunOptions& o, const Autostop& autostop, const captures::RingLimits& ring) {
  std::vector<live::PortSpec> ports;
  std::vector<ChannelInfo> channels;
  for (const auto& spec : o.interfaces) {
    ports.push_back(live::parse_port(spec));
    channels.push_back({ports.back().name, ports.back().role});
  }
  const auto& stop = live::stop_on_signals();
  live::LiveOptions options;
  options.analyzer = analyzer_options(o, ClockQuality::per_chunk);
  if (!o.baud || !o.parity) {
    auto probed = live::probe_ports(ports, options, o.baud, o.parity,
                                    static_cast<int64_t>(o.probe_s * 1e9), stop);
    options.analyzer.format = probed.format;
    options.replay = std::move(probed.read);  // the winning setting's bytes are analysed too
  }
  Session session(
      o, ring,
      {channels, options.analyzer.format, ClockQuality::per_chunk, ports.front().path, true},
      live::request_stop);
  const int64_t started_ns = live::wall_clock_ns();
  std::optional<std::string> stopped_by;  // the -a condition met
  options.done = [&](int64_t now_ns) {
    stopped_by = autostop_met(autostop, now_ns - started_ns, session.pcapng_bytes());
    return stopped_by.has_value();
  };
  options.analyzer.slave_timeout_ns = &session.slave_timeouts();
  // What the traffic says of the settings, for a hint when the run ends, as a file's run gives.
  LineHealth health(&session.records());
  options.on_read = [&](const Chunk& chunk, bool between_frames) {
    session.pipeline().on_read(chunk);
    if (session.keeps_raw()) session.keep_raw(chunk, between_frames);
  };
  options.reconnect = o.reconnect;
  options.announce = o.announce;
  output::PortHealth& port_health = session.port_health();
  port_health.ports = static_cast<uint32_t>(ports.size());
  port_health.open = static_cast<uint32_t>(ports.size());
  options.on_port_event = [&port_health](live::PortEvent event) {
    const bool failed = event == live::PortEvent::read_failed;
    ++(failed ? port_health.read_errors : port_health.reconnects);
    failed ? --port_health.open : ++port_health.open;
  };
  if (session.publishes()) options.on_wake = [&](int64_t now_ns) { session.tick(now_ns); };
  // A status line on the terminal, unless frame lines are printed on that same terminal.
  options.status_line = o.announce && terminal_free_for_status(o);
  auto view =
      top_view(o, session, options.analyzer.format, ClockQuality::per_chunk, live::request_stop);
  const int status = live::run_live(ports, options, health, stop);
  if (view) view->close();
  // Ctrl-C, -c and -a end a live run whole; a port gone (status 1) breaks it off.
  session.finish(status == 0, frames_met(o, autostop, session).value_or(stopped_by.value_or("")));
  hint_settings(options.analyzer.format, health, session.pipeline().pace(), HintContext{});
  return status;
}

void add_line_options(CLI::App& app, RunOptions& o) {
  add_enum_option(app, "--mode", o.mode,
                  "Transmission mode: rtu, ascii, or auto to tell it from the traffic (default)");
  app.add_option_function<std::string>(
         "--baud",
         [&o](const std::string& text) {
           o.baud.reset();
           if (text != "auto") o.baud = static_cast<uint32_t>(std::stoul(text));
         },
         "Baud rate, or auto to tell it from the traffic (default 19200)")
      ->check(CLI::IsMember({"auto"}) | CLI::Range(50u, 4'000'000u))
      ->type_name("BAUD|auto");
  add_enum_or_auto_option(app, "--parity", o.parity, "Parity: none, even (default), odd, or auto");
  app.add_option("--stop-bits", o.stop_bits, "Stop bits (default 1)")
      ->check(CLI::IsMember({1u, 2u}));
  app.add_option("--data-bits", o.data_bits, "Data bits (default 8 for RTU, 7 for ASCII)")
      ->check(CLI::IsMember({7u, 8u}));
  app.add_option("--model", o.models,
                 "Device model for the bus (MODEL) or one slave (SLAVE=MODEL); repeatable")
      ->type_name("[SLAVE=]MODEL");
}

}  // namespace modtap::tools
