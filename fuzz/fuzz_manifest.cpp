// Batch manifests (batch::read_manifest): the first byte picks CSV (even) or JSON (odd), the rest
// is the file. Rows are turned into jobs (paths, settings, names), never run. The job names a
// manifest passes with are held to what the batch relies on when it makes their folders: each
// normal name (batch::normal_job_name) is non-empty, relative, made of parts that are neither
// empty, "." nor "..", free of control characters, a fixed point of normalisation, stays inside
// the output folder, and is no other job's name or folder; a violation aborts (a finding).
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <string>

#include "batch/job.h"
#include "fuzz/fuzz_input.h"

namespace {

namespace fs = std::filesystem;

[[noreturn]] void violated(const std::string& name, const char* rule) {
  std::fprintf(stderr, "odyssey fuzz: job name '%s' passed the manifest checks but %s\n", name.c_str(), rule);
  std::abort();
}

void check_folder_names(const std::vector<odyssey::batch::Job>& jobs) {
  const fs::path out = "/out";
  std::set<std::string> names;
  for (const odyssey::batch::Job& job : jobs) {
    const std::string normal = odyssey::batch::normal_job_name(job.name);
    if (normal.empty()) violated(job.name, "normalises to nothing");
    if (odyssey::batch::normal_job_name(normal) != normal) violated(job.name, "is not a fixed point of normalisation");
    if (!fs::path(normal).is_relative()) violated(job.name, "is not relative");
    for (const fs::path& part : fs::path(normal)) {
      if (part.empty() || part == "." || part == "..") violated(job.name, "has an empty, . or .. part");
    }
    for (const char c : normal) {
      if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) violated(job.name, "holds a control character");
    }
    const std::string inside = (out / normal).lexically_normal().string();
    if (inside.compare(0, 5, "/out/") != 0) violated(job.name, "leaves the output folder");
    if (!names.insert(normal).second) violated(job.name, "is another job's name");
  }
  // No name is another's folder: "a/b" and "a/b/c" would nest.
  for (const std::string& name : names) {
    for (std::string parent = fs::path(name).parent_path().string(); !parent.empty();
         parent = fs::path(parent).parent_path().string()) {
      if (names.count(parent) != 0) violated(name, "sits in another job's folder");
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static odyssey::fuzz::ScratchFile csv("jobs.csv"), json("jobs.json");
  if (size == 0) return 0;
  const std::string& path = (data[0] % 2 == 0 ? csv : json).write(data + 1, size - 1);
  odyssey::fuzz::expect_input_errors([&] {
    const std::vector<odyssey::batch::Job> jobs = odyssey::batch::read_manifest(path, odyssey::batch::JobDefaults{});
    odyssey::batch::check_job_names(jobs);
    check_folder_names(jobs);
  });
  return 0;
}
