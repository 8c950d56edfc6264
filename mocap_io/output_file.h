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

// A file open for writing at temporary_name(target): commit() closes it and renames it onto the
// target; if never committed, the destructor removes it. Errors throw InputError naming the target,
// a target that may not be replaced (require_replaceable_output) included.
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
// file or a file by a folder. A target that does not exist must have its folder (no output makes
// its parents).
void require_replaceable_output(const std::string& target, bool folder = false);

// Throws InputError naming `output` when it is one of `inputs` (empty ones skipped): the same path
// made absolute and normal, or the same file by device and inode (links, other spellings).
void require_not_an_input(const std::string& output, const std::vector<std::string>& inputs);

// Outputs that appear together or not at all: the one way a command, a scene or a batch job
// commits files. stage() names a temporary path beside each target (same folder, so the rename
// cannot cross file systems) for a writer to fill. commit() replaces the previous outputs only
// when every new one goes in: it checks every target again (something may have appeared there
// since stage()), keeps each previous output under an aside name (a hard link for a file, so the
// file never disappears; the folder itself for a folder), renames the new ones in, and when any
// step fails puts every previous output back, removes the new ones and throws naming the target
// that blocked it. Temporaries of a set never committed are removed when it goes.
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

// The name a temporary of `target` gets: "<target>.partial-<pid>-<n>-<host>", <n> distinguishing
// the temporaries of one process and <host> eight hex digits of a hash of the host name, so that a
// sweep on one machine of a shared file system never takes another machine's process IDs for its
// own. A previous output kept aside during a commit is "<target>.previous-<pid>-<n>-<host>".
std::string temporary_name(const std::string& target);

// Creates the temporary `path` (mode as std::fopen's, nullptr on failure with errno set) and lists
// it until forget_temporary(path), so that an interrupt removes it (install_interrupt_cleanup). For
// writers that keep temporaries of their own beside a staged file (the trajectory file's spools);
// TempFile and StagedOutputs list theirs.
std::FILE* create_temporary_file(const std::string& path, const char* mode);
void forget_temporary(const std::string& path);

// Makes SIGINT and SIGTERM stop the process and remove every temporary it has listed (staged
// files and folders, TempFiles, spools) before exiting with 128 + the signal number (130, 143).
// The handler only writes the signal number to a pipe; a thread waiting on it removes the files
// holding the listing's lock, so a commit in progress finishes (or rolls back) first and no
// temporary is created after the removal. A child made by fork() gets the default actions back
// and an empty listing (a batch worker removes nothing of its parent's). Call once, from main().
void install_interrupt_cleanup();

// What a process that no longer exists left in `folder` (killed by SIGKILL, or a crash): files and
// folders named as temporary_name() names them, of this host, whose process ID is not running
// and is not ours. A kept-aside previous output goes back in place when its target is missing
// and is removed otherwise; temporaries are removed. Returns how many entries were handled. Every
// TempFile and StagedOutputs::stage sweeps its target's folder once per process.
int sweep_leftovers(const std::string& folder);

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
