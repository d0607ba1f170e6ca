// Hands a fuzzer's bytes to a reader that takes a path: one temporary file per process.
#pragma once

#include <unistd.h>

#include <cstdio>
#include <string>

namespace modtap::fuzz {

inline std::string write_temp_file(const uint8_t* data, size_t size, const char* suffix) {
  static const std::string path = "/tmp/modtap-fuzz-" + std::to_string(getpid()) + suffix;
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) std::abort();
  if (size && std::fwrite(data, 1, size, f) != size) std::abort();
  std::fclose(f);
  return path;
}

}  // namespace modtap::fuzz
