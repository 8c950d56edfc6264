// Making a dataset from a recipe (recipe.h): N sequences drawn (draw.h), each run as a batch job
// (batch/batch.h: worker processes, the journal, resume after a kill, timeouts, memory limits,
// shards, Slurm arrays) into the layout the point trackers' loaders read:
//
//   DIR/<split>/<seq>_<camera>/   a sequence per camera (scene_layouts/pointodyssey.h)
//   DIR/scenes/<seq>.json         the drawn shot as a scene file: `odyssey scene` re-makes it
//   DIR/reports/<seq>.json        the scene's report (placements, per camera its visibility shares)
//   DIR/previews/<seq>_<camera>.png  contact sheets, when the recipe asks
//   DIR/dataset.json              the manifest and report (write_dataset_report)
//   DIR/journal*.jsonl, DIR/report.{json,csv}  the batch's
//
// A sequence's job draws attempt 0, runs it, and checks it: the scene's own checks (footprints
// that overlap, a camera inside an actor or a prop: errors in the drawn scene file) and the
// dataset's (every camera keeps at least min_valid of its point-frames in view; an ego camera sees
// at least ego_min_other_visible of another actor's point-frames). A draw that fails is drawn
// again from the next attempt's numbers, up to max_redraws times, then the sequence fails with
// every reason. An error naming one of the drawn assets (a broken file) fails the sequence at
// once: the batch goes on with the others and the report names the asset.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "batch/batch.h"
#include "batch/journal.h"
#include "dataset/recipe.h"

namespace odyssey::dataset {

struct DatasetOptions {
  long count = 0;  // sequences; 0: the recipe's
  batch::BatchOptions batch;  // out, workers, timeout, memory limit, shard (settings are the dataset's)
};

struct DatasetSummary {
  batch::BatchProgress counts;
  std::vector<std::string> reports;  // files written (dataset.json and the batch's report)
};

// The batch jobs of sequences 0 ... count - 1 (named sequence_name(recipe, i)), and the settings
// their journal records (a rerun into the same folder must have the same recipe).
std::vector<batch::Job> dataset_jobs(const Recipe& recipe, long count, const std::string& out);
nlohmann::ordered_json dataset_settings(const Recipe& recipe);

// Runs the sequences of the options' shard; with the whole dataset, writes dataset.json too.
DatasetSummary run_dataset(const Recipe& recipe, const DatasetOptions& options, const batch::BatchProgressCallback& progress = {});

// DIR/dataset.json from the journals (every shard's): per sequence its scene file, split, seed,
// assets and their licences, frames, cameras with their sequence folders, tracks and visibility
// shares, redraws and their reasons, time; per split the totals of the trackers' comparison
// tables: sequences (shots and camera sequences), frames, tracks, point annotations, average
// track span (frames a track is in view), share of point-frames visible. Returns the path.
std::string write_dataset_report(const std::string& folder, const batch::JournalContents& contents);

}  // namespace odyssey::dataset
