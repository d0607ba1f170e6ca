#include "tools/top/top_view.hpp"

#include <langinfo.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <clocale>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <utility>

#include <fmt/format.h>

#include "captures/output_file.hpp"
#include "tools/live/live_capture.hpp"

#define NCURSES_NOMACROS
#include <curses.h>

namespace modtap::top {
namespace {

using std::chrono::steady_clock;
constexpr int escape = 27;
constexpr auto refresh_every = std::chrono::seconds(1);
constexpr size_t history_kept = 120;  // a followed register's values, one a refresh

// A size the environment gives (COLUMNS, LINES), where the shell exports it.
size_t exported_size(const char* variable, size_t otherwise) {
  const char* value = std::getenv(variable);
  const long number = value ? std::strtol(value, nullptr, 10) : 0;
  return number >= 10 && number <= 1000 ? static_cast<size_t>(number) : otherwise;
}

// The plain screen's size (a terminal that cannot draw, TERM=dumb, or a pipe): the terminal's
// own where the output is one, else COLUMNS and LINES, else 80 columns and 40 lines, so that
// a page never wraps on a terminal narrower than it.
std::pair<size_t, size_t> plain_size() {
  winsize size{};
  const bool terminal = isatty(STDOUT_FILENO) && ioctl(STDOUT_FILENO, TIOCGWINSZ, &size) == 0;
  const size_t columns = terminal && size.ws_col >= 10 ? size.ws_col : exported_size("COLUMNS", 80);
  const size_t lines = terminal && size.ws_row >= 10 ? size.ws_row : exported_size("LINES", 40);
  return {columns, lines};
}

// The screen as text: its lines without the spaces that pad them, and a blank line after.
std::string plain_page(const Snapshot& snapshot, const ViewState& view) {
  std::string page;
  const auto [columns, lines] = plain_size();
  for (const ScreenLine& line : lay_out(snapshot, view, columns, lines)) {
    std::string_view text(line.text);
    while (!text.empty() && text.back() == ' ') text.remove_suffix(1);
    page.append(text).push_back('\n');
  }
  page.push_back('\n');
  return page;
}

int attributes_of(Look look) {
  switch (look) {
    case Look::title:
      return A_REVERSE | A_BOLD;
    case Look::heading:
      return A_BOLD | A_UNDERLINE;
    case Look::selected:
      return A_REVERSE;
    case Look::warning:
      return COLOR_PAIR(2) | A_BOLD;
    case Look::error:
      return COLOR_PAIR(1) | A_BOLD;
    case Look::dim:
      return A_DIM;
    case Look::plain:
      return A_NORMAL;
  }
  return A_NORMAL;
}

bool terminal_can_draw() {
  const char* term = std::getenv("TERM");
  return isatty(STDIN_FILENO) && isatty(STDOUT_FILENO) && term && *term &&
         std::string_view(term) != "dumb";
}

// "modtap-top-20261127-051203.pcapng", in the folder modtap runs in.
std::string pcapng_name() {
  const std::time_t now = std::time(nullptr);
  std::tm local{};
  localtime_r(&now, &local);
  char name[64];
  std::strftime(name, sizeof name, "modtap-top-%Y%m%d-%H%M%S.pcapng", &local);
  return name;
}

// A register's last value as people read it, as the text output writes it.
std::string value_text(const RegisterKey& key, const LastValue& value) {
  fmt::memory_buffer text;
  append_value_text(text, value.as_register(key.table, key.address));
  return fmt::to_string(text);
}

// A slave's row: its counts, latencies, model, and its worst problem (`problems` come errors
// first, so the first of this slave's is its worst).
SlaveRow slave_row(uint8_t address, const SlaveStatistics& slave, const DeviceModel* model,
                   const std::vector<Problem>& problems) {
  SlaveRow row;
  row.address = address;
  const ExchangeCounts& c = slave.counts;
  row.requests = c.requests;
  row.answered_in_time = c.answered_in_time();
  row.timeouts = c.timeouts;
  row.retries = c.retries;
  row.exceptions = c.exceptions;
  row.bad_checks = c.bad_checks + c.garbled;
  if (slave.latency_ns.count()) {
    row.p50_ms = static_cast<double>(slave.latency_ns.percentile(50)) / 1e6;
    row.p99_ms = static_cast<double>(slave.latency_ns.percentile(99)) / 1e6;
  }
  row.last_answer_ns = slave.last_answer_ns;
  if (model) row.model = model->name;
  const auto worst = std::find_if(problems.begin(), problems.end(),
                                  [&](const Problem& p) { return p.slave == address; });
  if (worst != problems.end()) {
    row.problem = problem_info(worst->kind).name;
    row.severity = worst->severity;
  }
  return row;
}

}  // namespace

// The curses screen, while it is up.
class Terminal {
 public:
  Terminal() {
    screen_ = newterm(nullptr, stdout, stdin);
    if (!screen_) return;
    cbreak();  // Ctrl-C still stops the run, through its signal
    noecho();
    keypad(stdscr, TRUE);
    curs_set(0);
    wtimeout(stdscr, 100);
    if (has_colors()) {
      start_color();
      use_default_colors();
      init_pair(1, COLOR_RED, -1);
      init_pair(2, COLOR_YELLOW, -1);
    }
  }
  ~Terminal() {
    if (!screen_) return;
    endwin();
    delscreen(screen_);
  }
  bool up() const { return screen_ != nullptr; }
  void draw(const std::vector<ScreenLine>& lines) {
    werase(stdscr);
    for (size_t i = 0; i < lines.size(); ++i) {
      wattrset(stdscr, attributes_of(lines[i].look));
      mvwaddstr(stdscr, static_cast<int>(i), 0, lines[i].text.c_str());
      if (lines[i].mark_width)
        mvwchgat(stdscr, static_cast<int>(i), static_cast<int>(lines[i].mark_begin),
                 static_cast<int>(lines[i].mark_width), A_REVERSE | A_BOLD, 0, nullptr);
    }
    wattrset(stdscr, A_NORMAL);
    wrefresh(stdscr);
  }
  size_t width() const { return static_cast<size_t>(std::max(getmaxx(stdscr), 1)); }
  size_t height() const { return static_cast<size_t>(std::max(getmaxy(stdscr), 1)); }
  int key() { return wgetch(stdscr); }

