// The one error type every parser and writer throws for bad input: it names the file and the
// problem, so the CLI can print a single line "odyssey: FILE: PROBLEM" and exit non-zero, and a
// batch can report the file and go on.
#pragma once

#include <new>
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

// Runs a loader of `file`, turning a failed allocation into an InputError naming the file: a
// file whose sizes are all checked against its data can still be too large for the machine.
// std::length_error is a request past what a container can address, so it counts too.
template <class Read>
auto naming_out_of_memory(const std::string& file, Read&& read) -> decltype(read()) {
  try {
    return read();
  } catch (const std::bad_alloc&) {
    throw InputError(file, "out of memory reading the file");
  } catch (const std::length_error&) {
    throw InputError(file, "out of memory reading the file (a size past what can be allocated)");
  }
}

}  // namespace odyssey::io
