// Small helpers the test files share: the numpy cross-check interpreter, the message of an
// expected exception, substring tests.
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

namespace odyssey::test_support {

// The numpy-capable interpreter (ODYSSEY_PYTHON), or empty when there is none: tests that
// cross-check with numpy then skip and say so.
inline std::string numpy_python() {
  static const std::string python = [] {
    const std::string candidate = ODYSSEY_PYTHON;
    if (candidate.empty() || candidate.ends_with("NOTFOUND")) return std::string();
    return std::system((candidate + " -c 'import numpy' >/dev/null 2>&1").c_str()) == 0 ? candidate : std::string();
  }();
  return python;
}

// The what() of the exception of type E that `operation` throws; a test failure when it throws
// none.
template <class E, class F>
std::string message_of(F&& operation) {
  try {
    operation();
  } catch (const E& e) {
    return e.what();
  }
  ADD_FAILURE() << "no exception of the expected type";
  return {};
}

inline bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

}  // namespace odyssey::test_support

#define REQUIRE_NUMPY()                                  \
  if (odyssey::test_support::numpy_python().empty()) \
  GTEST_SKIP() << "python3 with numpy not found"