 private:
  SCREEN* screen_ = nullptr;
};

TopView::TopView(TopSources sources, TopSettings settings)
    : sources_(std::move(sources)),
      settings_(std::move(settings)),
      // Ctrl-C ends a replay as it ends a live run: with the terminal given back.
      signalled_(live::stop_on_signals()) {
  std::setlocale(LC_ALL, "");
  view_.unicode = std::string_view(nl_langinfo(CODESET)) == "UTF-8";
  if (terminal_can_draw()) {
    terminal_ = std::make_unique<Terminal>();
    if (!terminal_->up()) terminal_.reset();
  }
  view_.keys = terminal_ != nullptr;
  thread_ = std::thread([this] { terminal_ ? run() : run_plain(); });
}

TopView::~TopView() {
  stop_screen();
}

void TopView::stop_screen() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  terminal_.reset();
}

void TopView::close() {
  stop_screen();
  if (write_failed_) std::rethrow_exception(write_failed_);
}

bool TopView::stopping() const {
  return stop_ || quit_ || signalled_;
}

bool TopView::pace(int64_t t_ns) {
  if (!replay_start_) {
    replay_start_ = steady_clock::now();
    replay_first_ns_ = t_ns;
  }
  const double speed = settings_.replay_speed.value_or(1.0);
  const auto due = *replay_start_ + std::chrono::nanoseconds(static_cast<int64_t>(
                                        static_cast<double>(t_ns - replay_first_ns_) / speed));
  while (!stopping() && steady_clock::now() < due)
    std::this_thread::sleep_for(
        std::min<steady_clock::duration>(due - steady_clock::now(), std::chrono::milliseconds(50)));
  return !stopping();
}

void TopView::end_of_capture(bool complete) {
  broken_ = !complete;
  ended_ = true;
  if (!terminal_) {
    stop_ = true;  // the plain screen prints its last one as it stops
    return;
  }
  while (!stopping()) std::this_thread::sleep_for(std::chrono::milliseconds(50));
}

void TopView::run() {
  auto next = steady_clock::now();
  bool was_ended = false;
  while (!stopping()) {
    const bool ended_now = ended_ && !was_ended;
    was_ended = ended_;
    const bool due = steady_clock::now() >= next;
    if ((due && !view_.paused) || ended_now) {
      snapshot_ = take(true);
      next = steady_clock::now() + refresh_every;
    }
    if (due || ended_now) draw();
    const int key = terminal_->key();
    if (key != ERR && handle_key(key)) draw();
  }
  if (quit_ && settings_.on_quit) settings_.on_quit();
}

