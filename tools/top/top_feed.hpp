// What `modtap top` keeps of the records beside the statistics: the latest transactions as
// text lines (of the bus, and of each slave), what `/` lets through, and the pcapng file `w`
// writes. A sink of the capture's thread; the screen's thread reads it under the statistics'
// lock (SharedStatistics), so the capture never waits for the terminal.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "decoder/filter/display_filter.hpp"
#include "decoder/protocol/record_sink.hpp"
#include "output/output.hpp"
#include "output/pcapng_sink.hpp"
#include "output/text_sink.hpp"

namespace modtap::top {

// The lines of the latest records, at most `kept` of them.
class RecentLines final : public RecordSink {
 public:
  static constexpr size_t kept = 200;  // a tall terminal's panel, and some

  RecentLines(const std::vector<ChannelInfo>& channels, const output::TextOptions& options);
  void on_frame(const Frame& frame) override;
  void on_noise(const Noise& noise) override;
  void on_timeout(const Timeout& timeout) override;

  // The bus's lines, or one slave's, oldest first.
  std::vector<std::string> lines(std::optional<uint8_t> slave) const;
  void clear();

 private:
  void keep(std::optional<uint8_t> slave);

  output::Output text_;
  output::TextSink sink_;
  std::deque<std::string> bus_;
  std::map<uint8_t, std::deque<std::string>> slaves_;
};

class TopFeed final : public RecordSink {
 public:
  // `filter_for` compiles a `/` filter as -Y does (it throws FilterError).
  TopFeed(const std::vector<ChannelInfo>& channels, const output::TextOptions& text,
          const output::PcapngOptions& pcapng,
          std::function<DisplayFilter(const std::string&)> filter_for);

  void on_frame(const Frame& frame) override;
  void on_noise(const Noise& noise) override;
  void on_timeout(const Timeout& timeout) override;

  const RecentLines& recent() const { return recent_; }
  uint64_t frames() const { return frames_; }
  std::optional<int64_t> last_t_ns() const { return last_t_ns_; }

  // The transactions shown from now on: those `text` matches (empty: all). Throws FilterError.
  void set_filter(const std::string& text);
  const std::string& filter() const { return filter_text_; }

  // `w`: what follows goes to `path` as pcapng, until stop_writing(). Throws WriteError.
  void start_writing(const std::string& path);
  void stop_writing();
  bool writing() const { return pcapng_ != nullptr; }
  uint64_t packets_written() const { return pcapng_ ? pcapng_->packets() : 0; }
  const std::string& written_path() const { return written_path_; }

 private:
  RecordSink& shown() { return filter_ ? static_cast<RecordSink&>(*filter_) : recent_; }
  void saw(int64_t t_ns) { last_t_ns_ = last_t_ns_ ? std::max(*last_t_ns_, t_ns) : t_ns; }

  const std::vector<ChannelInfo>& channels_;
  output::PcapngOptions pcapng_options_;
  std::function<DisplayFilter(const std::string&)> filter_for_;
  RecentLines recent_;
  std::unique_ptr<FilterStage> filter_;
  std::string filter_text_;
  std::unique_ptr<output::PcapngFiles> pcapng_;
  std::string written_path_;
  uint64_t frames_ = 0;
  std::optional<int64_t> last_t_ns_;
};

}  // namespace modtap::top
