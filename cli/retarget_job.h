// The retargeting steps every command that drives a character with a motion shares (retarget,
// trajectories, point-cache): the same options, parsed the same way, and the same steps in the same
// order, so one command line gives the same motion whatever is written from it.
//
// Steps: load the motion as a Clip (BVH, or an AMASS-style sequence posed on a body model) and
// resample it to --fps; load the character; find both bone maps (preset or detection from names, a
// user map over it) and require humanoids; keep only the canonical joints of --parts on both maps;
// retarget (quality fast), then refine for balanced and accurate. Progress and the map used go to
// stdout before each step that can fail, so that in a batch log an error line follows its step.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "cli/args.h"
#include "retarget/bone_map.h"
#include "retarget/parts.h"
#include "retarget/refine.h"
#include "retarget/retarget.h"
#include "skeleton/character.h"
#include "skeleton/clip.h"

namespace odyssey::cli {

// Declares --motion, --character, --quality, --parts, --threads, --fps, --map, --source-map,
// --model, --source-rest, --weights and --bvh-units.
void add_retarget_options(Args& args);

struct RetargetSettings {
  std::string motion_path, character_path;
  std::optional<std::string> map_path, source_map_path, model_path;
  retarget::Quality quality = retarget::Quality::fast;
  retarget::Parts parts = retarget::Parts::body;
  double fps = 30;
  double bvh_metres_per_unit = 1;
  bool bvh_units_given = false;
  retarget::RetargetOptions options;
  retarget::RefineOptions refine_options;
};

// Throws UsageError for a malformed value.
RetargetSettings retarget_settings(const Args& args);

struct RetargetJob {
  RetargetSettings settings;
  Clip source;                // the motion, resampled to settings.fps
  double source_fps = 0;      // the motion file's own rate
  std::string motion_format;  // "bvh" or "amass"
  std::string body_model;     // AMASS: the model file, or the synthetic body's description
  Character character;
  retarget::BoneMap full_source_map, full_target_map;  // before --parts
  retarget::BoneMap source_map, target_map;            // used
  std::vector<int> source_left_out, target_left_out;   // rig joints --parts took out of the maps
  retarget::RetargetResult result;                     // result.transfer.clip: the character's motion
  std::optional<retarget::RefineSummary> refined;
  struct {
    double load_motion = 0, load_character = 0, bone_maps = 0, retarget_fast = 0;
  } seconds;

  const Clip& clip() const { return result.transfer.clip; }
};

// Runs the steps above, printing progress, the map used, scale, alignment, contacts and metrics.
// Errors propagate (InputError naming the file, std::invalid_argument).
RetargetJob run_retarget_job(const RetargetSettings& settings);

// Report entries for the inputs, the settings (with every refinement weight), the map and the
// refinement, over report_json()'s own; commands add their outputs and timings.
nlohmann::ordered_json retarget_job_report(const RetargetJob& job);

// One line of the job's stage timings, for the command's closing summary.
std::string retarget_job_timings(const RetargetJob& job);

}  // namespace odyssey::cli