void TopView::run_plain() {
  captures::OutputFile standard_output("-");
  auto next = steady_clock::now() + refresh_every;
  bool last = false;
  while (!last) {
    last = stop_ || signalled_;
    if (!last && steady_clock::now() < next) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      continue;
    }
    snapshot_ = take(true);
    try {
      standard_output.write(plain_page(snapshot_, view_));
      standard_output.flush();
    } catch (const captures::WriteError&) {
      // The reader went away (`| head`) or the disk is full: the run ends, and close() says so.
      write_failed_ = std::current_exception();
      quit_ = true;
      if (settings_.on_quit) settings_.on_quit();
      return;
    }
    next = steady_clock::now() + refresh_every;
  }
}

void TopView::draw() {
  sort_rows(snapshot_.slaves, view_.sort, view_.descending);
  const auto& rows = snapshot_.slaves;
  const auto at = std::find_if(rows.begin(), rows.end(),
                               [&](const SlaveRow& row) { return row.address == selected_; });
  view_.cursor = at == rows.end() ? 0 : static_cast<size_t>(at - rows.begin());
  if (at == rows.end() && !rows.empty()) selected_ = rows.front().address;
  terminal_->draw(lay_out(snapshot_, view_, terminal_->width(), terminal_->height()));
}

void TopView::move_cursor(int step) {
  const auto& rows = snapshot_.slaves;
  if (rows.empty()) return;
  const auto at = static_cast<int>(view_.cursor) + step;
  selected_ =
      rows[static_cast<size_t>(std::clamp(at, 0, static_cast<int>(rows.size()) - 1))].address;
}

// The `/` prompt's keys: the text typed, Enter applies it, Esc drops it.
void TopView::type_filter(int key) {
  std::string& text = *view_.typing;
  if (key == '\n' || key == KEY_ENTER) {
    apply_filter(text);
    view_.typing.reset();
  } else if (key == escape) {
    view_.typing.reset();
  } else if (key == KEY_BACKSPACE || key == 127 || key == 8) {
    if (!text.empty()) text.pop_back();
  } else if (key >= 32 && key < 127) {
    text += static_cast<char>(key);
  }
}

// True: the screen changes.
bool TopView::handle_key(int key) {
  struct Binding {
    std::vector<int> keys;
    void (*act)(TopView&);
    bool shows_other_records;  // a new snapshot: the panel shows the choice at once
  };
  static const Binding bindings[] = {
      {{'q'}, [](TopView& v) { v.quit_ = true; }, false},
      {{'?'}, [](TopView& v) { v.view_.help = true; }, false},
      {{KEY_UP, 'k'}, [](TopView& v) { v.move_cursor(-1); }, false},
      {{KEY_DOWN, 'j'}, [](TopView& v) { v.move_cursor(1); }, false},
      {{'\n', KEY_ENTER}, [](TopView& v) { v.view_.chosen = v.selected_; }, true},
      {{escape}, [](TopView& v) { v.view_.chosen.reset(); }, true},
      {{'<'}, [](TopView& v) { v.sort_by(-1); }, false},
      {{'>'}, [](TopView& v) { v.sort_by(1); }, false},
      {{'r'}, [](TopView& v) { v.view_.descending = !v.view_.descending; }, false},
      {{'p', ' '}, [](TopView& v) { v.view_.paused = !v.view_.paused; }, false},
      {{'/'}, [](TopView& v) { v.view_.typing = std::string(); }, false},
      {{'w'}, [](TopView& v) { v.toggle_writing(); }, true},
      {{KEY_RESIZE}, [](TopView&) {}, false},
  };
  if (view_.typing) {
    type_filter(key);
    return true;
  }
  if (view_.help) {  // any key closes the help
    view_.help = false;
    return true;
  }
  for (const Binding& binding : bindings) {
    if (std::find(binding.keys.begin(), binding.keys.end(), key) == binding.keys.end()) continue;
    view_.message.clear();
    binding.act(*this);
    if (binding.shows_other_records && !view_.paused) snapshot_ = take(false);
    return !quit_;
  }
  return false;
}

void TopView::sort_by(int step) {
  constexpr int last = static_cast<int>(column_count) - 1;
  view_.sort = static_cast<Column>(std::clamp(static_cast<int>(view_.sort) + step, 0, last));
}

void TopView::apply_filter(const std::string& text) {
  try {
    sources_.shared.read([&] { sources_.feed.set_filter(text); });
    view_.message.clear();
  } catch (const FilterError& e) {
    view_.message = fmt::format("filter: {}", e.what());
  }
}

