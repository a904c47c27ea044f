#pragma once
// Counts heap allocations made through global operator new (replaced in alloc_counter.cpp), so tests
// can prove that the servo-loop code allocates nothing.
#include <cstddef>

namespace cariesim::test {

/// Allocations (operator new, and malloc/calloc/realloc on glibc) since the program started.
std::size_t allocation_count();

}  // namespace cariesim::test
