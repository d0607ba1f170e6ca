#include "decoder/protocol/records.hpp"

#include "decoder/protocol/checksum.hpp"

namespace modtap {

uint16_t Frame::wire_check() const {
  if (adu.size() < check_size()) return 0;
  return mode == Mode::rtu ? wire_crc(adu) : adu.back();
}

}  // namespace modtap
