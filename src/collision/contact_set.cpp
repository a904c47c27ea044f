#include <algorithm>

#include "cariesim/collision/collide.hpp"

namespace cariesim {

namespace {

// Max-heap order on the gap: the root is the worst (largest-gap) kept contact.
bool smaller_gap(const Contact& a, const Contact& b) { return a.gap < b.gap; }

}  // namespace

ContactSet::ContactSet(std::size_t capacity) : items_(capacity) {}

void ContactSet::clear() {
  size_ = 0;
  overflow_ = false;
  capped_count_ = 0;
}

void ContactSet::push(const Contact& c) {
  // Room left: append; when that fills the set, turn it into a max-heap on the gap so that later
  // pushes replace the worst contact in O(log n).
  if (size_ < items_.size()) {
    items_[size_++] = c;
    if (size_ == items_.size()) std::make_heap(items_.begin(), items_.end(), smaller_gap);
    return;
  }
  // Full: keep the smaller gaps; either `c` or the current worst is dropped.
  overflow_ = true;
  if (items_.empty() || !(c.gap < items_.front().gap)) return;
  std::pop_heap(items_.begin(), items_.end(), smaller_gap);
  items_.back() = c;
  std::push_heap(items_.begin(), items_.end(), smaller_gap);
}

}  // namespace cariesim
