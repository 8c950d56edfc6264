// odyssey batch: many motions onto many characters (or a manifest of jobs), in worker processes,
// resumable, sharded on a Slurm job array; odyssey batch-report: the report of a batch's shards.
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "batch/batch.h"
#include "batch/report.h"
#include "batch/slurm_script.h"
#include "cli/args.h"
#include "cli/commands.h"
#include "cli/retarget_options.h"
#include "mocap_io/input_error.h"
#include "mocap_io/output_file.h"

namespace odyssey::cli {
namespace fs = std::filesystem;
namespace {

// Exit codes (docs/batches.md).
constexpr int kExitFailed = 1;   // some job failed
constexpr int kExitFlagged = 3;  // no job failed, some exceeded a gate

void add_gate_options(Args& args) {
  args.option("max-skate", "RATIO", "flag jobs whose foot skate ratio exceeds RATIO")
      .option("max-bone-error", "DEG", "flag jobs where some limb's mean direction error exceeds DEG degrees")
      .option("max-penetration", "CM", "flag jobs whose feet go more than CM centimetres below the floor")
      .option("max-floating", "CM", "flag jobs whose planted feet float more than CM centimetres")
      .option("max-jitter", "RATIO", "flag jobs whose jitter exceeds RATIO times the source's");
}

batch::Gates gates_from(const Args& args) {
  batch::Gates gates;
  const auto read = [&](const char* name, std::optional<double>& gate) {
    if (!args.has(name)) return;
    const double value = args.get_double(name);
    if (!(value >= 0)) throw UsageError(std::string("--") + name + " expects a number >= 0");
    gate = value;
  };
  read("max-skate", gates.max_skate);
  read("max-bone-error", gates.max_bone_error_deg);
  read("max-penetration", gates.max_penetration_cm);
  read("max-floating", gates.max_floating_cm);
  read("max-jitter", gates.max_jitter_ratio);
  return gates;
}

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

// Progress: on a terminal a bar redrawn in place; otherwise a line every 30 s and for each
// failure; nothing with --quiet.
class ProgressPrinter {
 public:
  explicit ProgressPrinter(bool quiet) : quiet_(quiet), interactive_(::isatty(STDERR_FILENO) != 0) {}

  void operator()(const batch::BatchProgress& p) {
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
    std::snprintf(line, sizeof line, "%ld/%ld jobs, %.0f frames/s, ETA %s, %ld failed, %ld flagged", finished, p.total, rate,
                  finished == p.total ? "0s" : duration_text(eta).c_str(), p.failed, p.flagged);
    if (interactive_) {
      constexpr int kWidth = 30;
      const int filled = p.total > 0 ? static_cast<int>(kWidth * finished / p.total) : kWidth;
      std::fprintf(stderr, "\r\033[K[%s%s] %s", std::string(static_cast<std::size_t>(filled), '#').c_str(),
                   std::string(static_cast<std::size_t>(kWidth - filled), '.').c_str(), line);
      drawn_ = true;
    } else if (p.seconds - last_line_s_ >= 30 || (finished == p.total && !ended_)) {
      std::fprintf(stderr, "batch   %s\n", line);
      last_line_s_ = p.seconds;
    }
    if (finished == p.total) ended_ = true;
    std::fflush(stderr);
  }
  void end() {
    if (drawn_) std::fputc('\n', stderr);
  }

