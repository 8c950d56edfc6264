// One actor of a scene driven by motion capture: a motion file (BVH, or an AMASS-style sequence
// posed on a body model) retargeted onto a character file. The steps, in order: load the motion
// and resample it to `fps`; load the character; find both bone maps (a preset or detection from
// names, a user map over it) and keep only the canonical joints of `parts`; retarget (quality
// fast); refine for balanced and accurate. Every command, scene and batch job that drives a
// character with a motion runs these steps through retarget_actor, so one request gives one
// motion wherever it is written.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "mocap_io/bvh.h"
#include "retarget/bone_map.h"
#include "retarget/parts.h"
#include "retarget/refine.h"
#include "retarget/retarget.h"
#include "skeleton/betas.h"
#include "skeleton/body_model.h"
#include "skeleton/character.h"
#include "skeleton/clip.h"

namespace odyssey::scene {

struct RetargetRequest {
  std::string motion_path, character_path;
  std::optional<std::string> map_path, source_map_path;  // JSON bone maps over the found ones
  std::optional<std::string> model_path;                 // AMASS: the body model; default: synthetic SMPL-X, seed 0
  BetasPolicy betas = BetasPolicy::fit;                   // AMASS: the sequence's betas against the model (skeleton/betas.h)
  retarget::Quality quality = retarget::Quality::fast;
  retarget::Parts parts = retarget::Parts::body;
  double fps = 30;                                        // the motion is resampled to this rate
  std::optional<double> bvh_metres_per_unit;              // BVH: empty infers it (io::guess_bvh_frame); AMASS refuses one
  retarget::RetargetOptions options;
  retarget::RefineOptions refine_options;                 // for balanced and accurate: options.quality == quality
};

// A request for `quality` with that quality's refinement defaults.
RetargetRequest retarget_request(std::string motion_path, std::string character_path,
                                 retarget::Quality quality = retarget::Quality::fast);

struct RetargetedActor {
  RetargetRequest request;
  Clip source;                // the motion, resampled to request.fps
  double source_fps = 0;      // the motion file's own rate
  std::string motion_format;  // "bvh" or "amass"
  std::string motion_description;  // "BVH, 31 joints, 344 frames at 120 fps"
  std::string body_model;     // AMASS: the model file, or the synthetic body's description
  std::optional<BetasFit> betas;  // AMASS: what request.betas did to the sequence's betas
  std::optional<io::BvhFrameGuess> bvh_frame;  // BVH: the unit and up axis used, and how they were found
  Character character;
  retarget::BoneMap full_source_map, full_target_map;  // before `parts`
  retarget::BoneMap source_map, target_map;            // used
  std::vector<int> source_left_out, target_left_out;   // rig joints `parts` took out of the maps
  retarget::RetargetResult result;                     // result.transfer.clip: the character's motion
  std::optional<retarget::RefineSummary> refined;
  struct {
    double load_motion = 0, load_character = 0, bone_maps = 0, retarget_fast = 0;
  } seconds;

  const Clip& clip() const { return result.transfer.clip; }
};

// Where a run is, for progress lines and bars. `actor` is the actor being built, filled up to the
// stage that just ended (the maps after "bone_maps", everything after "retarget"); `done` of
// `total` counts frames or jobs where a stage has them.
struct ProgressEvent {
  std::string stage;    // "load_motion", "load_character", "bone_maps", "retarget", "export", ...
  std::string message;  // one line a person can read
  const RetargetedActor* actor = nullptr;
  long done = 0, total = 0;
};
using ProgressCallback = std::function<void(const ProgressEvent&)>;

// Characters and body models loaded by earlier requests of this process, reused while their file's
// size and modification time are unchanged: a batch worker runs many jobs on a few characters and
// one body model. Not thread-safe; one per worker.
class LoadCache {
 public:
  std::shared_ptr<const Character> character(const std::string& path);
  std::shared_ptr<const BodyModel> body_model(const std::optional<std::string>& path);  // empty: synthetic SMPL-X, seed 0

  template <class T>
  struct Entry {
    std::uintmax_t size = 0;
    std::int64_t mtime_ns = 0;
    std::shared_ptr<const T> value;
  };

 private:
  std::map<std::string, Entry<Character>> characters_;
  std::map<std::string, Entry<BodyModel>> body_models_;
};

// Runs the steps above, loading through `cache` when given. Errors propagate: io::InputError
// naming the file, std::invalid_argument.
RetargetedActor retarget_actor(const RetargetRequest& request, const ProgressCallback& progress = {},
                               LoadCache* cache = nullptr);

// The refinement options that decide a result, as reports, batch journals and cache keys record
// them: every weight, the contact blend and lift, the window and span sizes, the solvers' limits
// (threads, which change the speed but not the result, are left out).
nlohmann::ordered_json refine_settings_json(const retarget::RefineOptions& options);

// The actor's report: retarget::report_json's entries, with the inputs, the settings (every
// refinement weight), the parts left out, the refinement and the stage timings.
nlohmann::ordered_json actor_report_json(const RetargetedActor& actor);

// One line of the actor's stage timings.
std::string actor_timings(const RetargetedActor& actor);

}  // namespace odyssey::scene
