#include "scene_layouts/shot.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <set>
#include <stdexcept>

#include "mocap_io/gltf_character.h"
#include "mocap_io/input_error.h"
#include "mocap_io/obj_mesh.h"
#include "scene_layouts/placement.h"
#include "scene_layouts/prop_physics.h"
#include "scene_layouts/shot_cameras.h"

namespace odyssey::scene {
namespace {

using Clock = std::chrono::steady_clock;

void require(bool condition, const std::string& message) {
  if (!condition) throw std::invalid_argument(message);
}

void validate_scene(const Scene& scene) {
  require(scene.fps > 0 && std::isfinite(scene.fps), "scene: fps must be positive");
  require(!scene.seconds || (*scene.seconds >= 0 && std::isfinite(*scene.seconds)), "scene: seconds must be 0 or more");
  require(!scene.actors.empty(), "scene: no actors");
  std::set<std::string> names;
  for (const SceneActor& actor : scene.actors) {
    const std::string who = "actor '" + actor.name + "': ";
    require(!actor.name.empty(), "scene: an actor has no name");
    require(names.insert("actor " + actor.name).second, "scene: two actors are called '" + actor.name + "'");
    require(actor.speed > 0 && std::isfinite(actor.speed), who + "speed must be positive");
    require(std::isfinite(actor.start_s), who + "start must be finite");
    require(!actor.start_range || (std::isfinite(actor.start_range->first) && std::isfinite(actor.start_range->second) &&
                                   actor.start_range->first <= actor.start_range->second),
            who + "a start range must be finite with min <= max");
    require(actor.trim_start_s >= 0 && std::isfinite(actor.trim_start_s), who + "trim start must be 0 or more");
    require(!actor.trim_end_s || (*actor.trim_end_s > actor.trim_start_s && std::isfinite(*actor.trim_end_s)),
            who + "trim end must come after trim start");
    require(!actor.points || *actor.points >= 0, who + "points must be 0 or more");
    const Placement& p = actor.placement;
    require(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.yaw_deg), who + "placement must be finite");
    require(p.kind != Placement::Kind::random || (p.region.min().allFinite() && p.region.max().allFinite() &&
                                                  (p.region.max().array() >= p.region.min().array()).all()),
            who + "the placement region must be finite with min <= max");
  }
  for (const Prop& prop : scene.props) {
    require(!prop.name.empty(), "scene: a prop has no name");
    require(names.insert("prop " + prop.name).second, "scene: two props are called '" + prop.name + "'");
    require(prop.position.allFinite() && std::isfinite(prop.yaw_deg) && prop.scale > 0 && std::isfinite(prop.scale),
            "prop '" + prop.name + "': position, yaw and scale must be finite, scale positive");
  }
  for (const SceneCamera& camera : scene.cameras) {
    require(!camera.name.empty(), "scene: a camera has no name");
    require(names.insert("camera " + camera.name).second, "scene: two cameras are called '" + camera.name + "'");
    if (const EgoRig* ego = std::get_if<EgoRig>(&camera.rig)) {
      require(ego->actor >= 0 && ego->actor < static_cast<int>(scene.actors.size()),
              "camera '" + camera.name + "': rides on actor " + std::to_string(ego->actor) + ", the scene has " +
                  std::to_string(scene.actors.size()));
    }
    double jitter_m = 0;
    if (const StaticRig* rig = std::get_if<StaticRig>(&camera.rig)) jitter_m = rig->jitter_m;
    if (const OrbitRig* rig = std::get_if<OrbitRig>(&camera.rig)) jitter_m = rig->jitter_m;
    require(jitter_m >= 0 && std::isfinite(jitter_m), "camera '" + camera.name + "': jitter must be 0 or more");
  }
  const SceneOutputs& out = scene.outputs;
  const auto per = [](const std::vector<std::string>& paths, std::size_t count, const char* what, const char* of) {
    require(paths.empty() || paths.size() == count, std::string("scene outputs: ") + what + " needs one path per " + of);
  };
  per(out.trajectories, scene.cameras.size(), "trajectories", "camera");
  per(out.sequences, scene.cameras.size(), "sequences", "camera");
  per(out.previews, scene.cameras.size(), "previews", "camera");
  per(out.camera_paths, scene.cameras.size(), "camera_paths", "camera");
  per(out.point_caches, scene.actors.size(), "point_caches", "actor");
  per(out.actor_reports, scene.actors.size(), "actor_reports", "actor");
  require(out.glb.empty() || (scene.actors.size() == 1 && scene.props.empty()),
          "scene outputs: a GLB is written for a scene of one actor and no props");
  require(out.glb.empty() || std::holds_alternative<RetargetRequest>(scene.actors[0].source),
          "scene outputs: the one-actor GLB animates a retargeted character; write the scene GLB for other actors");
  require(out.points_per_actor >= 0 && out.prop_points >= 0, "scene outputs: point counts must be 0 or more");
  require(out.prop_points == 0 || !scene.props.empty() || scene.scatter, "scene outputs: prop points asked for, but the scene has no props");
}

// Everything that changes what a source builds: identical keys are built once.
std::string source_key(const RetargetRequest& r) {
  nlohmann::ordered_json key = {r.motion_path,
                                r.character_path,
                                r.map_path.value_or(""),
                                r.source_map_path.value_or(""),
                                r.model_path.value_or(""),
                                retarget::quality_name(r.quality),
                                retarget::parts_name(r.parts),
                                r.fps,
                                r.bvh_metres_per_unit.value_or(-1),
                                static_cast<int>(r.options.source_rest),
                                betas_policy_name(r.betas)};
  key.push_back(refine_settings_json(r.refine_options));
  key.push_back(r.refine_options.threads);
  return "motion " + key.dump();
}

nlohmann::json length_key(const PlaybackLength& l) { return nlohmann::json{l.loops.value_or(0), l.seconds.value_or(-1)}; }

std::string source_key(const AnimationRequest& r) {
  return "animation " + nlohmann::json{r.character_path, r.animation, r.fps, length_key(r.length), r.scale}.dump();
}

std::string source_key(const AnimeRequest& r) {
  return "anime " + nlohmann::json{r.path, r.source_fps, r.fps, r.up_z, length_key(r.length), r.scale}.dump();
}

// A played source's progress: what was loaded (`event`), then its warnings.
void report_played(const ActorMotion& motion, const char* event, const ProgressCallback& progress) {
  if (!progress) return;
  progress(ProgressEvent{event, motion.source_path + ": " + motion.description, nullptr, 0, 0});
  for (const std::string& warning : motion.warnings) progress(ProgressEvent{"warning", motion.source_path + ": " + warning, nullptr, 0, 0});
}

ActorMotion build_motion(const RetargetRequest& request, const ProgressCallback& progress, LoadCache* cache) {
  return retargeted_motion(std::make_shared<const RetargetedActor>(retarget_actor(request, progress, cache)));
}

ActorMotion build_motion(const AnimationRequest& request, const ProgressCallback& progress, LoadCache* cache) {
  ActorMotion motion = play_character_animation(request, cache);
  report_played(motion, "load_character", progress);
  return motion;
}

ActorMotion build_motion(const AnimeRequest& request, const ProgressCallback& progress, LoadCache*) {
  ActorMotion motion = play_anime(request);
  report_played(motion, "load_anime", progress);
  return motion;
}

std::vector<skinning::SurfacePoint> sample_actor_points(const SceneActor& spec, const ActorMotion& actor, int count,
                                                        std::uint64_t seed, bool body_only) {
  if (count == 0) return {};
  skinning::SamplingOptions options;
  options.mode = spec.sampling;
  options.count = count;
  options.seed = seed;
  if (body_only) {
    options.region =
        skinning::JointSet::all(actor.character.skeleton) - skinning::JointSet::below(actor.character.skeleton, actor.wrists);
  }
  try {
    return skinning::sample_surface_points(actor.character, options);
  } catch (const std::invalid_argument& error) {
    throw io::InputError(actor.source_path, std::string("cannot sample points: ") + error.what());
  }
}

// Builds each distinct source once (retarget a motion, play an animation, read an anime) and
// gives every actor of the scene its own placed copy to fill.
void build_actors(const Scene& scene, const ProgressCallback& progress, LoadCache* cache, Shot& result) {
  std::map<std::string, std::shared_ptr<const ActorMotion>> built;
  for (const SceneActor& actor : scene.actors) {
    std::shared_ptr<const ActorMotion>& slot = built[std::visit([](const auto& request) { return source_key(request); }, actor.source)];
    if (!slot) {
      slot = std::make_shared<const ActorMotion>(
          std::visit([&](const auto& request) { return build_motion(request, progress, cache); }, actor.source));
    }
    PlacedActor placed;
    placed.name = actor.name;
    placed.motion = slot;
    placed.retargeted = slot->retargeted;
    result.actors.push_back(std::move(placed));
  }
  for (const SceneActor& actor : scene.actors) {
    const RetargetRequest* request = std::get_if<RetargetRequest>(&actor.source);
    if (request && request->parts == retarget::Parts::body) {
      result.skipped.push_back("actor '" + actor.name + "': fingers and face not solved (parts body: they keep their rest pose)");
    }
  }
}

// Points are numbered actor after actor (seed + k for actor k), then the props' (seed + 1000).
void sample_points(const Scene& scene, Shot& shot) {
  const SceneOutputs& outputs = scene.outputs;
  for (std::size_t a = 0; a < scene.actors.size(); ++a) {
    const int count = scene.actors[a].points.value_or(outputs.points_per_actor);
    shot.actors[a].tracked_points =
        sample_actor_points(scene.actors[a], *shot.actors[a].motion, count, scene.seed + a, outputs.body_points_only);
    shot.actors[a].points = count;
  }
  if (outputs.prop_points > 0) {
    skinning::SamplingOptions options;
    options.count = outputs.prop_points;
    options.seed = scene.seed + 1000;
    shot.props.points = skinning::sample_surface_points(shot.props.character, options);
  }
}

}  // namespace

