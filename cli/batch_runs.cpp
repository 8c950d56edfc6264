#include "cli/batch_runs.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <thread>

#include "batch/slurm_script.h"
#include "mocap_io/output_file.h"

namespace odyssey::cli {
namespace fs = std::filesystem;
namespace {

std::string duration_text(double seconds) {
  char text[32];
  if (!std::isfinite(seconds)) return "?";
  const long s = std::lround(seconds);
  if (s >= 3600) {
    std::snprintf(text, sizeof text, "%ldh%02ldm", s / 3600, s / 60 % 60);
  } else if (s >= 60) {
    std::snprintf(text, sizeof text, "%ldm%02lds", s / 60, s % 60);
  } else {
    std::snprintf(text, sizeof text, "%lds", s);
  }
  return text;
}

// The command line without the options that make a script, for the script to run.
std::vector<std::string> command_for_script(const std::string& subcommand, const std::vector<std::string>& arguments) {
  char self[4096];
  const ssize_t length = ::readlink("/proc/self/exe", self, sizeof self - 1);
  std::vector<std::string> command{length > 0 ? std::string(self, static_cast<std::size_t>(length)) : "odyssey", subcommand};
  for (std::size_t i = 0; i < arguments.size(); ++i) {
    const std::string& argument = arguments[i];
    const bool value_follows = argument.find('=') == std::string::npos;
    if (argument.rfind("--slurm-", 0) == 0 || argument.rfind("--shard", 0) == 0 || argument.rfind("--jobs", 0) == 0) {
      if (value_follows) ++i;
      continue;
    }
    command.push_back(argument);
  }
  return command;
}

}  // namespace

void add_run_options(Args& args, const std::string& unit) {
  args.option("out", "DIR", "the output folder (required)")
      .option("jobs", "N", "worker processes (default: the number of cores)")
      .option("timeout", "SECONDS", "fail one of the " + unit + " that runs longer than this (default: no limit)")
      .option("max-memory", "GIB", "address space of each worker (default: 90% of the memory, shared among the workers)")
      .option("shard", "I/N", "run only shard I of N of the " + unit + " (1 <= I <= N), or 'slurm' to take it from a Slurm job array")
      .option("slurm-script", "FILE", "write an sbatch script that runs this command as a job array, and stop")
      .option("slurm-tasks", "N", "the script's array size: shards (default: 4, at most the number of " + unit + ")")
      .option("slurm-cpus", "N", "the script's CPUs per task, one worker each (default: --jobs, or 4)")
      .option("slurm-mem", "MB", "the script's memory per task (default: 3072 per CPU)")
      .option("slurm-time", "MINUTES", "the script's time limit per task (default: 1440)")
      .option("slurm-partition", "NAME", "the script's partition (default: the cluster's)")
      .flag("quiet", "print only the closing summary");
}

batch::BatchOptions run_options_from(const Args& args) {
  batch::BatchOptions options;
  options.out = args.get("out");
  const long long cores = std::max(1u, std::thread::hardware_concurrency());
  options.workers = static_cast<int>(args.has("jobs") ? args.get_int("jobs") : cores);
  if (options.workers < 1 || options.workers > 1024) throw UsageError("--jobs expects 1 to 1024");
  if (args.has("timeout")) {
    options.timeout_s = args.get_double("timeout");
    if (!(options.timeout_s > 0)) throw UsageError("--timeout expects seconds above 0");
  }
  if (args.has("max-memory")) {
    const double gib = args.get_double("max-memory");
    if (!(gib > 0)) throw UsageError("--max-memory expects GiB above 0");
    options.memory_limit_bytes = static_cast<std::size_t>(gib * 1024 * 1024 * 1024);
  }
  if (args.has("shard")) {
    try {
      options.shard = batch::parse_shard(args.get("shard"));
    } catch (const std::invalid_argument& error) {
      throw UsageError(error.what());
    }
  }
  return options;
}

ProgressPrinter::ProgressPrinter(bool quiet, std::string unit)
    : quiet_(quiet), interactive_(::isatty(STDERR_FILENO) != 0), unit_(std::move(unit)) {}

void ProgressPrinter::operator()(const batch::BatchProgress& p) {
  if (quiet_) return;
  if (p.finished && p.finished->value("status", "") == "failed") {
    if (drawn_) std::fputs("\r\033[K", stderr);
    const nlohmann::json& error = (*p.finished)["error"];
    std::fprintf(stderr, "failed  %s: %s\n", (*p.finished)["job"].get<std::string>().c_str(),
                 error.is_string() ? error.get<std::string>().c_str() : "?");
  }
  const long finished = p.done + p.failed;
  const long ran = finished - p.resumed;
  const double rate = p.seconds > 0 ? static_cast<double>(p.frames) / p.seconds : 0;
  const double eta = ran > 0 ? p.seconds / static_cast<double>(ran) * static_cast<double>(p.total - finished) : NAN;
  char line[256];
  std::snprintf(line, sizeof line, "%ld/%ld %s, %.0f frames/s, ETA %s, %ld failed, %ld flagged", finished, p.total, unit_.c_str(), rate,
                finished == p.total ? "0s" : duration_text(eta).c_str(), p.failed, p.flagged);
  if (interactive_) {
    constexpr int kWidth = 30;
    const int filled = p.total > 0 ? static_cast<int>(kWidth * finished / p.total) : kWidth;
    std::fprintf(stderr, "\r\033[K[%s%s] %s", std::string(static_cast<std::size_t>(filled), '#').c_str(),
                 std::string(static_cast<std::size_t>(kWidth - filled), '.').c_str(), line);
    drawn_ = true;
  } else if (p.seconds - last_line_s_ >= 30 || (finished == p.total && !ended_)) {
    std::fprintf(stderr, "%s %s\n", unit_ == "sequences" ? "dataset" : "batch  ", line);
    last_line_s_ = p.seconds;
  }
  if (finished == p.total) ended_ = true;
  std::fflush(stderr);
}

void ProgressPrinter::end() {
  if (drawn_) std::fputc('\n', stderr);
}

void write_slurm_script(const Args& args, const std::vector<std::string>& arguments, const std::string& subcommand,
                        const std::string& report_command, std::size_t job_count, int workers) {
  const std::string out = args.get("out");
  batch::SlurmScriptOptions script;
  const long long tasks = args.has("slurm-tasks") ? args.get_int("slurm-tasks") : std::min<long long>(4, static_cast<long long>(job_count));
  if (tasks < 1 || tasks > 100000) throw UsageError("--slurm-tasks expects 1 to 100000");
  const long long cpus = args.has("slurm-cpus") ? args.get_int("slurm-cpus") : (args.has("jobs") ? workers : 4);
  if (cpus < 1 || cpus > 1024) throw UsageError("--slurm-cpus expects 1 to 1024");
  script.job_name = "odyssey-" + subcommand;
  script.tasks = static_cast<int>(tasks);
  script.cpus_per_task = static_cast<int>(cpus);
  script.memory_mb = args.has("slurm-mem") ? args.get_int("slurm-mem") : 3072 * cpus;
  script.time_limit_minutes = args.has("slurm-time") ? args.get_int("slurm-time") : 1440;
  if (script.memory_mb < 1 || script.time_limit_minutes < 1) throw UsageError("--slurm-mem and --slurm-time expect positive numbers");
  script.partition = args.get_optional("slurm-partition").value_or("");
  script.working_folder = fs::current_path().string();
  fs::create_directories(out);
  script.log_folder = fs::absolute(out).lexically_normal().string();
  script.command = command_for_script(subcommand, arguments);
  script.report_command = report_command;
  const std::string path = args.get("slurm-script");
  io::write_file_atomically(path, batch::slurm_script(script));
  fs::permissions(path, fs::perms::owner_exec | fs::perms::group_exec, fs::perm_options::add);
  std::printf("wrote %s: %zu %s in %d shards of %d CPUs each; submit with: sbatch %s; then: %s %s\n", path.c_str(), job_count,
              subcommand == "dataset" ? "sequences" : "jobs", script.tasks, script.cpus_per_task, path.c_str(), report_command.c_str(),
              out.c_str());
}

}  // namespace odyssey::cli
