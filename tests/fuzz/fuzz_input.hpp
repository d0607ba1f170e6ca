// Reads a fuzzer's bytes as a stream of small decisions, then as the rest.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <span>

namespace modtap::fuzz {

class FuzzInput {
 public:
  FuzzInput(const uint8_t* data, size_t size) : data_(data), size_(size) {}

  uint8_t byte() { return at_ < size_ ? data_[at_++] : 0; }
  std::span<const uint8_t> take(size_t n) {
    n = std::min(n, size_ - at_);
    const auto out = std::span<const uint8_t>(data_ + at_, n);
    at_ += n;
    return out;
  }
  std::span<const uint8_t> rest() { return take(size_ - at_); }
  bool empty() const { return at_ >= size_; }

 private:
  const uint8_t* data_;
  size_t size_;
  size_t at_ = 0;
};

// A property that does not hold: a finding, so the fuzzer stops with the input.
#define FUZZ_EXPECT(condition)                                                              \
  do {                                                                                      \
    if (!(condition)) {                                                                     \
      std::fprintf(stderr, "%s:%d: property failed: %s\n", __FILE__, __LINE__, #condition); \
      std::abort();                                                                         \
    }                                                                                       \
  } while (0)

}  // namespace modtap::fuzz