Shot prepare_shot(const Scene& scene, const PrepareOptions& options, const ProgressCallback& progress, LoadCache* cache) {
  validate_scene(scene);
  Shot shot;
  shot.name = scene.name;
  shot.fps = scene.fps;
  shot.seed = scene.seed;
  const auto start = Clock::now();
  build_actors(scene, progress, cache, shot);
  shot.retarget_seconds = std::chrono::duration<double>(Clock::now() - start).count();
  shot.frames = time_actors(scene, shot.actors);
  place_actors(scene, shot.frames, shot.actors);
  std::vector<Prop> props;
  std::vector<PropGeometry> geometry;
  gather_props(scene, shot.actors, props, geometry, shot.skipped);
  std::set<std::string> names;
  for (const Prop& prop : props) {
    if (!names.insert(prop.name).second) throw std::invalid_argument("scene: two props are called '" + prop.name + "' (a scattered prop is <template>_<k>)");
  }
  shot.props = build_props(props, geometry);
  simulate_props(scene, props, geometry, shot);
  shot.prop_specs = std::move(props);
  const Framing framing = frame_actors(shot.actors);
  for (std::size_t c = 0; c < scene.cameras.size(); ++c) {
    const SceneCamera& camera = scene.cameras[c];
    shot.cameras.push_back({camera.name, make_camera(camera, scene, shot.actors, framing, shot.frames, c, shot.notes),
                            rides_on(camera)});
  }
  if (options.sample_points) sample_points(scene, shot);
  return shot;
}

