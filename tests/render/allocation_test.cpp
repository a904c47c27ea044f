// The servo step allocates nothing (STYLE.md "Model / State / step"): count every global operator new
// around many steps that exercise free motion, sliding with friction, and slips.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>

#include "cariesim/render/step.hpp"
#include "render/render_support.hpp"

namespace {
std::atomic<bool> g_counting{false};
std::atomic<long> g_allocations{0};
}  // namespace

void* operator new(std::size_t size) {
  if (g_counting.load(std::memory_order_relaxed)) g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size) { return operator new(size); }
void* operator new(std::size_t size, std::align_val_t align) {
  if (g_counting.load(std::memory_order_relaxed)) g_allocations.fetch_add(1, std::memory_order_relaxed);
  const std::size_t a = static_cast<std::size_t>(align);
  if (void* p = std::aligned_alloc(a, (size + a - 1) / a * a)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size, std::align_val_t align) { return operator new(size, align); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }

namespace cariesim {
namespace {

TEST(StepAllocations, ManyStepsAllocateNothing) {
  test::SlabSpec spec;
  const Model m = test::model(
      {test::object("soft", test::slab(spec, [](const Vec3& p) { return p.x() < 0 ? 0 : 1; }), ObjectKind::Soft)},
      {test::soft(1.0, 0.6, 0.3, Tissue::Caries), test::soft(2.0)});
  State s(m, test::probe_at(Vec3(-4, 0, 2)));
  step(m, s, HapticInput{test::probe_at(Vec3(-4, 0, 2)), 0.001});  // warm up outside the window

  g_allocations = 0;
  g_counting = true;
  int slips = 0, sliding = 0;
  for (int i = 0; i < 4000; ++i) {
    const double x = -4.0 + 8.0 * i / 4000.0;
    const double z = i < 300 ? 2.0 - 2.5 * i / 300.0 : -0.5;  // free, then pressing and sliding
    const StepOutput out = step(m, s, HapticInput{test::probe_at(Vec3(x, 0.2, z)), 0.001});
    slips += out.slips;
    sliding += out.state == InteractionState::Sliding;
  }
  g_counting = false;
  EXPECT_EQ(g_allocations.load(), 0);
  EXPECT_GT(slips, 3);       // the window did exercise friction
  EXPECT_GT(sliding, 3000);  // and contact
}

}  // namespace
}  // namespace cariesim
