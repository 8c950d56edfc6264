#include "batch/journal.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <vector>

#include "mocap_io/input_error.h"

namespace odyssey::batch {
namespace fs = std::filesystem;
namespace {

constexpr int kJournalVersion = 1;

// Word-at-a-time multiply-rotate mixing with murmur3's 64-bit finaliser: every input bit reaches
// every output bit. State carries across chunks so a file hashes the same however it is read.
struct Hasher {
  std::uint64_t h;
  std::uint64_t length = 0;
  explicit Hasher(std::uint64_t seed) : h(seed ^ 0x9e3779b97f4a7c15ull) {}
  static std::uint64_t rotl(std::uint64_t x, int r) { return (x << r) | (x >> (64 - r)); }
  void word(std::uint64_t k) {
    k *= 0x87c37b91114253d5ull;
    k = rotl(k, 31);
    k *= 0x4cf5ad432745937full;
    h ^= k;
    h = rotl(h, 27) * 5 + 0x52dce729;
  }
  // `size` a multiple of 8 except for the last call.
  void update(const unsigned char* data, std::size_t size) {
    length += size;
    std::size_t i = 0;
    for (; i + 8 <= size; i += 8) {
      std::uint64_t k;
      std::memcpy(&k, data + i, 8);
      word(k);
    }
    if (i < size) {
      std::uint64_t k = 0;
      std::memcpy(&k, data + i, size - i);
      word(k ^ (0xffull << 56));
    }
  }
  std::string finish() {
    std::uint64_t x = h ^ length;
    x ^= x >> 33;
    x *= 0xff51afd7ed558ccdull;
    x ^= x >> 33;
    x *= 0xc4ceb9fe1a85ec53ull;
    x ^= x >> 33;
    char text[17];
    std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(x));
    return text;
  }
};

std::int64_t mtime_ns(const struct stat& status) {
  return static_cast<std::int64_t>(status.st_mtim.tv_sec) * 1000000000 + status.st_mtim.tv_nsec;
}

bool is_journal_name(const std::string& name) {
  return name == "journal.jsonl" || (name.rfind("journal.shard-", 0) == 0 && name.size() > 6 &&
                                     name.compare(name.size() - 6, 6, ".jsonl") == 0);
}

// The first key whose values differ, as "quality: fast here, balanced there".
std::string first_difference(const nlohmann::json& here, const nlohmann::json& there) {
  for (const auto& [key, value] : here.items()) {
    if (!there.contains(key)) return key + ": set here, absent there";
    if (there[key] != value) return key + ": " + value.dump() + " here, " + there[key].dump() + " there";
  }
  for (const auto& [key, value] : there.items()) {
    if (!here.contains(key)) return key + ": absent here, " + value.dump() + " there";
  }
  return "the journal version";
}

// Reads one journal: its header and records. A line that is not JSON is a record torn by an
// interrupted write (appending starts the next record on a line of its own): its job simply has
// no record.
bool read_journal(const fs::path& path, JournalContents& contents) {
  std::ifstream file(path, std::ios::binary);
  if (!file) throw io::InputError(path.string(), "cannot read the journal");
  std::string line;
  int number = 0;
  bool header = false;
  while (std::getline(file, line)) {
    ++number;
    nlohmann::json value = nlohmann::json::parse(line, nullptr, false);
    if (value.is_discarded() || !value.is_object()) continue;
    if (number == 1) {
      if (!value.contains("odyssey_batch_journal")) throw io::InputError(path.string(), "not a batch journal");
      contents.headers.push_back(std::move(value));
      header = true;
    } else if (value.contains("job") && value["job"].is_string()) {
      std::string name = value["job"].get<std::string>();  // before the move below empties `value`
      contents.records[std::move(name)] = std::move(value);
    } else {
      throw io::InputError(path.string(), "line " + std::to_string(number) + ": not a job record");
    }
  }
  return header;
}

std::vector<fs::path> journals_in(const std::string& folder) {
  std::vector<fs::path> paths;
  std::error_code error;
  for (const auto& entry : fs::directory_iterator(folder, error)) {
    if (entry.is_regular_file() && is_journal_name(entry.path().filename().string())) paths.push_back(entry.path());
  }
  std::sort(paths.begin(), paths.end());
  return paths;
}

void check_settings(const JournalContents& contents, const std::vector<fs::path>& paths) {
  for (std::size_t i = 1; i < contents.headers.size(); ++i) {
    if (contents.headers[i]["settings"] != contents.headers[0]["settings"]) {
      throw io::InputError(paths[i].string(), "holds another batch's journal than " + paths[0].string() + " (" +
                                                  first_difference(contents.headers[i]["settings"], contents.headers[0]["settings"]) + ")");
    }
  }
}

}  // namespace

