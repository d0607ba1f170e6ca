#include "decoder/records.hpp"

#include "decoder/checksum.hpp"

namespace modtap::decoder {

uint16_t Frame::wire_check() const {
  if (adu.size() < check_size()) return 0;
  return mode == Mode::rtu ? wire_crc(adu) : adu.back();
}

}  // namespace modtap::decoder
