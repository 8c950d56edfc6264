// Small helpers the test files share: the numpy cross-check interpreter, the message of an
// expected exception, substring tests, per-test scratch folders.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

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

// A fresh, empty folder for the current test under ODYSSEY_SCRATCH_DIR/`suite`, so that leftovers
// can be listed.
inline std::filesystem::path scratch_dir(const std::string& suite) {
  const auto* test = testing::UnitTest::GetInstance()->current_test_info();
  const std::filesystem::path dir =
      std::filesystem::path(ODYSSEY_SCRATCH_DIR) / suite / (std::string(test->test_suite_name()) + "." + test->name());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

// The names in a folder, sorted.
inline std::vector<std::string> files_in(const std::filesystem::path& dir) {
  std::vector<std::string> names;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

}  // namespace odyssey::test_support

#define REQUIRE_NUMPY()                                  \
  if (odyssey::test_support::numpy_python().empty()) \
  GTEST_SKIP() << "python3 with numpy not found"
