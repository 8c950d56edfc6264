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
#include "cli/args.h"
#include "cli/batch_runs.h"
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
  batch::BatchOptions options = run_options_from(args);
  options.gates = gates_from(args);
  options.settings = batch::request_settings_json(defaults.request, defaults.outputs);
  return options;
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
      .option("outputs", "LIST", std::string("files each job writes: ") + batch::kJobOutputNames, "glb,report");
  add_run_options(args, "jobs");
  add_retarget_settings(args);
  add_gate_options(args);
  if (!args.parse(arguments)) return 0;

  if (args.has("threads")) throw UsageError("--threads: a batch runs one thread per job and --jobs jobs at once; use --jobs");
  const batch::JobDefaults defaults = job_defaults_from(args);
  const batch::BatchOptions options = batch_options_from(args, defaults);
  std::vector<batch::Job> jobs = jobs_from(args, defaults);
  if (args.has("slurm-script")) {
    write_slurm_script(args, arguments, "batch", "odyssey batch-report", jobs.size(), options.workers);
    return 0;
  }

  ProgressPrinter printer(args.get_flag("quiet"), "jobs");
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
