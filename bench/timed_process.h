// A whole process as a user runs it, for the benchmarks that time the odyssey binary: a shell
// command's wall time and the peak resident set of the largest of it and its waited-for children
// (wait4's ru_maxrss).
#pragma once

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <string>

namespace odyssey::bench {

struct TimedProcess {
  double seconds = 0, peak_mib = 0;
  int exit_code = -1;  // -1 when it did not exit normally
};

inline TimedProcess run_timed(const std::string& command) {
  const auto start = std::chrono::steady_clock::now();
  const pid_t child = fork();
  if (child == 0) {
    execl("/bin/sh", "sh", "-c", command.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  int status = 0;
  rusage usage{};
  TimedProcess result;
  if (child < 0 || wait4(child, &status, 0, &usage) != child) return result;
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  result.peak_mib = usage.ru_maxrss / 1024.0;
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

}  // namespace odyssey::bench
