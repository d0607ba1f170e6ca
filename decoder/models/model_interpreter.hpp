// The pipeline stage that reads each frame through its slave's device model and hands the
// frame on with its Meaning attached. It also notices a device that names itself.
#pragma once

#include <map>
#include <vector>

#include "decoder/models/register_meaning.hpp"
#include "decoder/protocol/matcher.hpp"
#include "decoder/protocol/record_sink.hpp"

namespace modtap {

struct ModelChoice {
  const DeviceModel* bus = nullptr;                // for slaves not named below
  std::map<uint8_t, const DeviceModel*> by_slave;  // --model SLAVE=MODEL
};

// The time-out each slave's model sets (N3: 400 ms), for the matcher; 0 for slaves whose model
// sets none.
SlaveTimeouts model_timeouts(const ModelChoice& choice);

class ModelInterpreter final : public RecordSink {
 public:
  // `known` are the models whose identification rule may match the traffic; `clock` is the
  // source's, which says whether a turnaround is timed well enough to hold against a manual.
  // `list_unnamed`: see Meaning::lists_unnamed.
  // `timeouts`: the matcher's table of the slaves' own time-outs, given a slave's model's when
  // it identifies itself (none: the user told the time-out, which stands for every slave).
  ModelInterpreter(std::vector<const DeviceModel*> known, ModelChoice choice, ClockQuality clock,
                   RecordSink& next, bool list_unnamed = true, SlaveTimeouts* timeouts = nullptr);

  void on_frame(const Frame& frame) override;
  void on_noise(const Noise& noise) override { next_.on_noise(noise); }
  void on_timeout(const Timeout& timeout) override { next_.on_timeout(timeout); }

  const DeviceModel* model_for(uint8_t slave) const;

 private:
  void identify(const Frame& frame);
  void check_turnaround(const DeviceModel& model, const Frame& frame);

  std::vector<const DeviceModel*> known_;
  ModelChoice choice_;
  bool exact_clock_;
  SlaveTimeouts* timeouts_;
  std::map<uint8_t, const DeviceModel*> identified_;
  RecordSink& next_;
  Meaning meaning_;
};

}  // namespace modtap
