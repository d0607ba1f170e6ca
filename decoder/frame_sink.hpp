// What a framer hands its records to, and what it may ask back.
#pragma once

#include "decoder/records.hpp"

namespace modtap::decoder {

// The request the bus is waiting on, if any: lets a framer try the response reading first.
struct Expectation {
  bool pending = false;
  uint8_t slave = 0;
  uint8_t function = 0;
  uint16_t echo_size = 0;  // ADU size of an echo whose length its header does not tell, or 0
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

}  // namespace modtap::decoder
