// Runs the odyssey binary (ODYSSEY_CLI) the way a user's shell would, for the end-to-end tests.
#pragma once

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <string>

namespace odyssey::test_support {

struct CliResult {
  int exit_code;
  std::string output;  // stdout and stderr together
};

// The odyssey binary with `arguments`, run from the folder `working_dir` (empty: this process's).
inline CliResult run_cli_in(const std::string& working_dir, const std::string& arguments) {
  const std::string command =
      (working_dir.empty() ? std::string() : "cd '" + working_dir + "' && ") + ODYSSEY_CLI + " " + arguments + " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  CliResult result{-1, ""};
  if (!pipe) return result;
  std::array<char, 4096> buffer;
  while (std::fgets(buffer.data(), buffer.size(), pipe)) result.output += buffer.data();
  const int status = pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

inline CliResult run_cli(const std::string& arguments) { return run_cli_in("", arguments); }

}  // namespace odyssey::test_support
