#pragma once
/// Counts heap allocations made through the global operator new in this test executable, so a test
/// can prove that a piece of code allocates nothing (STYLE.md: "a test proves it by counting").

#include <cstddef>

namespace cariesim::test {

/// Number of calls to any global operator new since the program started.
std::size_t allocation_count();

}  // namespace cariesim::test
