// What every writer of mocap_io needs to leave no partial file behind, and to refuse non-finite
// values cheaply: the file is written under a temporary name beside its target (same folder, so the
// rename cannot cross file systems) and renamed onto the target only when complete.
#pragma once

#include <cstddef>
#include <cstdio>
#include <span>
#include <string>

namespace odyssey::io {

// A file open for writing at "<target>.partial-<pid>-<n>": commit() closes it and renames it onto
// the target; if never committed, the destructor removes it. Errors throw InputError naming the
// target.
class TempFile {
 public:
  explicit TempFile(std::string target);
  ~TempFile();
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;

  std::FILE* get() const { return file_; }
  const std::string& target() const { return target_; }
  const std::string& temp() const { return temp_; }

  void write(std::span<const std::byte> bytes);
  void commit();

 private:
  std::string target_, temp_;
  std::FILE* file_ = nullptr;
  bool committed_ = false;
};

// The whole file at once, through a TempFile.
void write_file_atomically(const std::string& path, std::span<const std::byte> bytes);
inline void write_file_atomically(const std::string& path, const std::string& text) {
  write_file_atomically(path, std::as_bytes(std::span(text.data(), text.size())));
}

// Position of the first value that is not finite, or values.size(). In IEEE 754 binary32 a value
// is infinite or NaN exactly when its exponent bits are all ones, that is when its bits with the
// sign cleared are >= 0x7f800000. The common, all-finite case is one pass taking the maximum of
// those bit patterns: an integer reduction the compiler vectorises (a float reduction it would
// not, without -ffast-math). Only an array that fails is scanned again, to name the position.
std::size_t first_non_finite(std::span<const float> values);

}  // namespace odyssey::io
