// Small helpers the test files share: the numpy cross-check interpreter, the message of an
// expected exception, substring tests, per-process and per-test scratch folders.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

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

// This process's own scratch folder, ODYSSEY_SCRATCH_DIR/pid-<pid>. gtest_discover_tests runs
// every test in a process of its own and `ctest -j` runs several at once, so a file one process
// writes (a suite's shared fixture included) must never be a path another process writes or
// reads. The folder is removed when the process ends with every test passed, and kept for a look
// when one failed.
class ScratchRoot : public testing::Environment {
 public:
  static const std::filesystem::path& path() {
    static const std::filesystem::path root = [] {
      std::filesystem::path dir = std::filesystem::path(ODYSSEY_SCRATCH_DIR) / ("pid-" + std::to_string(::getpid()));
      std::filesystem::remove_all(dir);  // a stale folder of an earlier process with the same pid
      std::filesystem::create_directories(dir);
      return dir;
    }();
    return root;
  }
  void TearDown() override {
    std::error_code ignored;
    if (testing::UnitTest::GetInstance()->Passed()) std::filesystem::remove_all(path(), ignored);
  }
};
inline testing::Environment* const kScratchRootCleanup = testing::AddGlobalTestEnvironment(new ScratchRoot);

inline const std::filesystem::path& scratch_root() { return ScratchRoot::path(); }

// ctest calls a test skipped by its exit code, 77 (tests/CMakeLists.txt), not by finding
// "[  SKIPPED ]" in its output: gtest prints that for every test of a suite whose
// SetUpTestSuite failed, and a failure would then pass as a skip. A process that ran only
// skipped tests and failed nothing exits 77.
class SkipExitCode : public testing::EmptyTestEventListener {
  void OnTestProgramEnd(const testing::UnitTest& unit) override {
    if (unit.Passed() && unit.skipped_test_count() > 0 && unit.successful_test_count() == 0) {
      std::fflush(stdout);
      std::fflush(stderr);
      std::_Exit(77);
    }
  }
};
inline const bool kSkipExitCodeInstalled = [] {
  testing::UnitTest::GetInstance()->listeners().Append(new SkipExitCode);
  return true;
}();

// A fresh, empty folder for the current test under scratch_root()/`suite`, so that leftovers can
// be listed.
inline std::filesystem::path scratch_dir(const std::string& suite) {
  const auto* test = testing::UnitTest::GetInstance()->current_test_info();
  const std::filesystem::path dir = scratch_root() / suite / (std::string(test->test_suite_name()) + "." + test->name());
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