std::string hash_bytes(const void* data, std::size_t size, std::uint64_t seed) {
  Hasher hasher(seed);
  hasher.update(static_cast<const unsigned char*>(data), size);
  return hasher.finish();
}

std::string hash_text(const std::string& text) { return hash_bytes(text.data(), text.size()); }

std::string hash_file(const std::string& path) {
  std::FILE* file = std::fopen(path.c_str(), "rb");
  if (!file) throw io::InputError(path, std::string("cannot read: ") + std::strerror(errno));
  Hasher hasher(0);
  std::vector<unsigned char> buffer(1 << 20);
  std::size_t read = 0;
  while ((read = std::fread(buffer.data(), 1, buffer.size(), file)) > 0) hasher.update(buffer.data(), read);
  const bool failed = std::ferror(file) != 0;
  std::fclose(file);
  if (failed) throw io::InputError(path, "cannot read");
  return hasher.finish();
}

static void require_regular_file(const std::string& path, const struct stat& status) {
  if (S_ISREG(status.st_mode)) return;
  const char* kind = S_ISDIR(status.st_mode)                            ? "a folder"
                     : S_ISFIFO(status.st_mode)                         ? "a FIFO"
                     : S_ISSOCK(status.st_mode)                         ? "a socket"
                     : S_ISCHR(status.st_mode) || S_ISBLK(status.st_mode) ? "a device"
                                                                        : "not a file";
  throw io::InputError(path, std::string("is ") + kind + ", not a regular file");
}

void require_regular_file(const std::string& path) {
  struct stat status {};
  if (::stat(path.c_str(), &status) != 0) throw io::InputError(path, std::string("cannot read: ") + std::strerror(errno));
  require_regular_file(path, status);
}

std::string FileHasher::hash(const std::string& path) { return stamp(path)["hash"].get<std::string>(); }

void FileHasher::remember(const std::string& path, const nlohmann::json& stamp) {
  if (!stamp.is_object() || !stamp.contains("size") || !stamp.contains("mtime_ns") || !stamp.contains("hash")) return;
  if (!stamp["size"].is_number_unsigned() || !stamp["mtime_ns"].is_number_integer() || !stamp["hash"].is_string()) return;
  stamps_.emplace(path, Stamp{stamp["size"].get<std::uintmax_t>(), stamp["mtime_ns"].get<std::int64_t>(),
                              stamp["hash"].get<std::string>()});
}

nlohmann::json FileHasher::stamp(const std::string& path) {
  struct stat status {};
  if (::stat(path.c_str(), &status) != 0) throw io::InputError(path, std::string("cannot read: ") + std::strerror(errno));
  // Hashing reads the file in the batch's own process, before any worker and its timeout: a FIFO
  // would block it and a device never end. Only regular files are hashed.
  require_regular_file(path, status);
  Stamp now{static_cast<std::uintmax_t>(status.st_size), mtime_ns(status), ""};
  const auto found = stamps_.find(path);
  if (found != stamps_.end() && found->second.size == now.size && found->second.mtime_ns == now.mtime_ns) {
    now.hash = found->second.hash;
  } else {
    now.hash = hash_file(path);
    stamps_[path] = now;
  }
  return {{"size", now.size}, {"mtime_ns", now.mtime_ns}, {"hash", now.hash}};
}