void TopView::toggle_writing() {
  TopFeed& feed = sources_.feed;
  try {
    sources_.shared.read([&] {
      if (feed.writing()) {
        const uint64_t packets = feed.packets_written();
        feed.stop_writing();
        view_.message = fmt::format("wrote {} ({} packets)", feed.written_path(), packets);
      } else {
        feed.start_writing(pcapng_name());
        view_.message = fmt::format("writing what follows to {}", feed.written_path());
      }
    });
  } catch (const std::exception& e) {
    view_.message = fmt::format("cannot write: {}", e.what());
  }
}

// Line 1's word on the run: live, a replay and its pace, or how the replay ended.
std::string TopView::state_text() const {
  if (ended_) {
    const std::string ended = broken_ ? "the capture broke off" : "end of capture";
    return view_.keys ? ended + " (q quits)" : ended;
  }
  if (settings_.replay_speed) return fmt::format("replay x{:g}", *settings_.replay_speed);
  return "live";
}

Snapshot TopView::take(bool refresh) {
  Snapshot s;
  s.source = settings_.source;
  s.settings = settings_.settings;
  s.clock = settings_.clock;
  s.state = state_text();
  sources_.shared.read([&] {
    fill_numbers(s, refresh);
    const auto problems = sources_.problems();
    for (const Problem& p : problems)
      s.problems.push_back({p.severity, p.since_ns, p.text, p.slave});
    std::stable_sort(s.problems.begin(), s.problems.end(),
                     [](const auto& a, const auto& b) { return a.since_ns > b.since_ns; });
    const auto& evidence = sources_.evidence.slaves();
    sources_.statistics.for_each_slave([&](uint8_t address, const SlaveStatistics& slave) {
      const auto found = evidence.find(address);
      s.slaves.push_back(slave_row(
          address, slave, found == evidence.end() ? nullptr : found->second.model, problems));
    });
    const TopFeed& feed = sources_.feed;
    s.transactions = feed.recent().lines(view_.chosen);
    s.filter = feed.filter();
    if (feed.writing())
      s.writing =
          fmt::format("writing {} ({} packets)", feed.written_path(), feed.packets_written());
    fill_registers(s, refresh);
  });
  return s;
}

// The header's numbers; frames a second over the capture's time since the refresh before (a
// snapshot a key asks for in between keeps the rate it had).
void TopView::fill_numbers(Snapshot& s, bool refresh) {
  const BusStatistics& st = sources_.statistics;
  const TopFeed& feed = sources_.feed;
  s.frames = st.frames;
  s.bad_checks = st.bad_checks;
  s.noise_records = st.noise_records;
  s.noise_bytes = st.noise_bytes;
  s.bus_load = st.bus_load();
  s.now_ns = feed.last_t_ns().value_or(0);
  s.running_s = settings_.replay_speed
                    ? st.duration_s()
                    : std::chrono::duration<double>(steady_clock::now() - started_).count();
  // The first snapshot (a short replay may need no second) has the average so far.
  const double duration_s = st.duration_s();
  s.frames_per_s = previous_t_ns_   ? snapshot_.frames_per_s
                   : duration_s > 0 ? static_cast<double>(st.frames) / duration_s
                                    : 0.0;
  if (!refresh) return;
  if (previous_t_ns_ && s.now_ns > *previous_t_ns_)
    s.frames_per_s = static_cast<double>(feed.frames() - previous_frames_) /
                     (static_cast<double>(s.now_ns - *previous_t_ns_) / 1e9);
  previous_frames_ = feed.frames();
  previous_t_ns_ = s.now_ns;
}

// A register by its model's name, or by its number where no model names it.
std::string TopView::register_label(const RegisterKey& key, const LastValue& value) const {
  if (!value.name.empty()) return value.name;
  return fmt::format("{}", RegisterNumber{key.table, key.address, settings_.register_base});
}

// The chosen slave's registers, or the followed ones with their values, one a refresh.
void TopView::fill_registers(Snapshot& s, bool refresh) {
  const auto& registers = sources_.statistics.registers;
  if (view_.chosen) {
    for (const auto& [key, value] : registers)
      if (key.slave == *view_.chosen)
        s.registers.push_back({register_label(key, value), value_text(key, value), {}});
    return;
  }
  if (settings_.follow.empty()) return;
  for (const auto& [key, value] : registers) {
    if (!output::follows(settings_.follow, value.as_register(key.table, key.address))) continue;
    const std::string name = fmt::format("{} (slave {})", register_label(key, value), key.slave);
    auto& history = history_[name];
    if (refresh) history.push_back(value.value);
    if (history.size() > history_kept) history.erase(history.begin());
    s.registers.push_back({name, value_text(key, value), history});
  }
}

}  // namespace modtap::top
