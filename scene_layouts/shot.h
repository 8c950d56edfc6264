// A shot prepared to run: prepare_shot(scene) does everything a scene needs before its first frame
// and returns it as plain data, so that run_scene (pipeline.h), a test or a caller's own frame loop
// (frame_loop.h) start from the same shot.
//
// Steps: validate the scene; build each actor's motion from its source (actor_source.h: a motion
// retargeted, a character's own animation played, a .anime mesh read; identical requests are built
// once); put each actor's clip (and an anime's vertices) on the scene's timeline and placement and
// check the footprints (placement.h); build the props, scatter more and simulate the dynamic ones
// (prop_physics.h); make every camera's path
// (shot_cameras.h); sample tracked points (actor k with seed + k, the props with seed + 1000) when
// asked.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "physics/rigid_scene.h"
#include "scene_layouts/actor.h"
#include "scene_layouts/actor_source.h"
#include "scene_layouts/frame_loop.h"
#include "scene_layouts/scene.h"
#include "scene_layouts/timed_clip.h"

namespace odyssey::scene {

struct PlacedActor {
  std::string name;
  std::shared_ptr<const ActorMotion> motion;          // shared by actors of identical requests
  std::shared_ptr<const RetargetedActor> retargeted;  // a motion's retargeting (motion->retargeted), else null
  TimedClip clip;  // motion->clip on the scene's timeline and placement (an anime's vertices too)
  double x = 0, y = 0, yaw_deg = 0;  // where the root starts and the direction the actor faces there
  double turn_deg = 0;               // the turn the placement gave the recorded motion
  double start_s = 0;                // the start used (drawn when the scene gave a range)
  int points = 0;                    // tracked points asked for
  std::vector<skinning::SurfacePoint> tracked_points;  // sampled on motion->character
};

struct ShotCamera {
  std::string name;
  CameraPath path;
  int rides_on = -1;  // ego: the actor whose head carries it
};

struct Shot {
  std::string name;
  double fps = 30;
  int frames = 0;
  std::uint64_t seed = 0;
  std::vector<PlacedActor> actors;
  StreamProps props;                 // every prop as a mesh in world coordinates (mesh k: prop k), with its points and motion
  // Per prop (the scene's, then the scattered): its description (a scattered prop's drawn place
  // and name) and what a dynamic prop did (empty for a static one).
  std::vector<Prop> prop_specs;
  std::vector<std::optional<physics::PropReport>> prop_reports;
  std::vector<ShotCamera> cameras;
  std::vector<std::string> skipped;  // work not done, one line each
  std::vector<std::string> notes;    // what an input held that the outputs do not carry (a lens distortion), one line each
  double retarget_seconds = 0;       // building the actors' motions
  double physics_seconds = 0;        // scattering and simulating the props
};

struct PrepareOptions {
  bool sample_points = true;  // sample the tracked points (scene.outputs' counts and sampling)
};

// Throws io::InputError naming the file (and JSON path, where the scene came from one) or
// std::invalid_argument naming the actor, camera or frame. `cache`, when given, keeps loaded
// characters and body models for later scenes (a batch worker's).
Shot prepare_shot(const Scene& scene, const PrepareOptions& options = {}, const ProgressCallback& progress = {},
                  LoadCache* cache = nullptr);

// The frame loop's view of a shot (pointers into it: the shot must outlive them). Actors whose
// whole mesh some sink needs every frame are named by `mesh_every_frame` (one flag per actor, or
// empty); cameras classify points when `tracks` says so (one flag per camera, or empty: all).
std::vector<StreamActor> stream_actors(const Shot& shot, const std::vector<bool>& mesh_every_frame = {});
std::vector<StreamCamera> stream_cameras(const Shot& shot, const std::vector<bool>& tracks = {});
// The props, or null when the shot has none.
const StreamProps* stream_props(const Shot& shot);

}  // namespace odyssey::scene
