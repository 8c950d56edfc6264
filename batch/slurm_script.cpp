#include "batch/slurm_script.h"

#include <cstdio>

namespace odyssey::batch {
namespace {

std::string shell_quoted(const std::string& text) {
  std::string quoted = "'";
  for (char c : text) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

}  // namespace

std::string slurm_script(const SlurmScriptOptions& options) {
  char time[32];
  std::snprintf(time, sizeof time, "%ld:%02ld:00", options.time_limit_minutes / 60, options.time_limit_minutes % 60);
  std::string script = "#!/bin/bash\n";
  script += "# Written by odyssey --slurm-script: submit with `sbatch FILE`, then merge the shards'\n";
  script += "# reports with `" + options.report_command + " OUT` once every task has ended.\n";
  script += "#SBATCH --job-name=" + options.job_name + "\n";
  script += "#SBATCH --array=1-" + std::to_string(options.tasks) + "\n";
  script += "#SBATCH --ntasks=1\n";
  script += "#SBATCH --cpus-per-task=" + std::to_string(options.cpus_per_task) + "\n";
  script += "#SBATCH --mem=" + std::to_string(options.memory_mb) + "M\n";
  script += std::string("#SBATCH --time=") + time + "\n";
  if (!options.partition.empty()) script += "#SBATCH --partition=" + options.partition + "\n";
  script += "#SBATCH --chdir=" + options.working_folder + "\n";
  script += "#SBATCH --output=" + options.log_folder + "/slurm-%A_%a.log\n";
  script += "set -euo pipefail\n";
  script += "exec";
  for (const std::string& argument : options.command) script += " " + shell_quoted(argument);
  script += " --shard slurm --jobs \"${SLURM_CPUS_PER_TASK:-" + std::to_string(options.cpus_per_task) + "}\"\n";
  return script;
}

}  // namespace odyssey::batch
