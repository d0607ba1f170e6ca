// -T csv: register values over time, as the master reads and writes them, one row per value:
// what ModbusScope plots, from a bus modtap only listens to. --follow picks registers by name or
// address; without it every register read or written is a row. A write's echo response adds no
// row (its values are the request's).
#pragma once

#include <array>
#include <deque>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "decoder/models/register_meaning.hpp"
#include "decoder/protocol/record_sink.hpp"
#include "decoder/protocol/register_numbering.hpp"
#include "output/followed_registers.hpp"
#include "output/output.hpp"
#include "output/text_sink.hpp"

namespace modtap::output {

class CsvSink final : public RecordSink {
 public:
  // `clock`: every record's, kept before a filter, so `t` counts from the capture's first
  // record as without the filter; none: the sink keeps the clock of the records it is given.
  CsvSink(Output& out, std::vector<FollowedRegister> follow, TimeFormat time_format,
          RegisterBase base = RegisterBase::hex, const RecordClock* clock = nullptr);

  void on_frame(const Frame& frame) override;
  void on_noise(const Noise& noise) override { see(noise.t_ns); }
  void on_timeout(const Timeout& timeout) override { see(timeout.t_ns); }

  // Reading a file, where no one waits for a row: the rows of a slave that `may_identify`
  // (one no --model names) wait until it identifies itself, so that they are named from its
  // first row, or until its answers show it does not: a master reads a device's
  // identification with its first requests. Every row after a held one waits too, so the file
  // stays in time order. At most `max_held` frames wait.
  void hold_until_identified(std::function<bool(uint8_t)> may_identify);
  // The end of the records: the rows still held are written, in the reading they have.
  void finish();

  // How many answers stating values a slave gives before it is taken not to identify itself.
  static constexpr unsigned answers_to_identify = 8;
  static constexpr size_t max_held = 8192;

 private:
  void see(int64_t t_ns) { clock_.see(t_ns); }
  void time(int64_t t_ns);
  void write_rows(const Frame& frame);

  // A slave's naming, as the hold sees it: whether its rows may still be named, and by whom.
  struct SlaveNaming {
    enum class State : uint8_t { unseen, waiting, settled } state = State::unseen;
    unsigned answers = 0;
    const DeviceModel* model = nullptr;  // what its frames came read through
  };
  // A frame that waits, with its bytes: re-read through its slave's model when written.
  struct HeldFrame {
    Frame frame;
    const DeviceModel* model;  // its slave's, as it settles
    std::vector<uint8_t> adu, request_pdu;
  };
  const SlaveNaming& naming_of(const Frame& frame);
  void hold(const Frame& frame);
  void release();

  std::function<bool(uint8_t)> may_identify_;  // empty: no rows are held
  std::array<SlaveNaming, 256> naming_{};
  std::deque<HeldFrame> held_;
  Meaning reread_;  // a held frame's reading, as it is written

  Output& out_;
  std::vector<FollowedRegister> follow_;
  TimeFormat time_format_;
  RegisterBase base_;
  SinkClock clock_;
};

}  // namespace modtap::output
