#include "tools/modtap/cited_records.hpp"

namespace modtap::tools {

CitedRecords::CitedRecords(decoder::ProblemEvidence& evidence,
                           const std::vector<decoder::ChannelInfo>& channels,
                           decoder::RegisterBase base, const decoder::RecordClock* clock)
    : evidence_(evidence),
      own_clock_used_(clock == nullptr),
      text_(text_out_, channels,
            TextOptions{false, TimeFormat::relative, base, clock ? clock : &own_clock_}) {}

template <typename Render>
void CitedRecords::keep(Render render) {
  const auto index = evidence_.cited();
  if (!index || lines_.size() >= max_kept) return;
  render();
  fmt::memory_buffer& line = text_out_.buffer();
  lines_[*index].append(line.data(), line.size());
  line.clear();
}

void CitedRecords::on_frame(const decoder::Frame& frame) {
  if (own_clock_used_) own_clock_.see(frame.t_ns);
  evidence_.on_frame(frame);
  keep([&] { text_.on_frame(frame); });
}

void CitedRecords::on_noise(const decoder::Noise& noise) {
  if (own_clock_used_) own_clock_.see(noise.t_ns);
  evidence_.on_noise(noise);
  keep([&] { text_.on_noise(noise); });
}

void CitedRecords::on_timeout(const decoder::Timeout& timeout) {
  if (own_clock_used_) own_clock_.see(timeout.t_ns);
  evidence_.on_timeout(timeout);
  keep([&] { text_.on_timeout(timeout); });
}

}  // namespace modtap::tools
