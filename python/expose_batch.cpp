// Batches from Python: every motion onto every character, or a manifest's jobs, in worker
// processes, as `odyssey batch` runs them (batch/batch.h), with progress as a callback.
#include <pybind11/stl.h>

#include "batch/batch.h"
#include "python/convert.h"
#include "python/expose.h"

namespace odyssey::python {
namespace {

batch::Gates gates_argument(const py::object& gates) {
  batch::Gates result;
  if (gates.is_none()) return result;
  if (!py::isinstance<py::dict>(gates)) throw UsageError("gates expects a dict such as {'max_skate': 0.25}");
  for (const auto& [key, value] : py::reinterpret_borrow<py::dict>(gates)) {
    const std::string name = py::str(key);
    const double number = number_argument(value, "gates: " + name);
    if (!(number >= 0)) throw UsageError("gates: " + name + " expects a number >= 0");
    if (name == "max_skate") result.max_skate = number;
    else if (name == "max_bone_error_deg") result.max_bone_error_deg = number;
    else if (name == "max_penetration_cm") result.max_penetration_cm = number;
    else if (name == "max_floating_cm") result.max_floating_cm = number;
    else if (name == "max_jitter_ratio") result.max_jitter_ratio = number;
    else throw UsageError("gates: unknown gate '" + name + "' (max_skate, max_bone_error_deg, max_penetration_cm, max_floating_cm, max_jitter_ratio)");
  }
  return result;
}

std::vector<std::string> paths_argument(const py::object& paths, const char* name) {
  std::vector<std::string> out;
  if (py::isinstance<py::str>(paths) || py::hasattr(paths, "__fspath__")) return {path_argument(paths, name)};
  for (const auto& item : paths) out.push_back(path_argument(item, name));
  return out;
}

}  // namespace

batch::BatchProgressCallback BatchProgressRelay::callback() {
  if (callable_.is_none()) return {};
  return [this](const batch::BatchProgress& progress) {
    py::gil_scoped_acquire acquire;
    if (failure_) return;
    try {
      callable_(batch_counts(progress));
    } catch (py::error_already_set& error) {
      failure_.emplace(std::move(error));
    }
  };
}

void BatchProgressRelay::rethrow() {
  if (failure_) {
    py::error_already_set error = std::move(*failure_);
    failure_.reset();
    throw error;
  }
}

py::dict batch_counts(const batch::BatchProgress& p) {
  py::dict d;
  d["total"] = p.total;
  d["done"] = p.done;
  d["failed"] = p.failed;
  d["flagged"] = p.flagged;
  d["resumed"] = p.resumed;
  d["frames"] = p.frames;
  d["seconds"] = p.seconds;
  d["finished"] = p.finished ? to_python(*p.finished) : py::none();
  return d;
}

void expose_batch(py::module_& m) {
  m.def(
      "run_batch",
      [](const py::object& out, const py::object& motions, const py::object& characters, const py::object& manifest,
         const std::string& quality, double fps, const std::string& parts, const py::object& model, const std::string& betas,
         const py::object& bvh_units, const std::string& outputs, int workers, double timeout_s,
         const py::object& max_memory_gib, const std::string& shard, const py::object& gates, const py::object& progress) {
        batch::JobDefaults defaults;
        defaults.request = request_from("", "", quality, fps, parts, py::none(), py::none(), model, betas, bvh_units, "rest",
                                        py::none(), py::none(), 1);
        const auto job_outputs = batch::parse_job_outputs(outputs);
        if (!job_outputs) throw UsageError(std::string("outputs expects a list of ") + batch::kJobOutputNames + ", got '" + outputs + "'");
        defaults.outputs = *job_outputs;
        batch::BatchOptions options;
        options.out = path_argument(out, "out");
        if (workers < 1 || workers > 1024) throw UsageError("workers expects 1 to 1024, got " + std::to_string(workers));
        options.workers = workers;
        if (!(timeout_s >= 0)) throw UsageError("timeout_s expects seconds >= 0 (0: none)");
        options.timeout_s = timeout_s;
        if (!max_memory_gib.is_none()) {
          const double gib = number_argument(max_memory_gib, "max_memory_gib");
          if (!(gib > 0)) throw UsageError("max_memory_gib expects GiB above 0");
          options.memory_limit_bytes = static_cast<std::size_t>(gib * 1024 * 1024 * 1024);
        }
        try {
          options.shard = batch::parse_shard(shard);
        } catch (const std::invalid_argument& error) {
          throw UsageError(std::string("shard: ") + error.what());
        }
        options.gates = gates_argument(gates);
        options.settings = batch::request_settings_json(defaults.request, defaults.outputs);

        std::vector<batch::Job> jobs;
        if (!manifest.is_none()) {
          if (!motions.is_none() || !characters.is_none()) throw UsageError("manifest lists the jobs; leave out motions and characters");
          jobs = batch::read_manifest(path_argument(manifest, "manifest"), defaults);
        } else {
          if (motions.is_none() || characters.is_none()) throw UsageError("give motions and characters, or manifest");
          jobs = batch::cross_product_jobs(batch::find_input_files(paths_argument(motions, "motions"), batch::kMotionExtensions, "motion"),
                                           batch::find_input_files(paths_argument(characters, "characters"), batch::kCharacterExtensions, "character"),
                                           defaults);
        }
        if (jobs.empty()) throw UsageError("no jobs: the lists are empty");
        batch::check_job_names(jobs);

        if (!progress.is_none() && !PyCallable_Check(progress.ptr())) throw UsageError("progress expects a callable taking one dict, or None");
        BatchProgressRelay relay(progress);
        batch::BatchSummary summary;
        {
          py::gil_scoped_release release;
          summary = batch::run_batch(std::move(jobs), options, relay.callback());
        }
        relay.rethrow();
        py::dict result = batch_counts(summary.counts);
        result.attr("pop")("finished");
        result["reports"] = summary.reports;
        return result;
      },
      py::arg("out"), py::arg("motions") = py::none(), py::arg("characters") = py::none(), py::kw_only(),
      py::arg("manifest") = py::none(), py::arg("quality") = "fast", py::arg("fps") = 30.0, py::arg("parts") = "body",
      py::arg("model") = py::none(), py::arg("betas") = "fit", py::arg("bvh_units") = py::none(),
      py::arg("outputs") = "glb,report", py::arg("workers") = 1, py::arg("timeout_s") = 0.0,
      py::arg("max_memory_gib") = py::none(), py::arg("shard") = "1/1", py::arg("gates") = py::none(),
      py::arg("progress") = py::none(),
      "Runs a batch as `odyssey batch` does: every motion (files, folders or globs) onto every character, or the\n"
      "jobs of a manifest (JSON or CSV), each into OUT/jobs/<character>/<motion>/, in `workers` processes,\n"
      "resumable (a rerun skips finished jobs), with OUT/report.json and report.csv. outputs: a comma list of\n"
      "glb, report, trajectories, point-cache, preview. gates: {'max_skate': R, 'max_bone_error_deg': D,\n"
      "'max_penetration_cm': C, 'max_floating_cm': C, 'max_jitter_ratio': R}. progress, when given, is called\n"
      "after each job (and about twice a second) with the counts {total, done, failed, flagged, resumed, frames,\n"
      "seconds, finished: the finished job's record or None}; an exception it raises is raised once the batch has\n"
      "finished its jobs (its workers are not left behind). Returns the final counts and the report files. A\n"
      "job that fails is counted, not raised; bad arguments raise UsageError, a bad list InputError.");
}

}  // namespace odyssey::python
