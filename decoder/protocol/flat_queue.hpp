// A first-in, first-out queue whose items sit side by side in one vector, so that a binary
// search over it runs on plain pointers: the framer looks up a byte's time mark several times a
// frame, and a std::deque's iterators cost a division and branches at every step.
#pragma once

#include <cstddef>
#include <iterator>
#include <vector>

namespace modtap {

template <typename T>
class FlatQueue {
 public:
  void push_back(const T& item) { items_.push_back(item); }
  // The items popped are dropped in bulk once they are half of the vector: amortised constant
  // time, and the memory held stays within twice what is queued.
  void pop_front() {
    if (++head_ == items_.size()) {
      items_.clear();
      head_ = 0;
    } else if (head_ >= 64 && 2 * head_ >= items_.size()) {
      items_.erase(items_.begin(), items_.begin() + static_cast<std::ptrdiff_t>(head_));
      head_ = 0;
    }
  }

  bool empty() const { return head_ == items_.size(); }
  size_t size() const { return items_.size() - head_; }
  const T& front() const { return items_[head_]; }
  const T& back() const { return items_.back(); }
  const T& operator[](size_t i) const { return items_[head_ + i]; }
  const T* begin() const { return items_.data() + head_; }
  const T* end() const { return items_.data() + items_.size(); }
  auto rbegin() const { return std::make_reverse_iterator(end()); }
  auto rend() const { return std::make_reverse_iterator(begin()); }

 private:
  std::vector<T> items_;
  size_t head_ = 0;
};

}  // namespace modtap
