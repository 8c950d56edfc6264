// Batch manifests (batch::read_manifest): the first byte picks CSV (even) or JSON (odd), the rest
// is the file. Rows are turned into jobs (paths, settings, names), never run.
#include "batch/job.h"
#include "fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static odyssey::fuzz::ScratchFile csv("jobs.csv"), json("jobs.json");
  if (size == 0) return 0;
  const std::string& path = (data[0] % 2 == 0 ? csv : json).write(data + 1, size - 1);
  odyssey::fuzz::expect_input_errors([&] {
    const std::vector<odyssey::batch::Job> jobs = odyssey::batch::read_manifest(path, odyssey::batch::JobDefaults{});
    odyssey::batch::check_job_names(jobs);
  });
  return 0;
}