std::string Journal::file_name(const std::string& shard) {
  if (shard.empty()) return "journal.jsonl";
  const std::size_t slash = shard.find('/');
  return "journal.shard-" + shard.substr(0, slash) + "-of-" + shard.substr(slash + 1) + ".jsonl";
}

Journal::Journal(const std::string& folder, const std::string& shard, const nlohmann::ordered_json& settings,
                 long planned_jobs) {
  path_ = (fs::path(folder) / file_name(shard)).string();
  std::vector<fs::path> paths;
  JournalContents contents;
  for (const fs::path& path : journals_in(folder)) {
    // A journal whose header was torn by a crash recorded nothing yet: ours starts again.
    if (!read_journal(path, contents) && path == fs::path(path_)) {
      fs::remove(path);
      continue;
    }
    paths.push_back(path);
  }
  check_settings(contents, paths);
  const nlohmann::json ours = nlohmann::json(settings);
  if (!contents.headers.empty() && contents.headers[0]["settings"] != ours) {
    throw io::InputError(paths[0].string(), "the output folder holds another batch's journal (" +
                                                first_difference(ours, contents.headers[0]["settings"]) +
                                                "); use another --out, or remove the folder to start over");
  }
  records_ = std::move(contents.records);
  headers_ = std::move(contents.headers);

  const bool fresh = !fs::exists(path_);
  fd_ = ::open(path_.c_str(), O_RDWR | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (fd_ < 0) throw io::InputError(path_, std::string("cannot open the journal: ") + std::strerror(errno));
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    ::close(fd_);
    fd_ = -1;
    throw io::InputError(path_, errno == EWOULDBLOCK ? "another batch (or the same shard) is running into this folder"
                                                     : std::string("cannot lock the journal: ") + std::strerror(errno));
  }
  if (fresh) {
    nlohmann::ordered_json header;
    header["odyssey_batch_journal"] = kJournalVersion;
    header["settings"] = settings;
    header["shard"] = shard.empty() ? "1/1" : shard;
    header["planned_jobs"] = planned_jobs;
    append(header);
    headers_.push_back(nlohmann::json(header));
    // The new file's name must survive a crash too.
    const int directory = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (directory >= 0) {
      ::fsync(directory);
      ::close(directory);
    }
  }
}

Journal::~Journal() {
  if (fd_ >= 0) ::close(fd_);
}

void Journal::append(const nlohmann::ordered_json& record) {
  // A record left torn by a crash is the file's last line: start ours on a line of its own.
  std::string line = record.dump() + "\n";
  const off_t end = ::lseek(fd_, 0, SEEK_END);
  if (end > 0) {
    char last = '\n';
    if (::pread(fd_, &last, 1, end - 1) == 1 && last != '\n') line.insert(line.begin(), '\n');
  }
  const char* data = line.data();
  std::size_t left = line.size();
  while (left > 0) {
    const ssize_t written = ::write(fd_, data, left);
    if (written < 0 && errno == EINTR) continue;
    if (written <= 0) throw io::InputError(path_, std::string("cannot write the journal: ") + std::strerror(errno));
    data += written;
    left -= static_cast<std::size_t>(written);
  }
  if (::fsync(fd_) != 0) throw io::InputError(path_, std::string("cannot sync the journal: ") + std::strerror(errno));
  if (record.contains("job")) records_[record["job"].get<std::string>()] = nlohmann::json(record);
}

JournalContents read_journals(const std::string& folder) {
  const std::vector<fs::path> paths = journals_in(folder);
  if (paths.empty()) throw io::InputError(folder, "holds no batch journal (journal.jsonl or journal.shard-*.jsonl)");
  JournalContents contents;
  for (const fs::path& path : paths) read_journal(path, contents);
  check_settings(contents, paths);
  return contents;
}

}  // namespace odyssey::batch
