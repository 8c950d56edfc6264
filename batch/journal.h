// The batch's memory of finished work: an append-only file of JSON lines in the output folder,
// DIR/journal.jsonl (a shard I of N: DIR/journal.shard-I-of-N.jsonl). Line 1 is the header: the
// batch's settings (what every job shares) and the shard with its planned job count. Every later
// line records one job that finished (done or failed): its name, the key of its inputs and
// settings, its result. Each record is one write() of a whole line followed by fsync, so a
// SIGKILL or power loss leaves at most a torn last line, which reading ignores.
//
// A job's key hashes what its outputs depend on: its kind, name and settings, the odyssey version,
// and the content of every input file (motion, character, bone maps, body model, scene file and
// the files it names). A rerun skips a job whose last record is "done" with the same key and whose
// folder is there; everything else runs again.
#pragma once

#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace odyssey::batch {

// 64-bit content hashes as 16 hex digits (not cryptographic: they detect change).
std::string hash_bytes(const void* data, std::size_t size, std::uint64_t seed = 0);
std::string hash_text(const std::string& text);
// Throws io::InputError naming the file when it cannot be read.
std::string hash_file(const std::string& path);

// Throws io::InputError naming the path when it is not a regular file ("is a FIFO, not a regular
// file") or does not exist: what the batch's own process may read before any worker starts.
void require_regular_file(const std::string& path);

// Hashes files once per process, trusting an earlier hash while the file's size and modification
// time are unchanged (as git's index does); stamps from journals seed it.
class FileHasher {
 public:
  std::string hash(const std::string& path);
  void remember(const std::string& path, const nlohmann::json& stamp);  // {"size","mtime_ns","hash"}
  nlohmann::json stamp(const std::string& path);                        // hashes when needed

 private:
  struct Stamp {
    std::uintmax_t size = 0;
    std::int64_t mtime_ns = 0;
    std::string hash;
  };
  std::map<std::string, Stamp> stamps_;
};

class Journal {
 public:
  // The journal file of `shard` ("" for an unsharded run) in `folder`.
  static std::string file_name(const std::string& shard);

  // Reads every journal in `folder` (all shards). Throws io::InputError naming a journal whose
  // settings differ from `settings` (another batch's), with the first setting that differs.
  // Then opens this run's journal for appending, writing its header when new.
  Journal(const std::string& folder, const std::string& shard, const nlohmann::ordered_json& settings, long planned_jobs);
  ~Journal();
  Journal(const Journal&) = delete;
  Journal& operator=(const Journal&) = delete;

  // The last record of each job name over every journal read, and the headers read.
  const std::map<std::string, nlohmann::json>& records() const { return records_; }
  const std::vector<nlohmann::json>& headers() const { return headers_; }

  // One line, written whole and fsync'd. Throws io::InputError when the write fails.
  void append(const nlohmann::ordered_json& record);

 private:
  std::string path_;
  int fd_ = -1;
  std::map<std::string, nlohmann::json> records_;
  std::vector<nlohmann::json> headers_;
};

// Every journal in `folder`: its records (the last of each job name, over all journals) and
// headers, for the merged report. Throws io::InputError when the folder holds none, or journals
// of batches with different settings.
struct JournalContents {
  std::map<std::string, nlohmann::json> records;
  std::vector<nlohmann::json> headers;
};
JournalContents read_journals(const std::string& folder);

}  // namespace odyssey::batch
