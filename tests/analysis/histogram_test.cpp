#include "decoder/analysis/histogram.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace modtap {
namespace {

uint64_t nearest_rank(std::vector<uint64_t> values, double p) {
  std::sort(values.begin(), values.end());
  const auto rank = std::max<size_t>(1, static_cast<size_t>(std::ceil(p / 100 * values.size())));
  return values[rank - 1];
}

TEST(Histogram, SmallValuesAreExact) {
  Histogram h;
  for (uint64_t v : {5, 1, 63, 7, 7}) h.add(v);
  EXPECT_EQ(h.count(), 5u);
  EXPECT_EQ(h.min(), 1u);
  EXPECT_EQ(h.max(), 63u);
  EXPECT_EQ(h.percentile(50), 7u);
  EXPECT_EQ(h.percentile(0), 1u);
  EXPECT_EQ(h.percentile(100), 63u);
}

TEST(Histogram, EmptySaysZero) {
  const Histogram h;
  EXPECT_EQ(h.count(), 0u);
  EXPECT_EQ(h.percentile(99), 0u);
  EXPECT_EQ(h.min(), 0u);
}

// Latencies from microseconds to minutes: every percentile within the stated error.
TEST(Histogram, PercentilesStayWithinTheStatedError) {
  std::mt19937_64 random(7);
  std::lognormal_distribution<double> latency(std::log(4e6), 1.5);  // around 4 ms, in ns
  std::vector<uint64_t> values;
  Histogram h;
  for (int i = 0; i < 100000; ++i) {
    values.push_back(static_cast<uint64_t>(latency(random)));
    h.add(values.back());
  }
  for (double p : {1.0, 10.0, 50.0, 90.0, 95.0, 99.0, 99.9, 100.0}) {
    const double exact = static_cast<double>(nearest_rank(values, p));
    EXPECT_LE(std::abs(static_cast<double>(h.percentile(p)) - exact),
              exact * Histogram::relative_error)
        << p;
  }
  EXPECT_EQ(h.max(), *std::max_element(values.begin(), values.end()));
}

TEST(Histogram, ValuesPastTheTopShareTheLastBucketAndKeepAnExactMax) {
  Histogram h;
  h.add(uint64_t{1} << 50);
  h.add(uint64_t{3} << 45);
  EXPECT_EQ(h.max(), uint64_t{1} << 50);
  EXPECT_EQ(h.min(), uint64_t{3} << 45);
  EXPECT_EQ(h.percentile(100), uint64_t{1} << 50);
}

TEST(Histogram, CountsAtMostABound) {
  Histogram h;
  for (uint64_t v = 1; v <= 1000; ++v) h.add(v * 1000);
  EXPECT_EQ(h.count_at_most(1'000'000), 1000u);
  EXPECT_EQ(h.count_at_most(10), 0u);
  const double half = static_cast<double>(h.count_at_most(500'000));
  EXPECT_NEAR(half, 500, 500 * Histogram::relative_error * 2);
  EXPECT_EQ(h.sum(), 500'500'000u);  // exact, unlike the buckets
}

// Memory is the same for one value and for a year of them.
TEST(Histogram, HasAFixedSize) {
  EXPECT_LT(sizeof(Histogram), 10 * 1024u);
}

}  // namespace
}  // namespace modtap
