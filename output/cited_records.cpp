#include "output/cited_records.hpp"

namespace modtap::output {

CitedRecords::CitedRecords(ProblemEvidence& evidence, const std::vector<ChannelInfo>& channels,
                           RegisterBase base, const RecordClock* clock)
    : evidence_(evidence),
      clock_(clock),
      text_(text_out_, channels, TextOptions{false, TimeFormat::relative, base, &clock_.get()}) {}

template <typename Render>
void CitedRecords::keep(std::optional<uint64_t> request, Render render) {
  if (const auto withdrawn = evidence_.withdrawn()) may_cite_.erase(*withdrawn);
  const auto cited = evidence_.cited();
  const auto index = cited ? cited : evidence_.may_cite();
  if (!index || lines_.size() + may_cite_.size() >= max_kept) return;
  if (request && request_.index == *request && *request != 0 && !request_raw_.empty())
    text_.on_frame(request_);
  render();
  fmt::memory_buffer& line = text_out_.buffer();
  (cited ? lines_ : may_cite_)[*index].append(line.data(), line.size());
  line.clear();
}

std::map<uint64_t, std::string> CitedRecords::lines() const {
  std::map<uint64_t, std::string> all = lines_;
  all.insert(may_cite_.begin(), may_cite_.end());
  return all;
}

// A copy that outlives the framer's buffer, without what points into other stages' storage.
void CitedRecords::remember_request(const Frame& frame) {
  request_raw_.assign(frame.raw.begin(), frame.raw.end());
  request_adu_.assign(frame.adu.begin(), frame.adu.end());
  request_ = frame;
  request_.raw = request_raw_;
  request_.adu = request_adu_;
  request_.request_pdu = {};
  request_.meaning = nullptr;
  request_.decoded = nullptr;
}

void CitedRecords::on_frame(const Frame& frame) {
  clock_.see(frame.t_ns);
  evidence_.on_frame(frame);
  keep(frame.request, [&] { text_.on_frame(frame); });
  if (frame.role == Role::request && frame.check_ok) remember_request(frame);
}

void CitedRecords::on_noise(const Noise& noise) {
  clock_.see(noise.t_ns);
  evidence_.on_noise(noise);
  keep(noise.request, [&] { text_.on_noise(noise); });
}

void CitedRecords::on_timeout(const Timeout& timeout) {
  clock_.see(timeout.t_ns);
  evidence_.on_timeout(timeout);
  keep(timeout.request, [&] { text_.on_timeout(timeout); });
}

}  // namespace modtap::output
