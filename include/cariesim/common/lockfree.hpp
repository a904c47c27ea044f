#pragma once
/// Lock-free hand-offs between the servo thread and the rest (docs/design.md §5): a triple buffer for
/// "latest value" (servo -> viewer snapshots and parameters, the UDP bridge's receiver -> servo) and a
/// bounded single-producer single-consumer queue for messages (viewer -> servo parameter changes,
/// servo -> recorder samples). Neither blocks nor allocates after construction (a TripleBuffer of a
/// type that holds a vector: when every value written has the size of the one it was made with).

#include <array>
#include <atomic>
#include <cstddef>
#include <memory>
#include <vector>

namespace cariesim {

/// The writer always has a free slot; the reader always gets the latest complete value.
template <typename T>
class TripleBuffer {
 public:
  /// Three value-initialised slots; nothing is published.
  TripleBuffer() = default;
  /// Fills the three slots with `initial`, so writing values of its size later copies into memory
  /// reserved here (e.g. a Params whose materials vector keeps its length). Nothing is published.
  explicit TripleBuffer(const T& initial) : slots_{initial, initial, initial} {}
  /// Publishes a value (one writer thread).
  void write(const T& value) {
    slots_[back_] = value;
    back_ = middle_.exchange(back_ | kFresh, std::memory_order_acq_rel) & kIndex;
  }
  /// Copies the latest value into `out` if a new one was published since the last read (one reader
  /// thread). Returns false when nothing new arrived.
  bool read(T& out) {
    if ((middle_.load(std::memory_order_acquire) & kFresh) == 0) return false;
    front_ = middle_.exchange(front_, std::memory_order_acq_rel) & kIndex;
    out = slots_[front_];
    return true;
  }

 private:
  static constexpr unsigned kIndex = 3u;
  static constexpr unsigned kFresh = 4u;
  std::array<T, 3> slots_{};
  unsigned back_ = 0;
  unsigned front_ = 1;
  std::atomic<unsigned> middle_{2};
};

/// Bounded queue for one producer and one consumer thread; push fails (returns false) when full.
template <typename T>
class SpscQueue {
 public:
  explicit SpscQueue(std::size_t capacity) : items_(capacity + 1) {}
  bool push(const T& item) {
    const std::size_t head = head_.load(std::memory_order_relaxed);
    const std::size_t next = head + 1 == items_.size() ? 0 : head + 1;
    if (next == tail_.load(std::memory_order_acquire)) return false;
    items_[head] = item;
    head_.store(next, std::memory_order_release);
    return true;
  }
  bool pop(T& item) {
    const std::size_t tail = tail_.load(std::memory_order_relaxed);
    if (tail == head_.load(std::memory_order_acquire)) return false;
    item = items_[tail];
    tail_.store(tail + 1 == items_.size() ? 0 : tail + 1, std::memory_order_release);
    return true;
  }
  [[nodiscard]] std::size_t capacity() const { return items_.size() - 1; }

 private:
  std::vector<T> items_;
  alignas(64) std::atomic<std::size_t> head_{0};
  alignas(64) std::atomic<std::size_t> tail_{0};
};

}  // namespace cariesim
