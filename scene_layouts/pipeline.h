// Runs a scene (scene.h) from files to files: every command that writes something from a motion
// (retarget, trajectories, point-cache, scene, demo) calls run_scene.
//
// Steps: validate the scene; build each actor's motion from its source (actor_source.h: a motion
// retargeted, a character's own animation played, a .anime mesh read; identical requests are built
// once); put each actor's clip (and an anime's vertices) on the scene's timeline and placement; check the footprints; build the props;
// make every camera's path; sample tracked points (actor k with seed + k, the props with
// seed + 1000); run the frame loop (streams.h) into the sinks of the outputs asked for; write the
// camera paths, the GLB and the report; then commit every output together (io::StagedOutputs): on
// any error nothing is left behind.
//
// Work that no output needs is not done, and the report says what was skipped: no points are
// sampled or skinned and no visibility is decided without trajectories; an actor's mesh is
// skinned only in frames where some camera may see it or a point cache asks for it; joints left
// out by `parts` are not solved.
//
// Framing (cameras whose position or target is unset). With h the tallest actor's rest height,
// m the mean horizontal position of the actors' roots over the shot and e the largest distance of
// a root from m:
//   target    (m.x, m.y, 0.55 h)
//   distance  d = 2.5 h + e
//   static    centre = target + d f, at height 0.9 h, f the first actor's facing at scene time 0
//   orbit     radius d, height 0.9 h, starting on f
//   ego       eye offsets 0.06 h forward and 0.047 h up of its own actor's height
#pragma once

#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "scene_layouts/actor.h"
#include "scene_layouts/scene.h"
#include "scene_layouts/streams.h"

namespace odyssey::scene {

struct PlacedActor {
  std::string name;
  std::shared_ptr<const ActorMotion> motion;          // shared by actors of identical requests
  std::shared_ptr<const RetargetedActor> retargeted;  // a motion's retargeting (motion->retargeted), else null
  Clip clip;                   // on the scene's timeline and placement
  // Anime: the mesh's vertices every scene frame, in clip joint 0's frame (actor_source.h).
  std::optional<MeshAnimation> vertex_animation;
  double x = 0, y = 0, yaw_deg = 0;  // where the root starts and the direction the actor faces there
  double turn_deg = 0;               // the turn the placement gave the recorded motion
  double start_s = 0;                // the start used (drawn when the scene gave a range)
  int points = 0;
};

struct SceneResult {
  std::string name;
  double fps = 30;
  int frames = 0;
  std::uint64_t seed = 0;
  std::vector<PlacedActor> actors;
  std::vector<CameraPath> cameras;
  std::vector<std::string> camera_names;
  std::vector<std::string> prop_names;
  Character props;                    // every prop as a mesh in world coordinates (mesh k: prop k)
  StreamSummary streams;
  std::vector<std::string> skipped;   // work not done, one line each
  std::vector<std::string> notes;     // what an input held that the outputs do not carry (a lens distortion), one line each
  std::vector<std::string> outputs;   // files written
  struct {
    double retarget = 0, streams = 0, total = 0;
  } seconds;
};

// Throws io::InputError naming the file (and JSON path, where the scene came from one) or
// std::invalid_argument naming the actor, camera or frame.
// `cache`, when given, keeps loaded characters and body models for later scenes (a batch worker's).
SceneResult run_scene(const Scene& scene, const ProgressCallback& progress = {}, LoadCache* cache = nullptr);

// The scene's report: per actor its retargeting report and placement, per camera its visibility
// figures, what was skipped, the outputs and the timings.
nlohmann::ordered_json scene_report_json(const SceneResult& result);

}  // namespace odyssey::scene
