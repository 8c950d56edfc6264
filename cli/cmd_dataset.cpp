// odyssey dataset: sequences drawn from a recipe, run as a resumable, sharded batch into the
// layout the point trackers' loaders read; odyssey dataset-report: the manifest of its shards.
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "batch/journal.h"
#include "batch/report.h"
#include "cli/args.h"
#include "cli/batch_runs.h"
#include "cli/commands.h"
#include "dataset/dataset.h"
#include "dataset/recipe.h"
#include "mocap_io/json_reader.h"

namespace odyssey::cli {
namespace fs = std::filesystem;

int run_dataset(const std::vector<std::string>& arguments) {
  Args args("dataset",
            "Make a dataset from RECIPE.json (docs/datasets.md): --count sequences, each drawn from the recipe's seed\n"
            "and its index alone, written as DIR/scenes/<seq>.json and run as a batch job into\n"
            "DIR/<split>/<seq>_<camera>/ (anno.npz, depths/, normals/, masks/: the PointOdyssey layout). A draw that\n"
            "fails its checks is drawn again; a broken asset fails the sequences that drew it. Running the same\n"
            "command again skips what is done and unchanged; more --count adds sequences without changing the\n"
            "others. At the end DIR/dataset.json lists every sequence (scene, split, assets and licences, frames,\n"
            "cameras, visibility, redraws) and the totals per split. Exit status: 0 every sequence made, 1 some\n"
            "failed, 2 a bad command line.");
  args.optional_positional("RECIPE", "the recipe (JSON); leave out with --example")
      .flag("example", "use the bundled example recipe (print it with --print-example)")
      .flag("print-example", "print the bundled example recipe and stop")
      .option("count", "N", "sequences to make (default: the recipe's count)");
  add_run_options(args, "sequences");
  if (!args.parse(arguments)) return 0;
  if (args.get_flag("print-example")) {
    std::fputs(io::read_text_file(dataset::example_recipe_path()).c_str(), stdout);
    return 0;
  }
  const bool example = args.get_flag("example");
  if (example == args.has("RECIPE")) throw UsageError("give a RECIPE, or --example for the bundled one");
  batch::BatchOptions batch_options = run_options_from(args);
  dataset::DatasetOptions options;
  if (args.has("count")) {
    options.count = args.get_int("count");
    if (options.count < 1 || options.count > 1'000'000) throw UsageError("--count expects 1 to 1000000");
  }
  // The recipe is read (and its libraries found) before anything is written.
  const dataset::Recipe recipe =
      dataset::read_recipe(example ? dataset::example_recipe_path() : args.get("RECIPE"));
  const long count = options.count > 0 ? options.count : recipe.count;
  if (args.has("slurm-script")) {
    write_slurm_script(args, arguments, "dataset", "odyssey dataset-report", static_cast<std::size_t>(count), batch_options.workers);
    return 0;
  }
  options.batch = batch_options;
  ProgressPrinter printer(args.get_flag("quiet"), "sequences");
  const dataset::DatasetSummary summary = dataset::run_dataset(recipe, options, std::ref(printer));
  printer.end();
  const batch::BatchProgress& counts = summary.counts;
  std::printf("dataset %ld sequences%s: %ld done (%ld earlier), %ld failed; %ld frames in %.1f s\n", counts.total,
              options.batch.shard.whole() ? "" : (" in shard " + options.batch.shard.text()).c_str(), counts.done, counts.resumed,
              counts.failed, counts.frames, counts.seconds);
  for (const std::string& report : summary.reports) std::printf("report  %s\n", report.c_str());
  return counts.failed > 0 ? 1 : 0;
}

int run_dataset_report(const std::vector<std::string>& arguments) {
  Args args("dataset-report",
            "Write DIR/dataset.json (and the batch's report.json and report.csv) from the journals of a dataset's\n"
            "shards, once every shard has ended. Exit status: 0 every sequence made, 1 some failed.");
  args.positional("DIR", "the dataset's folder");
  if (!args.parse(arguments)) return 0;
  const std::string folder = args.get("DIR");
  const batch::JournalContents contents = batch::read_journals(folder);
  const std::string manifest = dataset::write_dataset_report(folder, contents);
  std::printf("report  %s\n", manifest.c_str());
  for (const std::string& report : batch::write_batch_report(folder, contents, {})) std::printf("report  %s\n", report.c_str());
  const batch::ReportCounts counts = batch::report_counts(contents, {});
  std::printf("dataset %ld sequences: %ld done, %ld failed, %ld not run\n", counts.jobs, counts.done, counts.failed, counts.not_run);
  return counts.failed > 0 ? 1 : 0;
}

}  // namespace odyssey::cli
