#include "captures/raw_recorder.hpp"

namespace modtap::captures {

namespace {

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

constexpr int raw_dlt = 147;  // DLT_USER0: what modtap -r reads as timed chunks

}  // namespace

RawRecorder::RawRecorder(const std::string& path, std::vector<ChannelInfo> channels,
                         const RingLimits& limits)
    : channels_(std::move(channels)), as_pcapng_(ends_with(path, ".pcapng")), ring_(path, limits) {
  if (!limits.rotates()) begin_file(ring_.begin(0));
}

void RawRecorder::write(const Chunk& chunk, bool between_frames) {
  const uint64_t bytes = bytes_in_file();
  if ((between_frames && ring_.due(chunk.t_ns, bytes)) || ring_.overdue(chunk.t_ns, bytes))
    begin_file(ring_.begin(chunk.t_ns));
  if (pcapng_) {
    pcapng_->write_packet(interfaces_.at(chunk.channel), chunk.t_ns, chunk.bytes,
                          PacketDirection::unknown, {});
  } else {
    const bool named = channels_.size() > 1;
    hexlog_->write(chunk, named ? channels_.at(chunk.channel).name : std::string());
  }
}

void RawRecorder::begin_file(const std::string& path) {
  close_file();
  if (as_pcapng_) {
    pcapng_ = std::make_unique<PcapngWriter>(path);
    interfaces_.clear();
    for (const auto& channel : channels_)
      interfaces_.push_back(pcapng_->add_interface(raw_dlt, channel.name));
  } else {
    hexlog_ = std::make_unique<HexlogWriter>(path);
  }
}

uint64_t RawRecorder::bytes_in_file() const {
  if (pcapng_) return pcapng_->bytes_written();
  return hexlog_ ? hexlog_->bytes_written() : 0;
}

void RawRecorder::flush() {
  if (pcapng_) pcapng_->flush();
}

void RawRecorder::close_file() {
  if (pcapng_) pcapng_->close();
  if (hexlog_) hexlog_->close();
}

void RawRecorder::close() {
  if (ring_.files_begun() == 0) begin_file(ring_.begin_now());
  close_file();
}

}  // namespace modtap::captures