 private:
  bool quiet_, interactive_;
  bool drawn_ = false, ended_ = false;
  double last_line_s_ = 0;
};

// The command line without the options that make a script, for the script to run.
std::vector<std::string> command_for_script(const std::vector<std::string>& arguments) {
  char self[4096];
  const ssize_t length = ::readlink("/proc/self/exe", self, sizeof self - 1);
  std::vector<std::string> command{length > 0 ? std::string(self, static_cast<std::size_t>(length)) : "odyssey", "batch"};
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

// The command line's retargeting settings and outputs, which a job keeps where it does not say.
batch::JobDefaults job_defaults_from(const Args& args) {
  batch::JobDefaults defaults;
  defaults.request = retarget_settings_from(args, "", "");
  const auto outputs = batch::parse_job_outputs(args.get("outputs"));
  if (!outputs) throw UsageError(std::string("--outputs expects a list of ") + batch::kJobOutputNames + ", got '" + args.get("outputs") + "'");
  defaults.outputs = *outputs;
  return defaults;
}

// The jobs the command line asks for: a manifest's, or every motion onto every character.
std::vector<batch::Job> jobs_from(const Args& args, const batch::JobDefaults& defaults) {
  std::vector<batch::Job> jobs;
  if (args.has("manifest")) {
    if (args.has("motions") || args.has("characters")) throw UsageError("--manifest lists the jobs; leave out --motions and --characters");
    jobs = batch::read_manifest(args.get("manifest"), defaults);
  } else {
    if (!args.has("motions") || !args.has("characters")) throw UsageError("give --motions and --characters, or --manifest");
    jobs = batch::cross_product_jobs(batch::find_input_files(args.get_list("motions"), batch::kMotionExtensions, "motion"),
                                     batch::find_input_files(args.get_list("characters"), batch::kCharacterExtensions, "character"),
                                     defaults);
  }
  if (jobs.empty()) throw UsageError("no jobs: the lists are empty");
  batch::check_job_names(jobs);
  return jobs;
}

// How the batch runs: its folder, workers, limits, gates, shard, and the settings it records.
batch::BatchOptions batch_options_from(const Args& args, const batch::JobDefaults& defaults) {
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
  options.gates = gates_from(args);
  options.settings = batch::request_settings_json(defaults.request, defaults.outputs);
  if (args.has("shard")) {
    try {
      options.shard = batch::parse_shard(args.get("shard"));
    } catch (const std::invalid_argument& error) {
      throw UsageError(error.what());
    }
  }
  return options;
}

// --slurm-script: an sbatch script that runs this command as a job array of shards.
void write_slurm_script(const Args& args, const std::vector<std::string>& arguments, std::size_t job_count, int workers) {
  const std::string out = args.get("out");
  batch::SlurmScriptOptions script;
  const long long tasks = args.has("slurm-tasks") ? args.get_int("slurm-tasks") : std::min<long long>(4, static_cast<long long>(job_count));
  if (tasks < 1 || tasks > 100000) throw UsageError("--slurm-tasks expects 1 to 100000");
  const long long cpus = args.has("slurm-cpus") ? args.get_int("slurm-cpus") : (args.has("jobs") ? workers : 4);
  if (cpus < 1 || cpus > 1024) throw UsageError("--slurm-cpus expects 1 to 1024");
  script.tasks = static_cast<int>(tasks);
  script.cpus_per_task = static_cast<int>(cpus);
  script.memory_mb = args.has("slurm-mem") ? args.get_int("slurm-mem") : 3072 * cpus;
  script.time_limit_minutes = args.has("slurm-time") ? args.get_int("slurm-time") : 1440;
  if (script.memory_mb < 1 || script.time_limit_minutes < 1) throw UsageError("--slurm-mem and --slurm-time expect positive numbers");
  script.partition = args.get_optional("slurm-partition").value_or("");
  script.working_folder = fs::current_path().string();
  fs::create_directories(out);
  script.log_folder = fs::absolute(out).lexically_normal().string();
  script.command = command_for_script(arguments);
  const std::string path = args.get("slurm-script");
  io::write_file_atomically(path, batch::slurm_script(script));
  fs::permissions(path, fs::perms::owner_exec | fs::perms::group_exec, fs::perm_options::add);
  std::printf("wrote %s: %zu jobs in %d shards of %d CPUs each; submit with: sbatch %s; then: odyssey batch-report %s\n",
              path.c_str(), job_count, script.tasks, script.cpus_per_task, path.c_str(), out.c_str());
}

}  // namespace

int run_batch(const std::vector<std::string>& arguments) {
  Args args("batch",
            "Retarget every motion onto every character (--motions, --characters), or run the jobs a manifest\n"
            "lists, each into DIR/jobs/<character>/<motion>/ (animation.glb, retarget.json, and what --outputs\n"
            "adds), in --jobs worker processes. A job's files appear together or not at all; DIR/journal.jsonl\n"
            "records each finished job, so running the same command again skips what is done and unchanged. A\n"
            "bad input fails its job only. At the end DIR/report.json and DIR/report.csv list every job with its\n"
            "status, frames, time and quality metrics. Exit status: 0 every job done, 1 some job failed, 3 none\n"
            "failed but some exceeded a --max-* gate, 2 a bad command line.");
  args.list_option("motions", "PATH", "motion files (BVH, AMASS npz), folders searched recursively, or globs")
      .list_option("characters", "PATH", "character files (.glb, .gltf, .vrm), folders or globs; a bone map "
                                         "<character>.map.json beside a character is used for it")
      .option("manifest", "FILE", "a JSON or CSV list of jobs instead of --motions and --characters (docs/batches.md)")
      .option("out", "DIR", "the batch's folder (required)")
      .option("jobs", "N", "worker processes (default: the number of cores)")
      .option("timeout", "SECONDS", "fail a job that runs longer than this (default: no limit)")
      .option("max-memory", "GIB", "address space of each worker (default: 90% of the memory, shared among the workers)")
      .option("outputs", "LIST", std::string("files each job writes: ") + batch::kJobOutputNames, "glb,report")
      .option("shard", "I/N", "run only shard I of N of the jobs (1 <= I <= N), or 'slurm' to take it from a Slurm job array")
      .option("slurm-script", "FILE", "write an sbatch script that runs this batch as a job array, and stop")
      .option("slurm-tasks", "N", "the script's array size: shards (default: 4, at most the job count)")
      .option("slurm-cpus", "N", "the script's CPUs per task, one worker each (default: --jobs, or 4)")
      .option("slurm-mem", "MB", "the script's memory per task (default: 3072 per CPU)")
      .option("slurm-time", "MINUTES", "the script's time limit per task (default: 1440)")
      .option("slurm-partition", "NAME", "the script's partition (default: the cluster's)")
      .flag("quiet", "print only the closing summary");
  add_retarget_settings(args);
  add_gate_options(args);
  if (!args.parse(arguments)) return 0;

  if (args.has("threads")) throw UsageError("--threads: a batch runs one thread per job and --jobs jobs at once; use --jobs");
  const batch::JobDefaults defaults = job_defaults_from(args);
  const batch::BatchOptions options = batch_options_from(args, defaults);
  std::vector<batch::Job> jobs = jobs_from(args, defaults);
  if (args.has("slurm-script")) {
    write_slurm_script(args, arguments, jobs.size(), options.workers);
    return 0;
  }

  ProgressPrinter printer(args.get_flag("quiet"));
  const batch::BatchSummary summary = batch::run_batch(std::move(jobs), options, std::ref(printer));
  printer.end();
  const batch::BatchProgress& counts = summary.counts;
  std::printf("batch   %ld jobs%s: %ld done (%ld earlier), %ld failed, %ld flagged; %ld frames in %.1f s (%.0f frames/s)\n",
              counts.total, options.shard.whole() ? "" : (" in shard " + options.shard.text()).c_str(), counts.done,
              counts.resumed, counts.failed, counts.flagged, counts.frames, counts.seconds,
              counts.seconds > 0 ? static_cast<double>(counts.frames) / counts.seconds : 0.0);
  for (const std::string& report : summary.reports) std::printf("report  %s\n", report.c_str());
  return counts.failed > 0 ? kExitFailed : counts.flagged > 0 ? kExitFlagged : 0;
}

int run_batch_report(const std::vector<std::string>& arguments) {
  Args args("batch-report",
            "Render one report (report.json and report.csv) from the journals of a batch's output folders: the\n"
            "shards of a Slurm array writing into one folder, or shards run into several. Exit status as\n"
            "odyssey batch's: 0 every job done, 1 some failed, 3 some flagged by the gates.");
  args.rest("DIR", "output folders of the batch's shards")
      .option("out", "DIR", "where to write the report (default: the first DIR)");
  add_gate_options(args);
  if (!args.parse(arguments)) return 0;
  const std::vector<std::string> folders = args.get_list("DIR");
  const std::string out = args.get_optional("out").value_or(folders.front());
  const batch::Gates gates = gates_from(args);
  const batch::JournalContents merged = batch::merge_journals(folders);
  fs::create_directories(out);
  for (const std::string& report : batch::write_batch_report(out, merged, gates)) std::printf("report  %s\n", report.c_str());
  const batch::ReportCounts counts = batch::report_counts(merged, gates);
  std::printf("batch   %ld jobs: %ld done, %ld failed, %ld flagged, %ld not run\n", counts.jobs, counts.done, counts.failed,
              counts.flagged, counts.not_run);
  return counts.failed > 0 ? kExitFailed : counts.flagged > 0 ? kExitFlagged : 0;
}

}  // namespace odyssey::cli
