// Outputs that appear together or not at all. A command writes each output under a temporary name
// beside its destination (same folder, so the rename cannot cross file systems) and renames them
// all once every one is complete; an output never committed is removed when its StagedFile goes.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <vector>
#include <string>

#include "mocap_io/input_error.h"

namespace odyssey::cli {

class StagedFile {
 public:
  explicit StagedFile(std::string target)
      : target_(std::move(target)), temp_(target_ + ".partial-" + std::to_string(::getpid())) {}
  ~StagedFile() {
    std::error_code ignored;
    if (!committed_) std::filesystem::remove(temp_, ignored);
  }
  StagedFile(const StagedFile&) = delete;
  StagedFile& operator=(const StagedFile&) = delete;

  const std::string& temp() const { return temp_; }

  void write_text(const std::string& text) const {
    std::ofstream out(temp_, std::ios::binary);
    out << text;
    out.close();
    if (!out) throw io::InputError(target_, "cannot write " + temp_);
  }

  void commit() {
    std::error_code error;
    std::filesystem::rename(temp_, target_, error);
    if (error) throw io::InputError(target_, "cannot rename " + temp_ + " into place: " + error.message());
    committed_ = true;
  }

  // Removes the committed file again (a later output of the same command failed to commit).
  void uncommit() {
    std::error_code ignored;
    if (committed_) std::filesystem::remove(target_, ignored);
    committed_ = false;
  }

 private:
  std::string target_, temp_;
  bool committed_ = false;
};

// Renames every file into place, in order; when one fails, the ones already renamed are removed
// again and the error is rethrown, so the command leaves all of its outputs or none.
inline void commit_all(const std::vector<StagedFile*>& files) {
  for (StagedFile* file : files) {
    try {
      file->commit();
    } catch (...) {
      for (StagedFile* done : files) done->uncommit();
      throw;
    }
  }
}

}  // namespace odyssey::cli
