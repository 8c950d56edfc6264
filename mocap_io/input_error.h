// The one error type every parser and writer throws for bad input: it names the file and the
// problem, so the CLI can print a single line "odyssey: FILE: PROBLEM" and exit non-zero, and a
// batch can report the file and go on.
#pragma once

#include <stdexcept>
#include <string>

namespace odyssey::io {

class InputError : public std::runtime_error {
 public:
  InputError(std::string file, std::string problem)
      : std::runtime_error(file + ": " + problem), file_(std::move(file)), problem_(std::move(problem)) {}

  const std::string& file() const { return file_; }
  const std::string& problem() const { return problem_; }

 private:
  std::string file_;
  std::string problem_;
};

}  // namespace odyssey::io
