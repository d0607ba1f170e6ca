// What a framer hands its records to, and what it may ask back.
#pragma once

#include <span>

#include "decoder/protocol/records.hpp"

namespace modtap {

// The request the bus is waiting on, if any: lets a framer try the response reading first.
struct Expectation {
  bool pending = false;
  uint8_t slave = 0;
  uint8_t function = 0;
  // The request's ADU size where every good answer is the request again (ResponsePrefix::
  // echoes_request), else 0: the answer's length where its own header does not tell it.
  uint16_t echo_size = 0;
  // The request's end was in doubt (`ambiguous-end`, a byte longer or shorter): its echo's is.
  bool echo_end_in_doubt = false;
  std::span<const uint8_t> request_pdu;  // the pending request's PDU, valid while it is pending
  // A copy of the request that starts before this is its answer, not the master's retry (a
  // master repeats only after its time-out); 0 where the source has no clock.
  int64_t retry_from_ns = 0;
};

class FrameSink {
 public:
  virtual ~FrameSink() = default;
  // Spans inside the records are valid only during the call.
  virtual void on_frame(Frame& frame) = 0;
  virtual void on_noise(Noise& noise) = 0;
  // A live view of what the bus waits for; framers keep the reference and read it per frame.
  virtual const Expectation& expectation() const {
    static const Expectation nothing;
    return nothing;
  }
};

}  // namespace modtap