std::vector<StreamActor> stream_actors(const Shot& shot, const std::vector<bool>& mesh_every_frame) {
  std::vector<StreamActor> actors(shot.actors.size());
  for (std::size_t a = 0; a < shot.actors.size(); ++a) {
    const PlacedActor& placed = shot.actors[a];
    StreamActor& actor = actors[a];
    actor.name = placed.name;
    actor.character = &placed.motion->character;
    actor.clip = &placed.clip;
    actor.points = placed.tracked_points;
    actor.mesh_every_frame = a < mesh_every_frame.size() && mesh_every_frame[a];
    actor.head_joint = placed.motion->head_joint;
  }
  return actors;
}

std::vector<StreamCamera> stream_cameras(const Shot& shot, const std::vector<bool>& tracks) {
  std::vector<StreamCamera> cameras(shot.cameras.size());
  for (std::size_t c = 0; c < shot.cameras.size(); ++c) {
    cameras[c].name = shot.cameras[c].name;
    cameras[c].path = &shot.cameras[c].path;
    cameras[c].own_actor = shot.cameras[c].rides_on;
    cameras[c].tracks = tracks.empty() || tracks[c];
  }
  return cameras;
}

const StreamProps* stream_props(const Shot& shot) { return shot.props.names.empty() ? nullptr : &shot.props; }

}  // namespace odyssey::scene
