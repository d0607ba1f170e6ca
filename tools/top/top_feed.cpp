#include "tools/top/top_feed.hpp"

#include <string_view>

namespace modtap::top {
namespace {

void keep_line(std::deque<std::string>& lines, std::string_view line) {
  if (lines.size() == RecentLines::kept) lines.pop_front();
  lines.emplace_back(line);
}

}  // namespace

RecentLines::RecentLines(const std::vector<ChannelInfo>& channels,
                         const output::TextOptions& options)
    : sink_(text_, channels, options) {}

void RecentLines::on_frame(const Frame& frame) {
  sink_.on_frame(frame);
  keep(frame.device());
}

void RecentLines::on_noise(const Noise& noise) {
  sink_.on_noise(noise);
  keep(noise.request ? std::optional<uint8_t>(noise.request_slave) : std::nullopt);
}

void RecentLines::on_timeout(const Timeout& timeout) {
  sink_.on_timeout(timeout);
  keep(timeout.slave);
}

// The text sink's line (without -V, one per record), kept for the bus and for its slave.
void RecentLines::keep(std::optional<uint8_t> slave) {
  auto& buffer = text_.buffer();
  std::string_view line(buffer.data(), buffer.size());
  while (!line.empty() && line.back() == '\n') line.remove_suffix(1);
  keep_line(bus_, line);
  if (slave && *slave != 0) keep_line(slaves_[*slave], line);
  buffer.clear();
}

std::vector<std::string> RecentLines::lines(std::optional<uint8_t> slave) const {
  if (!slave) return {bus_.begin(), bus_.end()};
  const auto found = slaves_.find(*slave);
  if (found == slaves_.end()) return {};
  return {found->second.begin(), found->second.end()};
}

void RecentLines::clear() {
  bus_.clear();
  slaves_.clear();
}

TopFeed::TopFeed(const std::vector<ChannelInfo>& channels, const output::TextOptions& text,
                 const output::PcapngOptions& pcapng,
                 std::function<DisplayFilter(const std::string&)> filter_for)
    : channels_(channels),
      pcapng_options_(pcapng),
      filter_for_(std::move(filter_for)),
      recent_(channels, text) {}

void TopFeed::on_frame(const Frame& frame) {
  ++frames_;
  saw(frame.t_ns);
  shown().on_frame(frame);
  if (pcapng_) pcapng_->on_frame(frame);
}

void TopFeed::on_noise(const Noise& noise) {
  saw(noise.t_ns);
  shown().on_noise(noise);
  if (pcapng_) pcapng_->on_noise(noise);
}

void TopFeed::on_timeout(const Timeout& timeout) {
  saw(timeout.t_ns);
  shown().on_timeout(timeout);
  if (pcapng_) pcapng_->on_timeout(timeout);
}

// The lines shown so far were chosen by the filter before: they go, and the panel fills again
// with what the new one lets through.
void TopFeed::set_filter(const std::string& text) {
  if (text.find_first_not_of(" \t") == std::string::npos) {
    filter_.reset();
    filter_text_.clear();
  } else {
    filter_ = std::make_unique<FilterStage>(filter_for_(text), recent_);
    filter_text_ = text;
  }
  recent_.clear();
}

void TopFeed::start_writing(const std::string& path) {
  pcapng_ = std::make_unique<output::PcapngFiles>(path, captures::RingLimits{}, channels_,
                                                  pcapng_options_);
  written_path_ = path;
}

void TopFeed::stop_writing() {
  if (!pcapng_) return;
  auto files = std::move(pcapng_);
  files->close();
}

}  // namespace modtap::top
