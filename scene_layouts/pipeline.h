// Runs a scene (scene.h) from files to files: every command that writes something from a motion
// (retarget, trajectories, point-cache, scene, demo) and every batch job calls run_scene, which is
// the stages in order: prepare_shot (shot.h), the sinks the outputs ask for (open_sinks, sinks.h),
// the frame loop into them (frame_loop.h), each sink finished, then every output committed
// together (io::StagedOutputs): on any error nothing is left behind.
//
// Work that no output needs is not done, and the report says what was skipped: no points are
// sampled or skinned and no visibility is decided without trajectories or contact sheets; an
// actor's mesh is skinned only in frames where some camera may see it or a point cache asks for
// it; joints left out by `parts` are not solved.
#pragma once

#include <chrono>
#include <memory>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <vector>

#include "mocap_io/output_file.h"
#include "scene_layouts/frame_loop.h"
#include "scene_layouts/scene.h"
#include "scene_layouts/shot.h"

namespace odyssey::scene {

struct SceneResult : Shot {
  StreamSummary streams;
  std::vector<std::string> outputs;  // files written, in the order the sinks list them
  struct {
    double retarget = 0, streams = 0, total = 0;
  } seconds;
};

// Whether the scene's outputs need tracked points (trajectories, sequences or contact sheets).
bool tracks_points(const SceneOutputs& outputs);

// The sinks for the files `scene.outputs` names, in the order their files are listed (contact
// sheets, trajectories, sequences, point caches, camera paths, the character GLB, the scene GLB, the scene's
// report, the actors' reports), each staged in `staged`. Throws std::invalid_argument when
// trajectories are asked for with no points, io::InputError for a point cache of a character
// without a mesh.
std::vector<std::unique_ptr<StreamSink>> open_sinks(const Scene& scene, const Shot& shot, io::StagedOutputs& staged);

// Runs the frame loop over `shot` into the sinks (when some sink takes frames) and finishes them,
// reports last; fills the result's streams, outputs, skipped lines and timings. The caller
// commits. `started` is when the run began (for the total time the reports give).
SceneResult run_sinks(Shot shot, const Scene& scene, std::span<const std::unique_ptr<StreamSink>> sinks,
                      const ProgressCallback& progress = {},
                      std::chrono::steady_clock::time_point started = std::chrono::steady_clock::now());

// prepare_shot, open_sinks, run_sinks, commit. Throws io::InputError naming the file (and JSON
// path, where the scene came from one) or std::invalid_argument naming the actor, camera or frame.
// `cache`, when given, keeps loaded characters and body models for later scenes (a batch worker's).
SceneResult run_scene(const Scene& scene, const ProgressCallback& progress = {}, LoadCache* cache = nullptr);

// The scene's report: per actor its retargeting report and placement, per camera its visibility
// figures, what was skipped, the outputs and the timings.
nlohmann::ordered_json scene_report_json(const SceneResult& result);

}  // namespace odyssey::scene
