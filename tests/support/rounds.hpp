// How many rounds a randomised test runs (header-only test support).
//
// The plain build runs every round a test names: it is where the random cases find wrong answers.
// The sanitizer builds (RV_SANITIZED, defined by tests/CMakeLists.txt for RV_SANITIZE and
// RV_TSAN) run a quarter of them, at least two: there the rounds look for memory and undefined
// behaviour errors along the same code, which the first rounds already walk, at four to six times
// the plain build's time (bench/RESULTS-ci.md). A test whose closing checks count what its rounds
// met scales them by the rounds it ran.
#pragma once

#include <algorithm>

namespace rv::test {

constexpr int rounds(int plain) {
#ifdef RV_SANITIZED
  return std::max(plain / 4, std::min(plain, 2));
#else
  return plain;
#endif
}

}  // namespace rv::test
