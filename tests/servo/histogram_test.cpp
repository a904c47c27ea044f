// TimingHistogram: percentiles against values computed by hand, the overflow bin, odd input, and
// reading while another thread adds.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <thread>

#include "cariesim/servo/servo.hpp"

namespace cariesim {
namespace {

TEST(TimingHistogram, EmptyIsZero) {
  const TimingHistogram h;
  EXPECT_EQ(h.count(), 0u);
  EXPECT_EQ(h.percentile(0.5), 0.0);
  EXPECT_EQ(h.max(), 0.0);
}

TEST(TimingHistogram, PercentilesOfAUniformSpread) {
  // 1000 values 1, 2, ..., 1000 µs: the p-quantile is the value ceil(p * 1000); the histogram answers
  // the upper edge of its 0.25 µs bin (value + 0.25 for integers).
  TimingHistogram h;
  for (int v = 1; v <= 1000; ++v) h.add(v);
  EXPECT_EQ(h.count(), 1000u);
  EXPECT_DOUBLE_EQ(h.max(), 1000.0);
  EXPECT_DOUBLE_EQ(h.percentile(0.5), 500.25);
  EXPECT_DOUBLE_EQ(h.percentile(0.99), 990.25);
  EXPECT_DOUBLE_EQ(h.percentile(0.999), 999.25);
  EXPECT_DOUBLE_EQ(h.percentile(1.0), 1000.0);  // never above the maximum
  EXPECT_DOUBLE_EQ(h.percentile(0.0), 1.25);    // the first value's bin
}

TEST(TimingHistogram, CoarseBinsAboveAMillisecond) {
  // Beyond 1024 µs the bins are 64 µs wide: 3000 µs lies in [2944, 3008).
  TimingHistogram h;
  for (int i = 0; i < 98; ++i) h.add(10.0);
  h.add(5000.0);
  h.add(3000.0);
  EXPECT_DOUBLE_EQ(h.percentile(0.5), 10.25);  // the upper edge of the bin of 10 µs
  EXPECT_DOUBLE_EQ(h.percentile(0.99), 3008.0);
  EXPECT_DOUBLE_EQ(h.percentile(1.0), 5000.0);  // 5000 lies in [4992, 5056): capped at the maximum
  EXPECT_DOUBLE_EQ(h.max(), 5000.0);
}

TEST(TimingHistogram, OverflowBinAnswersTheMaximum) {
  // Beyond 65536 µs only the maximum is known.
  TimingHistogram h;
  for (int i = 0; i < 98; ++i) h.add(10.0);
  h.add(90000.0);
  h.add(70000.0);
  EXPECT_DOUBLE_EQ(h.percentile(0.99), 90000.0);
  EXPECT_DOUBLE_EQ(h.max(), 90000.0);
}

TEST(TimingHistogram, NegativeAndNaNCountAsZero) {
  TimingHistogram h;
  h.add(-3.0);
  h.add(std::nan(""));
  EXPECT_EQ(h.count(), 2u);
  EXPECT_DOUBLE_EQ(h.max(), 0.0);
  EXPECT_DOUBLE_EQ(h.percentile(1.0), 0.0);
}

TEST(TimingHistogram, CopyAndReset) {
  TimingHistogram h;
  for (int v = 0; v < 100; ++v) h.add(v * 0.5);
  const TimingHistogram copy = h;
  EXPECT_EQ(copy.count(), 100u);
  EXPECT_DOUBLE_EQ(copy.percentile(0.9), h.percentile(0.9));
  h.reset();
  EXPECT_EQ(h.count(), 0u);
  EXPECT_EQ(h.percentile(0.9), 0.0);
  EXPECT_EQ(copy.count(), 100u);
}

TEST(TimingHistogram, ReadingWhileAddingIsSafe) {
  // One thread adds, another reads percentiles: the readings stay within the values' range (and
  // ThreadSanitizer finds no race).
  TimingHistogram h;
  std::atomic<bool> done{false};
  std::thread writer([&] {
    for (int i = 0; i < 200000; ++i) h.add(20.0 + (i % 100));
    done.store(true);
  });
  // At least one reading, even when a loaded machine lets the writer finish before the reader runs.
  int readings = 0, outside = 0;
  do {
    const double p = h.percentile(0.99);
    outside += p != 0.0 && (p < 20.0 || p > 120.0);
    ++readings;
  } while (!done.load());
  writer.join();
  EXPECT_EQ(outside, 0);
  EXPECT_GT(readings, 0);
  EXPECT_EQ(h.count(), 200000u);
}

}  // namespace
}  // namespace cariesim
