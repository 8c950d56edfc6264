// An sbatch script that runs one batch as a Slurm job array: task k of the array runs shard k of
// N (`--shard slurm` reads SLURM_ARRAY_TASK_ID, SLURM_ARRAY_TASK_MIN and SLURM_ARRAY_TASK_COUNT),
// with `--jobs` workers on the task's CPUs. Every shard writes into the same output folder, each
// with its own journal; the report command (`odyssey batch-report DIR`) then renders the whole
// batch's report.
#pragma once

#include <string>
#include <vector>

namespace odyssey::batch {

struct SlurmScriptOptions {
  std::string job_name = "odyssey-batch";
  int tasks = 1;               // array size: shards
  int cpus_per_task = 2;       // workers per shard
  long memory_mb = 4096;       // per task
  long time_limit_minutes = 24 * 60;
  std::string partition;       // empty: the cluster's default
  std::string working_folder;  // where relative paths in the command resolve
  std::string log_folder;      // slurm-<array job>_<task>.log
  std::vector<std::string> command;  // the batch command: program and arguments, before the shard options
  std::string report_command = "odyssey batch-report";  // run on OUT once every task has ended
};

// The script's text. Arguments are single-quoted for the shell.
std::string slurm_script(const SlurmScriptOptions& options);

}  // namespace odyssey::batch
