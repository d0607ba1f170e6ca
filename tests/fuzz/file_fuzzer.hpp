// Hands a fuzzer's bytes to a reader that takes a path. The bytes live in one anonymous memory
// file per process, opened by its /proc path: nothing is left in /tmp however the fuzzer ends
// (libFuzzer leaves through _Exit on an interrupt or a crash, past any clean-up).
#pragma once

#include <sys/mman.h>
#include <unistd.h>

#include <cstdlib>
#include <string>

namespace modtap::fuzz {

inline std::string write_temp_file(const uint8_t* data, size_t size) {
  static const int fd = memfd_create("modtap-fuzz", 0);
  if (fd < 0 || ftruncate(fd, 0) != 0) std::abort();
  if (size && pwrite(fd, data, size, 0) != static_cast<ssize_t>(size)) std::abort();
  return "/proc/self/fd/" + std::to_string(fd);
}

}  // namespace modtap::fuzz
