#include "mocap_io/output_file.h"

#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <mutex>
#include <regex>
#include <set>
#include <stdexcept>
#include <thread>
#include <utility>

#include "mocap_io/input_error.h"

namespace odyssey::io {
namespace fs = std::filesystem;
namespace {

// Distinguishes the temporary files of several writers to one target within a process.
std::atomic<unsigned> temp_counter{0};

// Every temporary this process has made and not yet renamed into place or removed (path ->
// folder), and the folders already swept. One lock guards creation, listing, the renames of a
// commit and the removal on an interrupt, so that none of them interleave.
struct Listing {
  std::mutex mutex;
  std::map<std::string, bool> temporaries;
  std::set<std::string> swept;
};

Listing& listing() {
  // Never destroyed: the interrupt thread may use it while static destructors run.
  static Listing* const instance = [] {
    auto* made = new Listing;
    // A fork() while another thread holds the lock would leave it held forever in the child.
    ::pthread_atfork([] { listing().mutex.lock(); }, [] { listing().mutex.unlock(); },
                     [] {
                       listing().mutex.unlock();
                       listing().temporaries.clear();
                       listing().swept.clear();
                     });
    return made;
  }();
  return *instance;
}

// The first eight hex digits of FNV-1a over the host name.
const std::string& host_tag() {
  static const std::string tag = [] {
    char name[256] = {};
    ::gethostname(name, sizeof name - 1);
    std::uint32_t hash = 2166136261u;
    for (const char* c = name; *c; ++c) hash = (hash ^ static_cast<unsigned char>(*c)) * 16777619u;
    char text[9];
    std::snprintf(text, sizeof text, "%08x", hash);
    return std::string(text);
  }();
  return tag;
}

std::string tagged_name(const std::string& target, const char* kind) {
  return target + "." + kind + "-" + std::to_string(::getpid()) + "-" + std::to_string(temp_counter++) + "-" + host_tag();
}

// Sweeps the folder holding `target` unless this process already has; the caller holds the lock.
void sweep_once(const std::string& target) {
  std::error_code error;
  fs::path folder = fs::absolute(target, error).parent_path();
  if (error) return;
  if (!listing().swept.insert(folder.string()).second) return;
  sweep_leftovers(folder.string());
}

// What a target is, for a message saying what blocked a commit.
std::string what_is_there(const std::string& target) {
  std::error_code error;
  const fs::file_status status = fs::symlink_status(target, error);
  if (error || !fs::exists(status)) return "nothing";
  return fs::is_regular_file(status) ? "a file"
         : fs::is_directory(status) ? "a folder"
         : fs::is_symlink(status)   ? "a link"
                                    : "a device, FIFO or socket";
}

int interrupt_pipe[2] = {-1, -1};

extern "C" void on_interrupt(int signal) {
  const int saved = errno;
  const unsigned char number = static_cast<unsigned char>(signal);
  [[maybe_unused]] const ssize_t written = ::write(interrupt_pipe[1], &number, 1);
  errno = saved;
}

// Waits for a signal's number, then removes every listed temporary and ends the process. It holds
// the lock to the end, so nothing is created or renamed after the removal.
void clean_up_on_interrupt() {
  unsigned char number = 0;
  while (::read(interrupt_pipe[0], &number, 1) != 1) {
    if (errno != EINTR) return;
  }
  Listing& all = listing();
  all.mutex.lock();
  std::error_code ignored;
  int removed = 0;
  for (const auto& [path, folder] : all.temporaries) {
    removed += folder ? fs::remove_all(path, ignored) > 0 : fs::remove(path, ignored);
  }
  const std::string message = std::string("odyssey: interrupted by ") + (number == SIGINT ? "SIGINT" : "SIGTERM") +
                              ", removed " + std::to_string(removed) + " unfinished output" + (removed == 1 ? "" : "s") + "\n";
  [[maybe_unused]] const ssize_t written = ::write(STDERR_FILENO, message.data(), message.size());
  ::_exit(128 + number);
}

void reset_interrupts_in_child() {
  struct sigaction action {};
  action.sa_handler = SIG_DFL;
  ::sigaction(SIGINT, &action, nullptr);
  ::sigaction(SIGTERM, &action, nullptr);
}

}  // namespace

std::string temporary_name(const std::string& target) { return tagged_name(target, "partial"); }

std::FILE* create_temporary_file(const std::string& path, const char* mode) {
  Listing& all = listing();
  const std::lock_guard lock(all.mutex);
  std::FILE* file = std::fopen(path.c_str(), mode);
  if (file) all.temporaries.emplace(path, false);
  return file;
}

void forget_temporary(const std::string& path) {
  Listing& all = listing();
  const std::lock_guard lock(all.mutex);
  all.temporaries.erase(path);
}

void install_interrupt_cleanup() {
  listing();
  if (::pipe2(interrupt_pipe, O_CLOEXEC) != 0) return;
  std::thread(clean_up_on_interrupt).detach();
  ::pthread_atfork(nullptr, nullptr, reset_interrupts_in_child);
  struct sigaction action {};
  action.sa_handler = on_interrupt;
  action.sa_flags = SA_RESTART;
  ::sigemptyset(&action.sa_mask);
  ::sigaction(SIGINT, &action, nullptr);
  ::sigaction(SIGTERM, &action, nullptr);
}

int sweep_leftovers(const std::string& folder) {
  // The first ".partial-" or ".previous-" block names the process; a writer's own temporary of a
  // staged file (".partial-...-<key>" after it) goes with it.
  static const std::regex pattern(R"(^(.+?)\.(partial|previous)-([0-9]{1,10})-[0-9]{1,10}-([0-9a-f]{8})(\..*)?$)");
  std::error_code error;
  fs::directory_iterator it(folder, error);
  if (error) return 0;
  int handled = 0;
  for (; it != fs::directory_iterator(); it.increment(error)) {
    if (error) break;
    const std::string name = it->path().filename().string();
    std::smatch match;
    if (!std::regex_match(name, match, pattern) || match[4] != host_tag()) continue;
    const long long pid = std::stoll(match[3]);
    if (pid <= 0 || pid > std::numeric_limits<pid_t>::max() || pid == ::getpid()) continue;
    if (::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;  // running, or not ours to judge
    std::error_code ignored;
    const fs::path target = fs::path(folder) / match[1].str();
    if (match[2] == "previous" && !match[5].matched && !fs::exists(fs::symlink_status(target, ignored))) {
      fs::rename(it->path(), target, ignored);
    } else {
      fs::remove_all(it->path(), ignored);
    }
    ++handled;
  }
  return handled;
}

TempFile::TempFile(std::string target) : target_(std::move(target)), temp_(temporary_name(target_)) {
  // The last guard for writers that stage nothing (pose, make-body, the demo's files): renaming
  // onto a device node would replace it.
  require_replaceable_output(target_);
  {
    const std::lock_guard lock(listing().mutex);
    sweep_once(target_);
  }
  file_ = create_temporary_file(temp_, "wb");
  if (!file_) throw InputError(target_, "cannot create " + temp_ + ": " + std::strerror(errno));
}

TempFile::~TempFile() {
  if (file_) std::fclose(file_);
  if (!committed_) {
    std::remove(temp_.c_str());
    forget_temporary(temp_);
  }
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
  Listing& all = listing();
  const std::lock_guard lock(all.mutex);
  if (std::rename(temp_.c_str(), target_.c_str()) != 0) {
    throw InputError(target_, "cannot rename " + temp_ + " into place: " + std::strerror(errno));
  }
  all.temporaries.erase(temp_);
  committed_ = true;
}

StagedOutputs::~StagedOutputs() {
  Listing& all = listing();
  const std::lock_guard lock(all.mutex);
  std::error_code ignored;
  for (const Entry& entry : entries_) {
    if (entry.committed) continue;
    if (entry.folder) {
      fs::remove_all(entry.temp, ignored);
    } else {
      fs::remove(entry.temp, ignored);
    }
    all.temporaries.erase(entry.temp);
  }
}

void require_replaceable_output(const std::string& target, bool folder) {
  std::error_code error;
  const fs::file_status status = fs::status(target, error);
  if (error || !fs::exists(status)) {
    // A new output goes into a folder that must be there: no output makes its parents.
    const fs::path parent = fs::path(target).parent_path();
    if (!parent.empty() && !fs::is_directory(parent, error)) {
      throw InputError(target, "its folder " + parent.string() + (fs::exists(parent, error) ? " is not a folder" : " does not exist"));
    }
    return;
  }
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

void require_not_an_input(const std::string& output, const std::vector<std::string>& inputs) {
  const fs::path normal = fs::absolute(output).lexically_normal();
  for (const std::string& input : inputs) {
    if (input.empty()) continue;
    std::error_code error;
    if (fs::absolute(input).lexically_normal() == normal || fs::equivalent(input, output, error)) {
      throw InputError(output, "is also an input of this run (" + input + "): an output never replaces an input");
    }
  }
}

std::string StagedOutputs::stage(const std::string& target) {
  require_replaceable_output(target);
  return stage_path(target);
}

std::string StagedOutputs::stage_path(const std::string& target) {
  const fs::path absolute = fs::absolute(target);
  for (const Entry& entry : entries_) {
    if (fs::absolute(entry.target) == absolute) throw std::invalid_argument("two outputs name " + target);
  }
  Listing& all = listing();
  const std::lock_guard lock(all.mutex);
  sweep_once(target);
  entries_.push_back({target, temporary_name(target)});
  all.temporaries.emplace(entries_.back().temp, false);
  return entries_.back().temp;
}

std::string StagedOutputs::stage_folder(const std::string& target) {
  require_replaceable_output(target, true);
  const std::string temp = stage_path(target);
  Listing& all = listing();
  const std::lock_guard lock(all.mutex);
  entries_.back().folder = true;
  all.temporaries[temp] = true;
  std::error_code error;
  if (!fs::create_directory(temp, error) || error) {
    all.temporaries.erase(temp);
    entries_.pop_back();
    throw InputError(target, "cannot create the folder " + temp + (error ? ": " + error.message() : ""));
  }
  return temp;
}

void StagedOutputs::commit() {
  Listing& all = listing();
  const std::lock_guard lock(all.mutex);
  // Each previous output, kept until every new one is in place: a file by a hard link (the target
  // never goes missing; moved aside where links are not supported), a folder moved aside (a
  // rename cannot replace a folder that holds files).
  struct Aside {
    std::string path;
    bool moved = false;  // the target itself was moved (a folder, or no hard link)
  };
  std::vector<Aside> asides(entries_.size());
  const auto roll_back = [&](std::size_t count) -> std::string {
    std::string kept;
    for (std::size_t i = 0; i < count; ++i) {
      Entry& entry = entries_[i];
      const Aside& aside = asides[i];
      std::error_code error;
      if (entry.committed || aside.moved) {
        if (entry.committed && (aside.path.empty() || entry.folder)) fs::remove_all(entry.target, error);
        if (!aside.path.empty()) fs::rename(aside.path, entry.target, error);
      } else if (!aside.path.empty()) {
        fs::remove(aside.path, error);
      }
      if (error && !aside.path.empty()) kept += "; the previous " + entry.target + " is kept as " + aside.path;
      entry.committed = false;
    }
    return kept;
  };
  for (std::size_t i = 0; i < entries_.size(); ++i) {
    Entry& entry = entries_[i];
    try {
      require_replaceable_output(entry.target, entry.folder);
    } catch (const InputError& blocked) {
      const std::string kept = roll_back(i);
      throw InputError(entry.target, blocked.problem() + "; nothing was replaced" + kept);
    }
    std::error_code error;
    if (!fs::exists(fs::symlink_status(entry.target, error))) continue;
    Aside& aside = asides[i];
    aside.path = tagged_name(entry.target, "previous");
    if (entry.folder || ::link(entry.target.c_str(), aside.path.c_str()) != 0) {
      aside.moved = true;
      fs::rename(entry.target, aside.path, error);
    }
    if (error) {
      aside = {};
      const std::string kept = roll_back(i);
      throw InputError(entry.target, "cannot keep the previous version aside: " + error.message() + "; nothing was replaced" + kept);
    }
  }
  for (std::size_t i = 0; i < entries_.size(); ++i) {
    Entry& entry = entries_[i];
    std::error_code error;
    fs::rename(entry.temp, entry.target, error);
    if (error) {
      const std::string there = what_is_there(entry.target);
      const std::string kept = roll_back(entries_.size());
      throw InputError(entry.target, "cannot rename " + entry.temp + " into place: " + error.message() + " (the target holds " +
                                         there + "); the previous outputs are back in place" + kept);
    }
    entry.committed = true;
  }
  for (std::size_t i = 0; i < entries_.size(); ++i) {
    all.temporaries.erase(entries_[i].temp);
    std::error_code ignored;
    if (!asides[i].path.empty()) fs::remove_all(asides[i].path, ignored);
  }
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
