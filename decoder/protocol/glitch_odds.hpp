// What a bus has shown of its drivers' glitches (a lone 0x00 or 0xFF between frames, put on
// the line by a driver turning on), weighed against how often a frame's own byte would look the
// same by chance. The RTU framer asks it where the bytes alone cannot tell the two readings
// apart; each question is the odds of the glitch reading and the margin it must clear, and why.
#pragma once

#include <cstdint>

namespace modtap {

// What the bus has shown of its glitches, against a damaged answer's last byte being a 0x00 or
// 0xFF by chance: fewer (quiet), too few frames to tell (unknown), or more (glitchy).
enum class GlitchHabit : uint8_t { quiet, unknown, glitchy };

class GlitchOdds {
 public:
  void frame() { ++frames_; }  // a frame with a good check
  void glitch(uint8_t byte) {
    ++glitches_;
    zero_glitches_ += byte == 0x00;
  }

  // A frame whose CRC ends in 0x00, or the frame one byte shorter and a 0x00 glitch: a CRC ends
  // in 0x00 one time in 256. Both readings keep a good CRC, so the glitch reading, which breaks
  // a frame that checks, must be 16 times likelier: 0x00 glitches with more than 1 frame in
  // 16, once 16 frames have shown it.
  bool zero_glitch_likelier() const {
    return frames_ >= zero_glitch_odds &&
           zero_glitches_ * crc_ends_in_zero > frames_ * zero_glitch_odds;
  }

  // A damaged answer's last byte, 0x00 or 0xFF, before the next frame: a data byte is one of
  // those 2 times in 256. Neither reading keeps a good check, so even odds decide: glitches
  // with more than 1 frame in 128.
  bool trailing_glitch_likelier() const {
    return glitches_ * glitch_byte_by_chance > frames_ * trailing_glitch_odds;
  }

  // Too few frames to tell: no glitch yet, where 128 frames without one would put the bus's
  // rate below the chance above by the count alone.
  bool unknown() const { return glitches_ == 0 && frames_ < glitch_byte_by_chance; }
  GlitchHabit habit() const {
    if (trailing_glitch_likelier()) return GlitchHabit::glitchy;
    return unknown() ? GlitchHabit::unknown : GlitchHabit::quiet;
  }

 private:
  static constexpr uint64_t crc_ends_in_zero = 256;       // 1 in 256
  static constexpr uint64_t glitch_byte_by_chance = 128;  // 2 in 256
  static constexpr uint64_t zero_glitch_odds = 16;
  static constexpr uint64_t trailing_glitch_odds = 1;

  uint64_t frames_ = 0;
  uint64_t glitches_ = 0;       // lone 0x00 or 0xFF bytes between frames
  uint64_t zero_glitches_ = 0;  // of them, 0x00
};

}  // namespace modtap
