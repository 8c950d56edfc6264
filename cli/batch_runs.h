// What `odyssey batch` and `odyssey dataset` share: their worker, limit and shard options, the
// progress line, and the sbatch script that runs them as a Slurm job array.
#pragma once

#include <string>
#include <vector>

#include "batch/batch.h"
#include "cli/args.h"

namespace odyssey::cli {

// --out, --jobs, --timeout, --max-memory, --shard, --slurm-*, --quiet.
void add_run_options(Args& args, const std::string& unit);
// The options above as the batch takes them (settings and gates are the caller's).
batch::BatchOptions run_options_from(const Args& args);

// Progress: on a terminal a bar redrawn in place; otherwise a line every 30 s and for each
// failure; nothing with --quiet. `unit` names what is counted ("jobs", "sequences").
class ProgressPrinter {
 public:
  ProgressPrinter(bool quiet, std::string unit);
  void operator()(const batch::BatchProgress& p);
  void end();

 private:
  bool quiet_, interactive_;
  std::string unit_;
  bool drawn_ = false, ended_ = false;
  double last_line_s_ = 0;
};

// --slurm-script: writes an sbatch script that runs `subcommand` with these arguments (less the
// shard, job and script options) as a job array of shards, and prints how to submit it.
void write_slurm_script(const Args& args, const std::vector<std::string>& arguments, const std::string& subcommand,
                        const std::string& report_command, std::size_t job_count, int workers);

}  // namespace odyssey::cli
