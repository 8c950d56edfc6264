// What the harnesses share: the fuzz input written to a per-process scratch file (most loaders
// take a path), and the one rule for exceptions.
//
// A loader may refuse an input only by throwing odyssey::io::InputError (every parser's error,
// naming the file) or std::invalid_argument (which some APIs document, for example a numeric
// conversion of a text array). Any other exception escaping a parser is reported and aborts, so
// libFuzzer saves it as a finding, just like a crash, a sanitizer report, a leak, a timeout or
// running out of memory.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <stdexcept>
#include <string>
#include <typeinfo>

#include "mocap_io/input_error.h"
#include "mocap_io/npy.h"

namespace odyssey::fuzz {

// /dev/shm when it is writable (no disk traffic per execution), else $TMPDIR, else /tmp.
inline std::string scratch_folder() {
  if (::access("/dev/shm", W_OK) == 0) return "/dev/shm";
  if (const char* tmp = std::getenv("TMPDIR"); tmp != nullptr && *tmp != '\0') return tmp;
  return "/tmp";
}

// One file per process (the pid in its name), rewritten for every input and removed at exit.
class ScratchFile {
 public:
  explicit ScratchFile(const std::string& name)
      : path_(scratch_folder() + "/odyssey-fuzz-" + std::to_string(::getpid()) + "-" + name) {}
  ~ScratchFile() { std::remove(path_.c_str()); }
  ScratchFile(const ScratchFile&) = delete;
  ScratchFile& operator=(const ScratchFile&) = delete;

  const std::string& write(const std::uint8_t* data, std::size_t size) {
    std::FILE* file = std::fopen(path_.c_str(), "wb");
    if (file == nullptr || (size > 0 && std::fwrite(data, 1, size, file) != size) || std::fclose(file) != 0) {
      std::fprintf(stderr, "odyssey fuzz: cannot write the scratch file %s\n", path_.c_str());
      std::abort();
    }
    return path_;
  }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

// Runs one parse; see the rule above.
template <class Parse>
void expect_input_errors(Parse&& parse) {
  try {
    parse();
  } catch (const odyssey::io::InputError&) {
  } catch (const std::invalid_argument&) {
  } catch (const std::exception& e) {
    std::fprintf(stderr, "odyssey fuzz: a parser threw %s, not an InputError: %s\n", typeid(e).name(), e.what());
    std::abort();
  }
}

// Every conversion an array offers, as a caller would use them.
inline void convert(const odyssey::io::NpyArray& array) {
  using odyssey::io::DType;
  if (array.dtype() == DType::Object) return;
  if (array.dtype() == DType::Unicode || array.dtype() == DType::Bytes) {
    expect_input_errors([&] { (void)array.to_strings(); });
    expect_input_errors([&] { (void)array.to_double(); });  // std::invalid_argument for text
    return;
  }
  expect_input_errors([&] { (void)array.to_double(); });
  expect_input_errors([&] { (void)array.to_float(); });
  expect_input_errors([&] { (void)array.to_int64(); });
}

}  // namespace odyssey::fuzz
