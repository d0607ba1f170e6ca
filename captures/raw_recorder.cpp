#include "captures/raw_recorder.hpp"

namespace modtap::captures {

namespace {

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

constexpr int raw_dlt = 147;  // DLT_USER0: what modtap -r reads as timed chunks

}  // namespace

RawRecorder::RawRecorder(const std::string& path, std::vector<decoder::ChannelInfo> channels,
                         int64_t char_time_ns)
    : channels_(std::move(channels)) {
  if (ends_with(path, ".pcapng")) {
    pcapng_ = std::make_unique<PcapngWriter>(path);
    for (const auto& channel : channels_)
      interfaces_.push_back(pcapng_->add_interface(raw_dlt, channel.name));
  } else {
    hexlog_ = std::make_unique<HexlogWriter>(path, char_time_ns);
  }
}

void RawRecorder::write(const decoder::Chunk& chunk) {
  if (pcapng_) {
    pcapng_->write_packet(interfaces_.at(chunk.channel), chunk.t_ns, chunk.bytes,
                          PacketDirection::unknown, {});
  } else {
    const bool named = channels_.size() > 1;
    hexlog_->write(chunk, named ? channels_.at(chunk.channel).name : std::string());
  }
}

void RawRecorder::flush() {
  if (pcapng_) pcapng_->flush();
}

void RawRecorder::close() {
  if (pcapng_) pcapng_->close();
  if (hexlog_) hexlog_->close();
}

}  // namespace modtap::captures
