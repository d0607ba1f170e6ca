// A moment as the outputs print it: whole seconds and the microseconds after them, rounded to
// the microsecond. A header's or a sentence's whole second is this one too, so that a record
// placed 0.3 us before 09:00:00, printed 09:00:00.000000, is not said to come at 08:59:59.
#pragma once

#include <cstdint>

namespace modtap {

struct SecondsAndMicros {
  int64_t second;
  int64_t micros;
};

// Rounded to the microsecond, before 1970 too.
inline SecondsAndMicros seconds_and_micros(int64_t t_ns) {
  const int64_t us = t_ns >= 0 ? (t_ns + 500) / 1000 : -((-t_ns + 500) / 1000);
  const int64_t second = us >= 0 ? us / 1'000'000 : (us + 1) / 1'000'000 - 1;
  return {second, us - second * 1'000'000};
}

}  // namespace modtap
