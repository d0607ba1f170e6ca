#include "output/csv_sink.hpp"

#include <ctime>

#include <fmt/chrono.h>

#include "decoder/models/record_fields.hpp"
#include "output/render.hpp"

namespace modtap::output {

namespace {

// A CSV field: quoted when it holds a comma, a quote or a line break (RFC 4180).
void append_field(fmt::memory_buffer& out, std::string_view text) {
  if (text.find_first_of(",\"\r\n") == std::string_view::npos) {
    out.append(text);
    return;
  }
  out.push_back('"');
  for (char c : text) {
    if (c == '"') out.push_back('"');
    out.push_back(c);
  }
  out.push_back('"');
}

}  // namespace

CsvSink::CsvSink(Output& out, std::vector<FollowedRegister> follow, TimeFormat time_format,
                 RegisterBase base, const RecordClock* clock)
    : out_(out), follow_(std::move(follow)), time_format_(time_format), base_(base), clock_(clock) {
  out_.print("t,slave,address,name,value,unit,raw,text\n");
}

// Seconds since the capture's first record (the text's time column), with -t a since the Unix
// epoch: numbers a spreadsheet or a plotting tool takes as they are; with -t ad the local date
// and time, as the text prints them, which spreadsheets read as a date.
void CsvSink::time(int64_t t_ns) {
  if (time_format_ == TimeFormat::absolute) {
    out_.print(FMT_COMPILE("{}"), Fixed{t_ns, 9, 6});
    return;
  }
  if (time_format_ == TimeFormat::absolute_date) {
    const auto [second, micros] = seconds_and_micros(t_ns);
    std::tm local{};
    const auto when = static_cast<std::time_t>(second);
    localtime_r(&when, &local);
    out_.print("{:%Y-%m-%d %H:%M:%S}.{:06}", local, micros);
    return;
  }
  const RecordClock& clock = clock_.get();
  out_.print(FMT_COMPILE("{}"), Fixed{t_ns - clock.first_ns.value_or(t_ns), 9, 6});
}

void CsvSink::on_frame(const Frame& frame) {
  see(frame.t_ns);
  if (!states_values(frame)) return;
  if (!may_identify_) return write_rows(frame);
  const SlaveNaming& naming = naming_of(frame);
  if (held_.empty() && naming.state == SlaveNaming::State::settled) return write_rows(frame);
  hold(frame);
  release();
}

void CsvSink::write_rows(const Frame& frame) {
  const RecordFields f = gather_fields(frame, no_pdu_fields);
  auto& buf = out_.buffer();
  for (const RegisterValue& reg : f.registers) {
    if (!follows(follow_, reg)) continue;
    time(f.t_ns);
    out_.print(FMT_COMPILE(",{},{},"), f.slave, RegisterNumber{reg.table, reg.address, base_});
    append_field(buf, reg.name);
    buf.push_back(',');
    append_number(buf, reg.value, reg.decimals);
    buf.push_back(',');
    append_field(buf, reg.unit);
    out_.print(FMT_COMPILE(",{},"), reg.raw);
    append_field(buf, reg.text);  // an enumeration's or a bit field's meaning
    buf.push_back('\n');
  }
  out_.end_record();
}

void CsvSink::hold_until_identified(std::function<bool(uint8_t)> may_identify) {
  may_identify_ = std::move(may_identify);
}

// A slave identifies itself where its frame comes read through another model than its frames
// before (only the model stage's identification changes a slave's model, no --model naming
// it): the frames it holds are read through that model, from the first on.
const CsvSink::SlaveNaming& CsvSink::naming_of(const Frame& frame) {
  using State = SlaveNaming::State;
  SlaveNaming& naming = naming_[frame.slave()];
  if (naming.state == State::unseen) {
    naming.state = may_identify_(frame.slave()) ? State::waiting : State::settled;
    naming.model = frame.meaning->model;
  }
  if (naming.state != State::waiting) return naming;
  if (frame.meaning->model != naming.model) {
    for (HeldFrame& held : held_)
      if (held.frame.slave() == frame.slave()) held.model = frame.meaning->model;
    naming.state = State::settled;
  } else if (++naming.answers >= answers_to_identify) {
    naming.state = State::settled;
  }
  return naming;
}

void CsvSink::hold(const Frame& frame) {
  HeldFrame& held =
      held_.emplace_back(HeldFrame{frame,
                                   frame.meaning->model,
                                   {frame.adu.begin(), frame.adu.end()},
                                   {frame.request_pdu.begin(), frame.request_pdu.end()}});
  held.frame.adu = held.adu;
  held.frame.request_pdu = held.request_pdu;
  held.frame.raw = {};
  held.frame.meaning = nullptr;
  held.frame.decoded = nullptr;
  // The oldest waits no longer than the hold's room allows: its slave is settled as it reads.
  while (held_.size() > max_held) {
    naming_[held_.front().frame.slave()].state = SlaveNaming::State::settled;
    release();
  }
}

// Writes the held frames from the oldest on, while their slave's naming is settled.
void CsvSink::release() {
  while (!held_.empty()) {
    HeldFrame& held = held_.front();
    if (naming_[held.frame.slave()].state != SlaveNaming::State::settled) return;
    interpret(*held.model, held.frame, reread_);
    held.frame.meaning = &reread_;
    write_rows(held.frame);
    held_.pop_front();
  }
}

void CsvSink::finish() {
  for (SlaveNaming& naming : naming_)
    if (naming.state == SlaveNaming::State::waiting) naming.state = SlaveNaming::State::settled;
  release();
}

}  // namespace modtap::output
