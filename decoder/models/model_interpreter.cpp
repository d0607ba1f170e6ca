#include "decoder/models/model_interpreter.hpp"

#include <fmt/format.h>

#include "decoder/protocol/bytes.hpp"
#include "decoder/protocol/function_codes.hpp"

namespace modtap {

SlaveTimeouts model_timeouts(const ModelChoice& choice) {
  SlaveTimeouts timeouts{};
  for (unsigned slave = 1; slave <= 255; ++slave) {
    const auto it = choice.by_slave.find(static_cast<uint8_t>(slave));
    const DeviceModel* model = it != choice.by_slave.end() ? it->second : choice.bus;
    if (model && model->response_timeout_ns)
      timeouts[static_cast<uint8_t>(slave)] = *model->response_timeout_ns;
  }
  return timeouts;
}

ModelInterpreter::ModelInterpreter(std::vector<const DeviceModel*> known, ModelChoice choice,
                                   ClockQuality clock, RecordSink& next, bool list_unnamed,
                                   SlaveTimeouts* timeouts)
    : known_(std::move(known)),
      choice_(std::move(choice)),
      exact_clock_(clock == ClockQuality::per_byte),
      timeouts_(timeouts),
      next_(next) {
  meaning_.lists_unnamed = list_unnamed;
}

const DeviceModel* ModelInterpreter::model_for(uint8_t slave) const {
  if (auto it = choice_.by_slave.find(slave); it != choice_.by_slave.end()) return it->second;
  if (auto it = identified_.find(slave); it != identified_.end()) return it->second;
  return choice_.bus;
}

void ModelInterpreter::on_frame(const Frame& frame) {
  const DeviceModel* model = model_for(frame.slave());
  // A frame cut short or run into holds no values to trust.
  if (!model || frame.damage == Damage::cut || frame.damage == Damage::collision)
    return next_.on_frame(frame);
  interpret(*model, frame, meaning_);
  check_turnaround(*model, frame);
  identify(frame);
  Frame annotated = frame;
  annotated.meaning = &meaning_;
  next_.on_frame(annotated);
}

// A manual's least turnaround holds only against a clock that times each byte: one per read
// may be late by more than the 10 ms the drives' manuals ask for.
void ModelInterpreter::check_turnaround(const DeviceModel& model, const Frame& frame) {
  if (!exact_clock_ || !model.min_turnaround_ns || frame.role != Role::response ||
      !frame.latency_ns || *frame.latency_ns >= *model.min_turnaround_ns)
    return;
  meaning_.findings.add(RuleKind::early_response, std::nullopt,
                        "answered {:.3f} ms after the request; {} answers no sooner than {} ms",
                        static_cast<double>(*frame.latency_ns) / 1e6, model.name,
                        *model.min_turnaround_ns / 1'000'000);
}

// A read response that covers a model's identification register with its value names the
// device: from then on the slave is decoded with that model, unless the user chose one.
void ModelInterpreter::identify(const Frame& frame) {
  if (frame.role != Role::response || !frame.check_ok || frame.is_exception()) return;
  const auto read = function_code(frame.function()).response_values(frame.pdu(), frame.request_pdu);
  if (!read || read->write || read->data != RegisterAccess::Data::words) return;
  for (const DeviceModel* model : known_) {
    const auto& id = model->identification;
    if (!id || id->address < read->start || id->address >= read->start + read->count) continue;
    if (be16(read->values, 2 * (id->address - read->start)) != id->value) continue;
    const uint8_t slave = frame.slave();
    const DeviceModel* chosen = model_for(slave);
    if (chosen == model) return;
    std::string text = fmt::format("slave {} identifies as {} ({:04X}H = {:04X}H)", slave,
                                   model->name, id->address, id->value);
    if (choice_.by_slave.count(slave)) {
      text += fmt::format(", but is decoded as {}", chosen ? chosen->name : "nothing");
    } else {
      identified_[slave] = model;
      if (timeouts_) (*timeouts_)[slave] = model->response_timeout_ns.value_or(0);
      interpret(*model, frame, meaning_);
      text += "; decoded as such from here on";
    }
    meaning_.findings.add(RuleKind::identified, id->address, "{}", text);
    return;
  }
}

}  // namespace modtap
