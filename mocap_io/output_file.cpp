#include "mocap_io/output_file.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <utility>

#include "mocap_io/input_error.h"

namespace odyssey::io {
namespace {

// Distinguishes the temporary files of several writers to one target within a process.
std::atomic<unsigned> temp_counter{0};

}  // namespace

TempFile::TempFile(std::string target)
    : target_(std::move(target)),
      temp_(target_ + ".partial-" + std::to_string(::getpid()) + "-" + std::to_string(temp_counter++)),
      file_(std::fopen(temp_.c_str(), "wb")) {
  if (!file_) throw InputError(target_, "cannot create " + temp_ + ": " + std::strerror(errno));
}

TempFile::~TempFile() {
  if (file_) std::fclose(file_);
  if (!committed_) std::remove(temp_.c_str());
}

void TempFile::write(std::span<const std::byte> bytes) {
  if (std::fwrite(bytes.data(), 1, bytes.size(), file_) != bytes.size()) {
    throw InputError(target_, std::string("write failed: ") + std::strerror(errno));
  }
}

void TempFile::commit() {
  errno = 0;
  const bool had_error = std::ferror(file_) != 0;
  const bool closed = std::fclose(std::exchange(file_, nullptr)) == 0;
  if (!closed || had_error) {
    throw InputError(target_, std::string("write failed") + (errno ? std::string(": ") + std::strerror(errno) : std::string()));
  }
  if (std::rename(temp_.c_str(), target_.c_str()) != 0) {
    throw InputError(target_, "cannot rename " + temp_ + " into place: " + std::strerror(errno));
  }
  committed_ = true;
}

StagedOutputs::~StagedOutputs() {
  std::error_code ignored;
  for (const Entry& entry : entries_) {
    if (entry.committed) continue;
    if (entry.folder) {
      std::filesystem::remove_all(entry.temp, ignored);
    } else {
      std::filesystem::remove(entry.temp, ignored);
    }
  }
}

void require_replaceable_output(const std::string& target, bool folder) {
  namespace fs = std::filesystem;
  std::error_code error;
  const fs::file_status status = fs::status(target, error);
  if (error || !fs::exists(status)) return;
  const char* what = fs::is_regular_file(status) ? "a file"
                     : fs::is_directory(status)  ? "a folder"
                     : fs::is_character_file(status) || fs::is_block_file(status) ? "a device"
                     : fs::is_fifo(status)       ? "a FIFO"
                     : fs::is_socket(status)     ? "a socket"
                                                 : "not a regular file";
  if (folder ? fs::is_directory(status) : fs::is_regular_file(status)) return;
  throw InputError(target, std::string("exists and is ") + what + ", not " + (folder ? "a folder" : "a regular file") +
                               ": an output never replaces it");
}

std::string StagedOutputs::stage(const std::string& target) {
  require_replaceable_output(target);
  return stage_path(target);
}

std::string StagedOutputs::stage_path(const std::string& target) {
  const std::filesystem::path absolute = std::filesystem::absolute(target);
  for (const Entry& entry : entries_) {
    if (std::filesystem::absolute(entry.target) == absolute) throw std::invalid_argument("two outputs name " + target);
  }
  entries_.push_back({target, target + ".partial-" + std::to_string(::getpid()) + "-" + std::to_string(temp_counter++)});
  return entries_.back().temp;
}

std::string StagedOutputs::stage_folder(const std::string& target) {
  require_replaceable_output(target, true);
  const std::string temp = stage_path(target);
  entries_.back().folder = true;
  std::error_code error;
  if (!std::filesystem::create_directory(temp, error) || error) {
    entries_.pop_back();
    throw InputError(target, "cannot create the folder " + temp + (error ? ": " + error.message() : ""));
  }
  return temp;
}

void StagedOutputs::commit() {
  namespace fs = std::filesystem;
  // A folder's previous version (a rerun's) is moved aside first, since a rename cannot replace a
  // folder that holds files, and removed once every output is in place.
  std::vector<std::string> aside;
  const auto roll_back = [&] {
    std::error_code ignored;
    for (Entry& done : entries_) {
      if (done.committed && done.folder) fs::remove_all(done.target, ignored);
      if (done.committed && !done.folder) fs::remove(done.target, ignored);
      done.committed = false;
    }
    for (const std::string& old : aside) fs::rename(old + ".previous-" + std::to_string(::getpid()), old, ignored);
  };
  for (Entry& entry : entries_) {
    std::error_code error;
    if (entry.folder && fs::is_directory(fs::symlink_status(entry.target))) {
      fs::rename(entry.target, entry.target + ".previous-" + std::to_string(::getpid()), error);
      if (!error) aside.push_back(entry.target);
    }
    if (!error) fs::rename(entry.temp, entry.target, error);
    if (error) {
      roll_back();
      throw InputError(entry.target, "cannot rename " + entry.temp + " into place: " + error.message());
    }
    entry.committed = true;
  }
  std::error_code ignored;
  for (const std::string& old : aside) fs::remove_all(old + ".previous-" + std::to_string(::getpid()), ignored);
}

void write_file_atomically(const std::string& path, std::span<const std::byte> bytes) {
  TempFile file(path);
  file.write(bytes);
  file.commit();
}

std::size_t first_non_finite(std::span<const float> values) {
  std::uint32_t largest = 0;
  for (const float v : values) largest = std::max(largest, std::bit_cast<std::uint32_t>(v) & 0x7fffffffu);
  if (largest < 0x7f800000u) return values.size();
  return static_cast<std::size_t>(std::find_if(values.begin(), values.end(), [](float v) { return !std::isfinite(v); }) -
                                  values.begin());
}

}  // namespace odyssey::io
