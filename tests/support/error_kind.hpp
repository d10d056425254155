// The kind of the rv::Error a call throws, for tests that check how something is refused.
// Header-only, for every test folder (tests/support is on every test's include path).
#pragma once

#include <gtest/gtest.h>

#include "rv/field/error.hpp"

namespace rv::test {

// The kind of the rv::Error `f()` throws; a test failure (and ErrorKind::internal) when it
// throws none. Other exceptions pass through.
template <class F>
ErrorKind kind_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.kind();
  }
  ADD_FAILURE() << "no rv::Error thrown";
  return ErrorKind::internal;
}

}  // namespace rv::test
