// Runs a batch: jobs (job.h) into DIR/jobs/<name>/, each in a worker process, resumable through
// the journal (journal.h), one shard of a job array at a time, reported in DIR/report.json and
// DIR/report.csv (report.h).
//
// Workers. `workers` processes are forked from this one; each runs jobs one after another and
// keeps the characters and body models it loaded (scene::LoadCache). A job that throws is
// failed with its one-line error; a worker that dies (a crash, an abort, the kernel's OOM killer)
// or runs past `timeout_s` on a job fails that job only, and a new worker takes its place. Each
// worker's address space is limited to `memory_limit_bytes` (default: the machine's memory shared
// among the workers), so a job that asks for more fails with "out of memory" instead of taking
// the machine.
//
// Outputs. A job writes into DIR/.staging/<shard>/<hash of its name>/, syncs its files, then
// renames that folder onto DIR/jobs/<name> (an old folder there is renamed away first and
// removed after): a job's files appear together or not at all. Then its record is appended to the
// journal. A rerun removes its shard's staging folder (what a killed run left) before starting.
// A task job (job.h, JobTask) places each of its outputs the same way at its own path under DIR.
//
// Shards. Jobs are ordered by name; shard I of N runs those at positions I-1, I-1+N, ... A job's
// outputs depend only on its inputs and settings, never on the worker, the shard or the order, so
// any split gives the same files.
#pragma once

#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "batch/job.h"

namespace odyssey::batch {

struct Shard {
  int index = 1, count = 1;  // 1-based: shard `index` of `count`
  bool whole() const { return count == 1; }
  std::string text() const { return std::to_string(index) + "/" + std::to_string(count); }
};
// "I/N" with 1 <= I <= N, or "slurm": shard ID - MIN + 1 of COUNT from SLURM_ARRAY_TASK_ID,
// SLURM_ARRAY_TASK_MIN (0 when unset) and SLURM_ARRAY_TASK_COUNT, so --array=0-3 and --array=1-4
// both work. Throws std::invalid_argument with the problem.
Shard parse_shard(const std::string& text);

// Metric limits past which a done job is flagged (unset: no gate).
struct Gates {
  std::optional<double> max_skate;           // foot skate ratio
  std::optional<double> max_bone_error_deg;  // any limb's mean direction error
  std::optional<double> max_penetration_cm, max_floating_cm;
  std::optional<double> max_jitter_ratio;    // jitter over the source's
};
nlohmann::ordered_json gates_json(const Gates& gates);
// The gates a job's metrics exceed, one line each ("skate 0.31 > 0.25").
std::vector<std::string> gate_flags(const nlohmann::json& metrics, const Gates& gates);

struct BatchOptions {
  std::string out;
  int workers = 1;
  double timeout_s = 0;                // per job; 0: none
  std::size_t memory_limit_bytes = 0;  // per worker; 0: physical memory / workers
  Shard shard;
  Gates gates;
  // What every job shares, recorded in the journal's header; a rerun into DIR must match it.
  nlohmann::ordered_json settings;
};

struct BatchProgress {
  long total = 0;     // jobs of this shard
  long done = 0, failed = 0, flagged = 0, resumed = 0;  // done includes flagged and resumed
  long frames = 0;    // frames retargeted by jobs run now
  double seconds = 0;
  const nlohmann::json* finished = nullptr;  // the record of the job that just finished, if one did
};
using BatchProgressCallback = std::function<void(const BatchProgress&)>;

struct BatchSummary {
  BatchProgress counts;
  std::vector<std::string> reports;  // report files written
};

// Throws io::InputError for a folder holding another batch's journal, std::invalid_argument for
// jobs whose names collide. Calls `progress` after each job and about twice a second.
BatchSummary run_batch(std::vector<Job> jobs, const BatchOptions& options, const BatchProgressCallback& progress = {});

// The settings of a request, as the journal records them and the job key hashes them.
nlohmann::ordered_json request_settings_json(const scene::RetargetRequest& request, const JobOutputs& outputs);

}  // namespace odyssey::batch
