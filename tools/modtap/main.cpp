// modtap: a passive Modbus RTU/ASCII analyzer. This file is its command line: it checks the
// options and hands them to a run (run.hpp); the stages do the work (docs/architecture.md).
#include <algorithm>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include "captures/output_file.hpp"
#include "captures/tap_port.hpp"
#include "decoder/filter/display_filter.hpp"
#include "decoder/protocol/field_registry.hpp"
#include "decoder/protocol/nearest_name.hpp"
#include "output/csv_sink.hpp"
#include "tools/help_format.hpp"
#include "tools/modtap/capture_conditions.hpp"
#include "tools/modtap/enum_option.hpp"
#include "tools/modtap/model_catalog.hpp"
#include "tools/modtap/run.hpp"

namespace {

using namespace modtap;
using tools::Autostop;
using tools::OutputKind;
using tools::RunOptions;

bool same_file(const std::string& a, const std::string& b) {
  namespace fs = std::filesystem;
  std::error_code error;
  if (fs::equivalent(a, b, error)) return true;
  return fs::weakly_canonical(a, error) == fs::weakly_canonical(b, error) && !error;
}

// Outputs that would destroy the input or each other, or mix two formats on one stream.
std::optional<std::string> refuse_outputs(const RunOptions& o) {
  const std::vector<std::pair<const char*, std::string>> files{{"-w", o.write_file},
                                                               {"--save-raw", o.save_raw},
                                                               {"--stats", o.stats_file},
                                                               {"--report", o.report_file}};
  for (size_t i = 0; i < files.size(); ++i) {
    const auto& [option, path] = files[i];
    if (path.empty() || path == "-") continue;
    if (!o.read_file.empty() && o.read_file != "-" && same_file(path, o.read_file))
      return fmt::format("{} {} would overwrite the capture being read", option, path);
    for (size_t j = i + 1; j < files.size(); ++j)
      if (!files[j].second.empty() && same_file(path, files[j].second))
        return fmt::format("{} and {} both name {}", option, files[j].first, path);
  }
  std::vector<std::string> on_standard_output;
  for (const auto& [option, path] : files)
    if (path == "-") on_standard_output.push_back(std::string(option) + " -");
  if (tools::prints_to_terminal(o.output))
    on_standard_output.push_back(fmt::format("-T {}", o.output));
  if (on_standard_output.size() > 1)
    return fmt::format("{} and {} would both write to standard output", on_standard_output[0],
                       on_standard_output[1]);
  return std::nullopt;
}

// -b turns files: it needs a file to turn, and standard output is none.
std::optional<std::string> refuse_ring(const RunOptions& o, const captures::RingLimits& ring) {
  if (!ring.rotates()) return std::nullopt;
  if (o.write_file.empty() && o.save_raw.empty())
    return "-b turns the files of -w and --save-raw: give one of them";
  if (o.write_file == "-" || o.save_raw == "-")
    return "-b writes a ring of files; standard output is one stream: give a file name";
  return std::nullopt;
}

// Every field modtap shows, one a line: its name (the JSON key, the -Y name, Wireshark's
// modtap.NAME), where it is (record, pdu, or item of a list), its JSON kind, its type, title.
int list_fields() {
  for (const auto& field : field_registry()) {
    const char* where = field.item ? "item" : field.id < first_pdu_field ? "record" : "pdu";
    fmt::print("{}\t{}\t{}\t{}\t{}\n", field.name, where, json_kind(field.type),
               to_string(field.type), field.title);
  }
  return 0;
}

int list_models(const RunOptions& o) {
  const tools::ModelCatalog catalog = tools::load_models(o);
  for (const auto& entry : catalog.entries())
    fmt::print("{:<12} {:<40} {}\n", entry.model.name, entry.model.title, entry.origin);
  return 0;
}

// "; did you mean NAME?" for the models' register name nearest `name`, if one is near.
std::string nearest_register(const std::vector<const DeviceModel*>& models, std::string_view name) {
  NearestName nearest(name);
  for (const DeviceModel* model : models)
    for (const auto& [key, def] : model->registers) nearest.consider(def.name);
  return nearest.suggestion();
}

// --follow names a register of a loaded model (any of them, as -Y does: a slave may identify
// itself as a model --model did not name) or gives an address; any other name is a mistake
// that would follow nothing.
std::optional<std::string> refuse_follow(const RunOptions& o) {
  if (o.follow.empty()) return std::nullopt;
  const tools::ModelCatalog catalog = tools::load_models(o);
  const auto models = catalog.all();
  for (const auto& item : o.follow) {
    if (item.number || std::any_of(models.begin(), models.end(),
                                   [&](const auto* m) { return names_register(*m, item.name); }))
      continue;
    return fmt::format("--follow: no model names a register \"{}\"{}", item.name,
                       nearest_register(models, item.name));
  }
  return std::nullopt;
}

// -c N and -a frames:N: whichever stops first (0: no limit).
uint64_t record_limit(const RunOptions& o, const Autostop& autostop) {
  if (!autostop.frames) return o.max_records;
  return o.max_records ? std::min(o.max_records, *autostop.frames) : *autostop.frames;
}

// What the command line asks beyond a run's options: a subcommand, and which options were
// given rather than left at their defaults.
struct Command {
  std::string named_capture;  // `modtap FILE`, as -r FILE
  CLI::Option* output = nullptr;
  CLI::Option* timeout = nullptr;
  CLI::Option* link = nullptr;
  CLI::Option* dlt = nullptr;
  CLI::Option* reconnect = nullptr;
  CLI::Option* probe_time = nullptr;
  CLI::Option* chunk_jitter = nullptr;
  CLI::App* fields = nullptr;
  CLI::App* models = nullptr;
  CLI::App* check = nullptr;
  CLI::App* top = nullptr;
  CLI::App* discover = nullptr;
  CLI::Option* speed = nullptr;
  std::vector<std::string> check_files;
};

// Options are added in the order --help lists them: what to read; what to write, what to serve
// while running and which records to show; how to read the line; then the subcommands.
void add_input_options(CLI::App& app, RunOptions& o, Command& command) {
  auto* read = app.add_option("-r,--read", o.read_file,
                              "Capture file to read; - for standard input or a pipe")
                   ->type_name("FILE");
  app.add_option("capture", command.named_capture, "The capture file, as with -r")
      ->type_name("FILE")
      ->excludes(read);
  auto* listen_on = app.add_option("-i,--interface", o.interfaces,
                                   "Serial port to listen on (read-only): PATH, or master=PATH and "
                                   "slave=PATH for a tap that splits the directions; or a device "
                                   "server's stream, tcp://HOST:PORT, or rfc2217://HOST:PORT "
                                   "to set its port too")
                        ->type_name("PORT");
  read->excludes(listen_on);
  command.reconnect =
      app.add_flag("--reconnect", o.reconnect,
                   "Wait for an unplugged port or a dropped connection to come back");
  tools::add_enum_option(app, "--format", o.format, "Capture format",
                         {{"pcapng", captures::Format::pcap}});
}

// The outputs and the files a run writes.
void add_output_options(CLI::App& app, RunOptions& o, Command& command) {
  command.output =
      tools::add_enum_option(app, "-T,--output", o.output,
                             "Output: text, json (JSON Lines), stats, csv (register "
                             "values over time), none (default: text, or none with -w)");
  app.add_option("--follow", o.follow_list,
                 "With -T csv (implied): the registers to follow, by name or address: "
                 "frequency_command,2503H")
      ->type_name("REGISTERS");
  app.add_option("-w,--write", o.write_file, "Write every frame and noise record as pcapng")
      ->type_name("FILE");
  app.add_option("--save-raw", o.save_raw,
                 "Keep every read as it came, with its time, to read again with other settings: "
                 "FILE.pcapng, or a timed hex log for any other name")
      ->type_name("FILE");
  app.add_option("--stats", o.stats_file,
                 "Write the statistics as one JSON object at the end of the run (also after "
                 "Ctrl-C, and marked incomplete when the input breaks off)")
      ->type_name("FILE");
  app.add_option("--report", o.report_file,
                 "Write a report a customer can read (one HTML file with charts; with --follow, "
                 "those registers over time) at the end of the run, as --stats")
      ->type_name("FILE.html");
  tools::add_enum_option(
      app, "--register-base", o.register_base,
      "How text, CSV, statistics and the report number registers: hex (2502H, as the "
      "drives' manuals), 0 (0-based decimal, as on the wire), 1 (1-based, as mbpoll), "
      "4xxxx (Modicon: 40001 is holding register 0); --follow reads numbers the same way");
}

// Metrics for Prometheus and MQTT: what a run that stays on a bus serves while it runs.
void add_monitoring_options(CLI::App& app, RunOptions& o) {
  auto* metrics =
      app.add_option(
             "--metrics", o.metrics_address,
             "Serve bus-health metrics for Prometheus on http://ADDR:PORT/metrics while running "
             "(ADDR:PORT, [IPV6]:PORT, or :PORT for every interface)")
          ->type_name("[ADDR]:PORT");
  app.add_option("--metrics-web-config", o.metrics_web_config,
                 "HTTPS and users with bcrypt passwords for --metrics, in the Prometheus "
                 "exporter toolkit's web configuration format (docs/monitoring.md)")
      ->type_name("FILE")
      ->needs(metrics);
  auto* mqtt =
      app.add_option(
             "--mqtt", o.mqtt_url,
             "Publish register values (retained, on change), a health summary and an "
             "online/offline status to an MQTT broker: mqtt://[USER@]HOST[:PORT]/PREFIX, or "
             "mqtts:// over TLS (docs/monitoring.md)")
          ->type_name("URL");
  app.add_option("--mqtt-password-file", o.mqtt_password_file,
                 "The MQTT password, from the file's first line (or MODTAP_MQTT_PASSWORD): "
                 "never on the command line, where every local user sees it")
      ->type_name("FILE")
      ->needs(mqtt);
  app.add_option("--mqtt-ca", o.mqtt_tls.ca_file,
                 "For mqtts://: the CA certificate (PEM) that signs the broker's (default: the "
                 "system's CA store)")
      ->type_name("FILE")
      ->needs(mqtt);
  auto* mqtt_cert = app.add_option("--mqtt-cert", o.mqtt_tls.cert_file,
                                   "For mqtts://: modtap's client certificate (PEM), where the "
                                   "broker asks for one")
                        ->type_name("FILE")
                        ->needs(mqtt);
  app.add_option("--mqtt-key", o.mqtt_tls.key_file,
                 "For mqtts://: the client certificate's private key (PEM)")
      ->type_name("FILE")
      ->needs(mqtt_cert);
  app.add_flag("--mqtt-insecure", o.mqtt_tls.insecure,
               "For mqtts:// in tests only: do not check the broker's name against its "
               "certificate")
      ->needs(mqtt);
  app.add_option("--mqtt-interval", o.mqtt_interval_s,
                 "Seconds: a register at most this often, the health summary this often "
                 "(at least 1 s); 0 sends every change at once (default 10)")
      ->type_name("SECONDS")
      ->check(CLI::NonNegativeNumber)
      ->needs(mqtt);
  app.add_option("--mqtt-bus", o.mqtt_bus,
                 "The topic level naming the bus (default: the port's or capture's name)")
      ->type_name("NAME")
      ->needs(mqtt);
  app.add_flag("--mqtt-discovery{homeassistant}", o.mqtt_discovery,
               "Announce each register to Home Assistant (--mqtt-discovery=PREFIX for another "
               "discovery prefix than homeassistant)")
      ->needs(mqtt);
}

// How the records are written and shown, and which of them and for how long.
void add_record_options(CLI::App& app, RunOptions& o, Command& command) {
  command.link = tools::add_enum_option(
      app, "--link", o.link,
      "pcapng link: user (DLT_USER + the modtap plugin), exported-pdu, bare");
  command.dlt = app.add_option("--dlt", o.dlt, "DLT_USER link type for --link user or bare")
                    ->check(CLI::Range(147, 162));
  app.add_flag("-V,--verbose", o.verbose, "Print each frame's field tree");
  app.add_option("--explain", o.explain,
                 "Print record INDEX and why the RTU framer cut there: each reading it weighed "
                 "at the record's first byte and the evidence that decided (with -r)")
      ->type_name("INDEX")
      ->check(tools::positive("needs a record's index, from 1"));
  tools::add_enum_option(app, "-t", o.time_format,
                         "Text time column: r (since the capture's first record), a (local time "
                         "of day), ad (local date and time), d (since the record before, shown "
                         "or not), dd (since the line shown before)");
  app.add_option("-Y,--display-filter", o.display_filter,
                 "Only records that match, in every output: 'slave == 3 && fc == 6', "
                 "'latency_us > 50000', 'finding', 'register.name == \"fault\"' (docs/output.md)")
      ->type_name("FILTER");
  app.add_option("-c", o.max_records,
                 "Stop after this many records read: frames and noise (time-outs do not count)")
      ->check(tools::positive("needs at least 1"));
  app.add_option("-a,--autostop", o.autostop,
                 "Stop after duration:SECONDS (capture time of a file, wall time on a port), "
                 "filesize:KB (the -w files), or frames:N; repeatable, the first reached wins")
      ->type_name("CONDITION");
  app.add_option("-b,--ring-buffer", o.ring_buffer,
                 "Write -w and --save-raw as a ring of files, named as dumpcap names them: a "
                 "new file after duration:SECONDS or filesize:KB, keeping the newest files:N")
      ->type_name("CONDITION");
  app.add_flag("-q,--quiet", o.quiet,
               "No line per frame: only what the run adds up to (-T stats, --stats)");
}

void add_analysis_options(CLI::App& app, RunOptions& o, Command& command) {
  app.set_version_flag("--version", std::string("modtap ") + MODTAP_VERSION);
  tools::add_line_options(app, o);
  command.probe_time =
      app.add_option("--probe-time", o.probe_s,
                     "With --baud auto on a port: seconds to listen under each setting")
          ->type_name("SECONDS")
          ->check(tools::positive("needs a number of seconds above 0"));
  command.timeout = app.add_option("--timeout", o.timeout_s,
                                   "Seconds of silence before a request times out (1, or what the "
                                   "slave's model says)")
                        ->type_name("SECONDS")
                        ->check(tools::positive("needs a number of seconds above 0"));
  app.add_option("--ascii-timeout", o.ascii_timeout_s, "ASCII inter-character time-out, seconds")
      ->type_name("SECONDS")
      ->check(tools::positive("needs a number of seconds above 0"));
  command.chunk_jitter =
      app.add_option("--chunk-jitter", o.jitter_ms,
                     "For sources timed per read: milliseconds an adapter or a device server may "
                     "hold bytes back (30; 100 for tcp://)")
          ->type_name("MS")
          ->check(CLI::NonNegativeNumber);
  app.add_option("--sigrok-channels", o.sigrok_channels,
                 "sigrok lines: tx=NAME,rx=NAME (the master's transmit and receive) or bus=NAME")
      ->type_name("LINES");
  app.add_flag("--sigrok-invert", o.sigrok_invert, "The sigrok lines have inverted levels");
  app.add_option("--models-dir", o.models_dir, "A folder of the user's model files (*.yaml, *.yml)")
      ->type_name("DIR");
}

void add_subcommands(CLI::App& app, RunOptions& o, Command& command) {
  command.fields = app.add_subcommand(
      "fields",
      "List every field: name (JSON key, -Y, Wireshark's modtap.NAME), place, JSON kind, type, "
      "title");
  command.models = app.add_subcommand("models", "List the device models, or check a model file");
  command.models->fallthrough();  // `modtap models --models-dir DIR` lists the user's models too
  command.check = command.models->add_subcommand("check", "Validate model files");
  command.check->add_option("FILE", command.check_files, "Model files (YAML)")
      ->type_name("FILE")
      ->required();
  command.top = app.add_subcommand(
      "top",
      "A live view of the bus on the terminal: the slaves, their rates and latencies, the "
      "problems, the latest transactions (docs/top.md); with -i PORT, or -r FILE replayed at its "
      "own pace");
  command.top->fallthrough();  // modtap's options, `modtap top -i PORT --baud auto`
  command.speed =
      command.top->add_option("--speed", o.top_speed, "With -r: replay this many times faster")
          ->type_name("TIMES")
          ->check(tools::positive("needs a number above 0"));
  command.top->footer(
      "modtap's options apply: -i, -r, --baud, --parity, --model, --follow, -Y, -t, --stats, "
      "--report, -w, --metrics, --mqtt (modtap --help)");
  command.top->add_option("capture", command.named_capture, "The capture file, as with -r")
      ->type_name("FILE");
  command.discover = app.add_subcommand(
      "discover",
      "Draft each slave's register map from the values its master reads: the blocks, each "
      "register's likeliest reading with its runner-up and confidence, the polling program "
      "(docs/discover.md); with -r FILE, or -i PORT until Ctrl-C or -a");
  command.discover->fallthrough();
  command.discover
      ->add_option("--out", o.discover_out,
                   "Write a draft model per slave, DIR/slave-N.yaml, to use with --models-dir DIR "
                   "--model N=slave-N")
      ->type_name("DIR");
  command.discover->add_option("capture", command.named_capture, "The capture file, as with -r")
      ->type_name("FILE");
}

// --follow "frequency_command,2503H": none for an empty list, which follows every register.
std::vector<output::FollowedRegister> parse_follow(const std::string& list, RegisterBase base) {
  std::vector<output::FollowedRegister> follow;
  if (list.empty()) return follow;
  size_t at = 0;
  while (at <= list.size()) {
    const size_t comma = std::min(list.find(',', at), list.size());
    const std::string item = list.substr(at, comma - at);
    if (item.empty()) throw std::invalid_argument("--follow: an empty name in \"" + list + "\"");
    follow.push_back({item, parse_register_number(item, base)});
    at = comma + 1;
  }
  return follow;
}

// What options left at their defaults mean beside the others given: -w alone writes nothing
// to the terminal (as tshark -w), --follow alone the values over time, -q only statistics.
void settle_implied(RunOptions& o, const Command& command) {
  // -Y ' ' filters nothing, as -Y '' does.
  if (o.display_filter.find_first_not_of(" \t\r\n") == std::string::npos) o.display_filter.clear();
  if (!command.named_capture.empty()) o.read_file = command.named_capture;
  o.timeout_given = command.timeout->count() > 0;
  const bool network = std::any_of(o.interfaces.begin(), o.interfaces.end(), [](const auto& spec) {
    return captures::is_network_tap(spec.substr(spec.find('=') + 1));
  });
  if (network && command.chunk_jitter->count() == 0) o.jitter_ms = captures::network_read_jitter_ms;
  if (!o.write_file.empty() && command.output->count() == 0) o.output = OutputKind::none;
  o.follow = parse_follow(o.follow_list, o.register_base);
  if (!o.follow.empty() && command.output->count() == 0)
    o.output = o.report_file.empty() ? OutputKind::csv : OutputKind::text;
  if (o.quiet && o.output != OutputKind::stats) o.output = OutputKind::none;
  o.top = command.top->parsed();
  if (o.top && command.output->count() == 0) o.output = OutputKind::none;
  if (o.top) o.announce = false;  // the screen says what is listened to
  o.discover = command.discover->parsed();
  if (o.discover && command.output->count() == 0) o.output = OutputKind::none;
}

std::optional<std::string> refuse_source(const RunOptions& o) {
  if (o.interfaces.empty() && o.read_file.empty())
    return "give a capture with -r FILE or a port with -i PORT";
  if (o.interfaces.size() > 2) return "at most two ports (master=PATH slave=PATH)";
  return std::nullopt;
}

// The first of the conditions' and outputs' conflicts, checked before any work; none when they
// fit.
std::optional<std::string> refuse(const RunOptions& o, const Autostop& autostop,
                                  const captures::RingLimits& ring) {
  if (autostop.filesize_bytes && o.write_file.empty())
    return "-a filesize stops on the size of the -w file: give -w";
  if (o.top && o.output != OutputKind::none)
    return fmt::format(
        "modtap top draws on the terminal; -T {} would print there too: write "
        "the statistics with --stats FILE",
        o.output);
  if (o.top && o.explain) return "--explain prints a record; modtap top shows the bus";
  if (o.explain && (o.read_file.empty() || o.output != OutputKind::text))
    return "--explain prints one record of a capture read with -r, as text";
  if (auto refusal = refuse_ring(o, ring)) return refusal;
  if (auto refusal = refuse_outputs(o)) return refusal;
  return refuse_follow(o);
}

// Options given that this run would not use: said, never ignored in silence. Each row: whether
// it was given, whether the run uses it, and what it is for.
void warn_idle_options(const RunOptions& o, const Command& command) {
  const bool lines = o.output == OutputKind::text;
  const bool values_over_time =
      o.output == OutputKind::csv || !o.report_file.empty() || !o.mqtt_url.empty();
  const struct {
    bool given, used;
    const char* what;
  } options[] = {
      {command.link->count() > 0, !o.write_file.empty(), "--link sets the link type of -w"},
      {command.dlt->count() > 0, !o.write_file.empty(), "--dlt sets the link type of -w"},
      {o.reconnect, !o.interfaces.empty(), "--reconnect waits for a port (-i) to come back"},
      {command.probe_time->count() > 0, !o.interfaces.empty() && (!o.baud || !o.parity),
       "--probe-time is how long --baud auto listens on a port (-i)"},
      {!o.follow.empty(), values_over_time,
       "--follow picks the registers of -T csv, --report and --mqtt"},
      {o.verbose, lines, "-V adds the field tree to the text output (-T text)"},
      {command.speed->count() > 0, !o.read_file.empty(),
       "--speed is how fast modtap top replays a capture (-r)"},
  };
  for (const auto& option : options)
    if (option.given && !option.used)
      fmt::print(stderr, "modtap: warning: {}; this run has none, so it does nothing\n",
                 option.what);
}

int run_command(RunOptions& o, const Command& command) {
  try {
    settle_implied(o, command);
    if (command.check->parsed()) return tools::check_model_files(command.check_files, o.models_dir);
    if (command.models->parsed()) return list_models(o);
    if (command.fields->parsed()) return list_fields();
    if (auto refusal = refuse_source(o)) {
      fmt::print(stderr, "modtap: {}\n", *refusal);
      return 2;
    }
    warn_idle_options(o, command);
    const Autostop autostop = tools::parse_autostop(o.autostop);
    const captures::RingLimits ring = tools::parse_ring_buffer(o.ring_buffer);
    o.max_records = record_limit(o, autostop);
    if (auto refusal = refuse(o, autostop, ring)) {
      fmt::print(stderr, "modtap: {}\n", *refusal);
      return 2;
    }
    return o.interfaces.empty() ? tools::read_capture(o, autostop, ring)
                                : tools::listen(o, autostop, ring);
  } catch (const FilterError& e) {
    fmt::print(stderr, "modtap: -Y: {}\n", e.what());
    return 2;
  } catch (const captures::WriteError& e) {
    // The reader went away (`| head`): no message, but not success either, as with tshark.
    if (e.broken_pipe()) return 2;
    fmt::print(stderr, "modtap: cannot write {}\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fflush(stdout);
    fmt::print(stderr, "modtap: {}\n", e.what());
    return 2;
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"modtap: a passive analyzer for Modbus RTU and ASCII on serial lines"};
  app.formatter(std::make_shared<tools::HelpFormatter>());
  RunOptions o;
  Command command;
  add_input_options(app, o, command);
  add_output_options(app, o, command);
  add_monitoring_options(app, o);
  add_record_options(app, o, command);
  add_analysis_options(app, o, command);
  add_subcommands(app, o, command);
  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {  // --help, --version
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    fmt::print(stderr, "modtap: {} (modtap --help lists the options)\n", e.what());
    return 2;
  }
  signal(SIGPIPE, SIG_IGN);  // a closed pipe is a failed write (EPIPE), handled in run_command
  return run_command(o, command);
}
