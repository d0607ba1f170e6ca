// A histogram of non-negative integers in fixed memory, laid out as HdrHistogram lays its
// buckets: values below 64 each have their own bucket; above, every power of two is split
// into 32 buckets of equal width. A bucket is at most 1/32 of its values wide, so a percentile
// read as its bucket's middle is within 1/64 (1.6%) of the true value. About 9 KB, whatever
// the number of values: a week on a bus costs what a minute does.
#pragma once

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>

namespace modtap {

class Histogram {
 public:
  static constexpr int sub_bucket_bits = 5;  // 32 buckets per power of two
  static constexpr int top_power = 40;       // values of 2^40 and more (18 minutes in ns) share the
                                        // last bucket, read as the maximum; min and max stay exact
  static constexpr double relative_error = 1.0 / (2 << sub_bucket_bits);

  void add(uint64_t value) {
    ++counts_[bucket_of(value)];
    ++count_;
    sum_ += value;
    min_ = std::min(min_, value);
    max_ = std::max(max_, value);
  }
  uint64_t count() const { return count_; }
  uint64_t sum() const { return sum_; }  // exact: a Prometheus histogram's _sum
  uint64_t min() const { return count_ ? min_ : 0; }
  uint64_t max() const { return max_; }

  // The nearest-rank percentile (the smallest value that at least p% of the values do not
  // exceed), as its bucket's middle, within relative_error of the true one. 0 when empty.
  uint64_t percentile(double p) const {
    if (count_ == 0) return 0;
    const double wanted = std::clamp(p, 0.0, 100.0) / 100.0 * static_cast<double>(count_);
    const uint64_t rank = std::max<uint64_t>(1, static_cast<uint64_t>(std::ceil(wanted)));
    uint64_t seen = 0;
    for (size_t i = 0; i < counts_.size(); ++i) {
      seen += counts_[i];
      if (seen >= rank)
        return i + 1 == counts_.size() ? max_ : std::clamp(middle_of(i), min(), max_);
    }
    return max_;
  }

  // How many values are at most `bound`, counting a bucket that holds `bound` as below it
  // when its middle is: what a Prometheus histogram's cumulative buckets need.
  uint64_t count_at_most(uint64_t bound) const {
    if (bound >= max_) return count_;
    uint64_t seen = 0;
    for (size_t i = 0; i < counts_.size() && middle_of(i) <= bound; ++i) seen += counts_[i];
    return seen;
  }

 private:
  static constexpr uint64_t linear_limit = uint64_t{2} << sub_bucket_bits;  // 64
  static constexpr size_t bucket_count =
      linear_limit + (top_power - sub_bucket_bits - 1) * (size_t{1} << sub_bucket_bits);

  static size_t bucket_of(uint64_t value) {
    if (value < linear_limit) return value;
    const int power = std::min(static_cast<int>(std::bit_width(value)) - 1, top_power - 1);
    if (power == top_power - 1 && value >= (uint64_t{1} << top_power)) return bucket_count - 1;
    const int shift = power - sub_bucket_bits;
    const uint64_t sub = (value >> shift) - (uint64_t{1} << sub_bucket_bits);
    return linear_limit +
           static_cast<size_t>(power - sub_bucket_bits - 1) * (size_t{1} << sub_bucket_bits) +
           static_cast<size_t>(sub);
  }
  static uint64_t middle_of(size_t bucket) {
    if (bucket < linear_limit) return bucket;
    const size_t above = bucket - linear_limit;
    const int power = static_cast<int>(above >> sub_bucket_bits) + sub_bucket_bits + 1;
    const uint64_t sub =
        (above & ((size_t{1} << sub_bucket_bits) - 1)) + (uint64_t{1} << sub_bucket_bits);
    const int shift = power - sub_bucket_bits;
    return (sub << shift) + ((uint64_t{1} << shift) >> 1);
  }

  std::array<uint64_t, bucket_count> counts_{};
  uint64_t count_ = 0;
  uint64_t sum_ = 0;
  uint64_t min_ = std::numeric_limits<uint64_t>::max();
  uint64_t max_ = 0;
};

}  // namespace modtap
