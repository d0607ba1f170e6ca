#include "decoder/protocol/flat_queue.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

namespace modtap {
namespace {

// Items come out in the order they went in, across the compactions that drop popped items, and
// the queue's view stays sorted for a binary search.
TEST(FlatQueue, KeepsOrderAcrossCompactions) {
  FlatQueue<int> queue;
  int next_in = 0, next_out = 0;
  for (int round = 0; round < 50; ++round) {
    for (int i = 0; i < 97; ++i) queue.push_back(next_in++);
    for (int i = 0; i < 89; ++i) {
      ASSERT_EQ(queue.front(), next_out);
      queue.pop_front();
      ++next_out;
    }
    ASSERT_EQ(queue.size(), static_cast<size_t>(next_in - next_out));
    ASSERT_EQ(queue[0], next_out);
    ASSERT_EQ(queue.back(), next_in - 1);
    ASSERT_TRUE(std::is_sorted(queue.begin(), queue.end()));
    const auto found = std::lower_bound(queue.begin(), queue.end(), next_out + 3);
    ASSERT_EQ(*found, next_out + 3);
    ASSERT_EQ(*queue.rbegin(), next_in - 1);
    ASSERT_EQ(std::distance(queue.rbegin(), queue.rend()), next_in - next_out);
  }
  while (!queue.empty()) queue.pop_front();
  EXPECT_EQ(queue.size(), 0u);
  EXPECT_EQ(queue.begin(), queue.end());
}

}  // namespace
}  // namespace modtap
