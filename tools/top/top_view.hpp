// `modtap top`: the bus on a full-screen terminal, refreshed once a second, with keys to sort,
// choose a slave, filter, pause and write pcapng; plain text where the terminal can do no more
// (TERM=dumb, or not a terminal). The screen has its own thread: it takes a snapshot of the
// statistics under their lock and draws it, so a slow terminal or a paused screen never holds
// the capture back.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <exception>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "decoder/analysis/bus_problems.hpp"
#include "decoder/analysis/bus_statistics.hpp"
#include "output/csv_sink.hpp"
#include "output/metrics.hpp"
#include "tools/top/top_feed.hpp"
#include "tools/top/top_screen.hpp"

namespace modtap::top {

// What the screen reads, all under `shared`'s lock.
struct TopSources {
  output::SharedStatistics& shared;
  const BusStatistics& statistics;
  const ProblemEvidence& evidence;
  TopFeed& feed;
  std::function<std::vector<Problem>()> problems;
};

struct TopSettings {
  std::string source;    // "port /dev/ttyUSB0", "file bus.pcap"
  std::string settings;  // "19200 8E1, as given"
  std::string clock;
  std::optional<double> replay_speed;  // a file replayed at this pace; none: live
  std::vector<output::FollowedRegister> follow;
  RegisterBase register_base = RegisterBase::hex;
  std::function<void()> on_quit;  // `q`, or a plain screen nobody reads: stop the capture
};

class Terminal;

class TopView {
 public:
  TopView(TopSources sources, TopSettings settings);
  ~TopView();  // the screen's thread stopped, the terminal as it was
  TopView(const TopView&) = delete;
  TopView& operator=(const TopView&) = delete;

  // A replay: waits until the capture's moment `t_ns` comes at the replay's pace. False once
  // the person quit (q, Ctrl-C): read no further.
  bool pace(int64_t t_ns);
  // The screen's thread stopped and the terminal given back; throws WriteError where the plain
  // screen could not be written (its reader went away).
  void close();
  // A replay's end: the last screen stays until q (at once in plain text). `complete` false:
  // the capture broke off, and the error is said once the screen is gone.
  void end_of_capture(bool complete);

 private:
  void run();
  void run_plain();
  void stop_screen();
  bool handle_key(int key);
  void type_filter(int key);
  void sort_by(int step);
  // `refresh`: the once-a-second one, which measures the rate and samples the followed values.
  Snapshot take(bool refresh);
  std::string state_text() const;
  void fill_numbers(Snapshot& s, bool refresh);
  void fill_registers(Snapshot& s, bool refresh);
  std::string register_label(const RegisterKey& key, const LastValue& value) const;
  void toggle_writing();
  void apply_filter(const std::string& text);
  void draw();
  void move_cursor(int step);
  bool stopping() const;

  TopSources sources_;
  TopSettings settings_;
  std::unique_ptr<Terminal> terminal_;
  std::thread thread_;
  std::atomic<bool> stop_{false}, quit_{false}, ended_{false}, broken_{false};
  std::exception_ptr write_failed_;  // set by the screen's thread, read after it ended
  const std::atomic<bool>& signalled_;

  Snapshot snapshot_;
  ViewState view_;
  std::optional<uint8_t> selected_;  // the slave under the cursor, kept across sorts
  std::map<std::string, std::vector<double>> history_;
  uint64_t previous_frames_ = 0;
  std::optional<int64_t> previous_t_ns_;
  std::chrono::steady_clock::time_point started_ = std::chrono::steady_clock::now();
  std::optional<std::chrono::steady_clock::time_point> replay_start_;
  int64_t replay_first_ns_ = 0;
};

}  // namespace modtap::top
