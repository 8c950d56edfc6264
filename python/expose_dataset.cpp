// Datasets from Python: a recipe (a file or a dict in its layout) run as `odyssey dataset` runs it
// (dataset/dataset.h), with progress as a callback. Built when the dataset library is.
#include <pybind11/stl.h>

#include <filesystem>

#include "batch/batch.h"
#include "dataset/dataset.h"
#include "dataset/recipe.h"
#include "python/convert.h"
#include "python/expose.h"

namespace odyssey::python {

void expose_dataset(py::module_& m) {
  m.def(
      "run_dataset",
      [](const py::object& recipe, const py::object& out, const py::object& count, int workers, double timeout_s,
         const py::object& max_memory_gib, const std::string& shard, const py::object& base_dir, const py::object& progress) {
        dataset::Recipe parsed;
        if (py::isinstance<py::dict>(recipe)) {
          const std::string label = base_dir.is_none() ? "recipe" : (std::filesystem::path(path_argument(base_dir, "base_dir")) / "recipe").string();
          parsed = dataset::parse_recipe(from_python(recipe, "recipe").dump(), label);
        } else {
          if (!base_dir.is_none()) throw UsageError("base_dir is for a recipe given as a dict; a file's paths are relative to it");
          parsed = dataset::read_recipe(path_argument(recipe, "recipe"));
        }
        dataset::DatasetOptions options;
        if (!count.is_none()) {
          const long long n = integer_argument(count, "count");
          if (n < 1) throw UsageError("count expects a number of sequences >= 1, got " + std::to_string(n));
          options.count = n;
        }
        options.batch.out = path_argument(out, "out");
        if (workers < 1 || workers > 1024) throw UsageError("workers expects 1 to 1024, got " + std::to_string(workers));
        options.batch.workers = workers;
        if (!(timeout_s >= 0)) throw UsageError("timeout_s expects seconds >= 0 (0: none)");
        options.batch.timeout_s = timeout_s;
        if (!max_memory_gib.is_none()) {
          const double gib = number_argument(max_memory_gib, "max_memory_gib");
          if (!(gib > 0)) throw UsageError("max_memory_gib expects GiB above 0");
          options.batch.memory_limit_bytes = static_cast<std::size_t>(gib * 1024 * 1024 * 1024);
        }
        try {
          options.batch.shard = batch::parse_shard(shard);
        } catch (const std::invalid_argument& error) {
          throw UsageError(std::string("shard: ") + error.what());
        }
        if (!progress.is_none() && !PyCallable_Check(progress.ptr())) throw UsageError("progress expects a callable taking one dict, or None");
        BatchProgressRelay relay(progress);
        dataset::DatasetSummary summary;
        {
          py::gil_scoped_release release;
          summary = dataset::run_dataset(parsed, options, relay.callback());
        }
        relay.rethrow();
        py::dict result = batch_counts(summary.counts);
        result.attr("pop")("finished");
        result["reports"] = summary.reports;
        return result;
      },
      py::arg("recipe"), py::arg("out"), py::kw_only(), py::arg("count") = py::none(), py::arg("workers") = 1,
      py::arg("timeout_s") = 0.0, py::arg("max_memory_gib") = py::none(), py::arg("shard") = "1/1",
      py::arg("base_dir") = py::none(), py::arg("progress") = py::none(),
      "Makes a dataset from a recipe (a file, or a dict in its layout) into `out` as `odyssey dataset` does:\n"
      "`count` sequences (default: the recipe's) drawn and run as batch jobs in `workers` processes, resumable,\n"
      "into <split>/<seq>_<camera>/ sequence folders with dataset.json. progress is called as run_batch's.\n"
      "Returns the counts and the report files.");
}

}  // namespace odyssey::python
