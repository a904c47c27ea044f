// The lock-free hand-offs of the servo loop: TripleBuffer (latest value) and SpscQueue (FIFO),
// single-threaded semantics and multi-threaded stress tests (run them under ThreadSanitizer too).
#include "cariesim/common/lockfree.hpp"

#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <thread>
#include <vector>

#include "support/alloc_counter.hpp"

namespace cariesim {
namespace {

// A value whose fields all derive from one number, so a torn copy is detectable.
struct Stamped {
  uint64_t seq = 0;
  std::array<uint64_t, 15> payload{};  // 128 bytes in all: a copy takes several stores

  static Stamped make(uint64_t seq) {
    Stamped s;
    s.seq = seq;
    for (std::size_t i = 0; i < s.payload.size(); ++i) s.payload[i] = seq * 31 + i;
    return s;
  }
  [[nodiscard]] bool consistent() const {
    for (std::size_t i = 0; i < payload.size(); ++i)
      if (payload[i] != seq * 31 + i) return false;
    return true;
  }
};

TEST(TripleBuffer, NothingBeforeTheFirstWrite) {
  TripleBuffer<int> tb;
  int out = -1;
  EXPECT_FALSE(tb.read(out));
  EXPECT_EQ(out, -1);
}

TEST(TripleBuffer, ReadGetsTheLatestOnce) {
  TripleBuffer<int> tb;
  int out = 0;
  tb.write(1);
  tb.write(2);
  tb.write(3);
  ASSERT_TRUE(tb.read(out));
  EXPECT_EQ(out, 3);
  EXPECT_FALSE(tb.read(out));  // nothing new
  EXPECT_EQ(out, 3);
  tb.write(4);
  ASSERT_TRUE(tb.read(out));
  EXPECT_EQ(out, 4);
}

TEST(TripleBuffer, ManyAlternationsKeepValues) {
  // Exercise every slot rotation: write k, read k, with and without skipped writes.
  TripleBuffer<int> tb;
  int out = 0;
  for (int k = 0; k < 1000; ++k) {
    tb.write(2 * k);
    if (k % 3 == 0) tb.write(2 * k + 1);
    ASSERT_TRUE(tb.read(out));
    EXPECT_EQ(out, k % 3 == 0 ? 2 * k + 1 : 2 * k);
  }
}

TEST(TripleBuffer, SlotsSizedAtConstructionTakeWritesWithoutAllocating) {
  // Made from a value holding a vector, every slot holds a vector of that size: writing values of the
  // same size copies into that memory (the servo thread's Params publication relies on it).
  const std::vector<double> initial(64, 1.0);
  TripleBuffer<std::vector<double>> tb(initial);
  std::vector<double> out;
  EXPECT_FALSE(tb.read(out));  // constructing publishes nothing
  std::vector<double> value(64);
  const std::size_t before = test::allocation_count();
  for (int k = 0; k < 10; ++k) {
    value.assign(64, static_cast<double>(k));
    tb.write(value);
  }
  const std::size_t after = test::allocation_count();
  EXPECT_EQ(after - before, 0u);
  ASSERT_TRUE(tb.read(out));
  EXPECT_EQ(out, std::vector<double>(64, 9.0));
}

TEST(TripleBuffer, StressOneWriterOneReader) {
  // The writer publishes increasing sequence numbers; the reader must only ever see complete values,
  // in increasing order, and finally the last one.
  TripleBuffer<Stamped> tb;
  constexpr uint64_t kWrites = 300000;
  std::atomic<bool> done{false};
  std::thread writer([&] {
    for (uint64_t i = 1; i <= kWrites; ++i) tb.write(Stamped::make(i));
    done.store(true);
  });
  uint64_t last = 0, reads = 0, torn = 0, backwards = 0;
  Stamped s;
  while (true) {
    const bool finished = done.load();
    while (tb.read(s)) {
      ++reads;
      torn += !s.consistent();
      backwards += s.seq <= last;
      last = s.seq;
    }
    if (finished) break;
  }
  writer.join();
  EXPECT_EQ(torn, 0u);
  EXPECT_EQ(backwards, 0u);
  EXPECT_EQ(last, kWrites);
  EXPECT_GT(reads, 0u);
}

TEST(SpscQueue, FifoAndCapacity) {
  SpscQueue<int> q(3);
  EXPECT_EQ(q.capacity(), 3u);
  int out = 0;
  EXPECT_FALSE(q.pop(out));
  EXPECT_TRUE(q.push(1));
  EXPECT_TRUE(q.push(2));
  EXPECT_TRUE(q.push(3));
  EXPECT_FALSE(q.push(4));  // full
  ASSERT_TRUE(q.pop(out));
  EXPECT_EQ(out, 1);
  EXPECT_TRUE(q.push(5));  // room again, wrapping around
  for (int expected : {2, 3, 5}) {
    ASSERT_TRUE(q.pop(out));
    EXPECT_EQ(out, expected);
  }
  EXPECT_FALSE(q.pop(out));
}

TEST(SpscQueue, ZeroCapacityRefusesEverything) {
  SpscQueue<int> q(0);
  int out = 0;
  EXPECT_EQ(q.capacity(), 0u);
  EXPECT_FALSE(q.push(1));
  EXPECT_FALSE(q.pop(out));
}

TEST(SpscQueue, StressOneProducerOneConsumer) {
  // Every item arrives exactly once, in order, intact, through a small queue that is often full and
  // often empty.
  SpscQueue<Stamped> q(64);
  constexpr uint64_t kItems = 300000;
  uint64_t refused = 0;
  std::thread producer([&] {
    for (uint64_t i = 1; i <= kItems; ++i)
      while (!q.push(Stamped::make(i))) ++refused;
  });
  uint64_t expected = 1, torn = 0, out_of_order = 0;
  Stamped s;
  while (expected <= kItems) {
    if (!q.pop(s)) continue;
    torn += !s.consistent();
    out_of_order += s.seq != expected;
    expected = s.seq + 1;
  }
  producer.join();
  EXPECT_EQ(torn, 0u);
  EXPECT_EQ(out_of_order, 0u);
  EXPECT_EQ(expected, kItems + 1);
  EXPECT_FALSE(q.pop(s));
}

}  // namespace
}  // namespace cariesim
