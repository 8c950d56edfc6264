// What every writer of mocap_io needs to leave no partial file behind, and to refuse non-finite
// values cheaply: the file is written under a temporary name beside its target (same folder, so the
// rename cannot cross file systems) and renamed onto the target only when complete.
#pragma once

#include <cstddef>
#include <cstdio>
#include <span>
#include <string>
#include <vector>

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

// Throws InputError naming `target` when it exists and is not what an output may replace: a regular
// file (or, with `folder`, a folder), followed through symbolic links. A device, FIFO or socket is
// never replaced by an output (renaming onto /dev/null would replace the node), nor a folder by a
// file or a file by a folder.
void require_replaceable_output(const std::string& target, bool folder = false);

// Outputs that appear together or not at all: the one way a command, a scene or a batch job
// commits files. stage() names a temporary path beside each target (same folder, so the rename
// cannot cross file systems) for a writer to fill; commit() renames them all into place, in order,
// and when one rename fails removes the ones already renamed and rethrows. Temporaries of a set
// never committed are removed when it goes.
class StagedOutputs {
 public:
  StagedOutputs() = default;
  ~StagedOutputs();
  StagedOutputs(const StagedOutputs&) = delete;
  StagedOutputs& operator=(const StagedOutputs&) = delete;

  // Throws std::invalid_argument when `target` is already staged (two outputs naming one file),
  // InputError when it may not be replaced (require_replaceable_output).
  std::string stage(const std::string& target);
  // A folder that appears whole or not at all: the temporary folder is created here (its parent
  // must exist) for writers to fill, renamed onto `target` by commit(), removed with its contents
  // otherwise. InputError naming the target when it cannot be created.
  std::string stage_folder(const std::string& target);
  void commit();

 private:
  std::string stage_path(const std::string& target);  // the entry and its temporary name

  struct Entry {
    std::string target, temp;
    bool folder = false;
    bool committed = false;
  };
  std::vector<Entry> entries_;
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
