#include "scene_layouts/pipeline.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <numbers>
#include <set>
#include <stdexcept>

#include "mocap_io/camera_import.h"
#include "mocap_io/camera_path_file.h"
#include "mocap_io/gltf_character.h"
#include "mocap_io/gltf_export.h"
#include "mocap_io/input_error.h"
#include "mocap_io/obj_mesh.h"
#include "mocap_io/output_file.h"
#include "mocap_io/scene_glb.h"
#include "retarget/canonical.h"
#include "scene_layouts/camera_rigs.h"
#include "scene_layouts/imported_camera.h"
#include "scene_layouts/preview.h"
#include "scene_layouts/seeded_uniform.h"

namespace odyssey::scene {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

Eigen::Matrix3d yaw_rotation(double degrees) {
  return Eigen::AngleAxisd(degrees * std::numbers::pi / 180, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

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
    require(camera.kind != SceneCamera::Kind::ego || (camera.actor >= 0 && camera.actor < static_cast<int>(scene.actors.size())),
            "camera '" + camera.name + "': rides on actor " + std::to_string(camera.actor) + ", the scene has " +
                std::to_string(scene.actors.size()));
    require(camera.jitter_m >= 0 && std::isfinite(camera.jitter_m), "camera '" + camera.name + "': jitter must be 0 or more");
  }
  const SceneOutputs& out = scene.outputs;
  const auto per = [](const std::vector<std::string>& paths, std::size_t count, const char* what, const char* of) {
    require(paths.empty() || paths.size() == count, std::string("scene outputs: ") + what + " needs one path per " + of);
  };
  per(out.trajectories, scene.cameras.size(), "trajectories", "camera");
  per(out.previews, scene.cameras.size(), "previews", "camera");
  per(out.camera_paths, scene.cameras.size(), "camera_paths", "camera");
  per(out.point_caches, scene.actors.size(), "point_caches", "actor");
  per(out.actor_reports, scene.actors.size(), "actor_reports", "actor");
  require(out.glb.empty() || (scene.actors.size() == 1 && scene.props.empty()),
          "scene outputs: a GLB is written for a scene of one actor and no props");
  require(out.glb.empty() || scene.actors[0].source == ActorSourceKind::motion,
          "scene outputs: the one-actor GLB animates a retargeted character; write the scene GLB for other actors");
  require(out.points_per_actor >= 0 && out.prop_points >= 0, "scene outputs: point counts must be 0 or more");
  require(out.prop_points == 0 || !scene.props.empty(), "scene outputs: prop points asked for, but the scene has no props");
}

bool any_path(const std::vector<std::string>& paths) {
  return std::any_of(paths.begin(), paths.end(), [](const std::string& p) { return !p.empty(); });
}

// Everything that changes what retarget_actor returns.
std::string request_key(const RetargetRequest& r) {
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
  return key.dump();
}

// Everything that changes what an actor's source builds.
std::string source_key(const SceneActor& actor) {
  const auto length = [](const PlaybackLength& l) { return nlohmann::json{l.loops.value_or(0), l.seconds.value_or(-1)}; };
  switch (actor.source) {
    case ActorSourceKind::motion:
      return "motion " + request_key(actor.retarget);
    case ActorSourceKind::animation: {
      const AnimationRequest& r = actor.animation;
      return "animation " + nlohmann::json{r.character_path, r.animation, r.fps, length(r.length), r.scale}.dump();
    }
    case ActorSourceKind::anime: {
      const AnimeRequest& r = actor.anime;
      return "anime " + nlohmann::json{r.path, r.source_fps, r.fps, r.up_z, length(r.length), r.scale}.dump();
    }
  }
  return {};
}

ActorMotion build_motion(const SceneActor& actor, const ProgressCallback& progress, LoadCache* cache) {
  if (actor.source == ActorSourceKind::motion) {
    return retargeted_motion(std::make_shared<const RetargetedActor>(retarget_actor(actor.retarget, progress, cache)));
  }
  ActorMotion motion = actor.source == ActorSourceKind::animation ? play_character_animation(actor.animation, cache)
                                                                  : play_anime(actor.anime);
  if (progress) {
    progress(ProgressEvent{actor.source == ActorSourceKind::animation ? "load_character" : "load_anime",
                           motion.source_path + ": " + motion.description, nullptr, 0, 0});
    for (const std::string& warning : motion.warnings) progress(ProgressEvent{"warning", motion.source_path + ": " + warning, nullptr, 0, 0});
  }
  return motion;
}

int root_joint(const PlacedActor& actor) { return actor.motion->root_joint; }

double actor_clip_end(const SceneActor& actor, double start, const Clip& clip) {
  const double trim_end = std::min(actor.trim_end_s.value_or(clip.duration()), clip.duration());
  return start + std::max(trim_end - actor.trim_start_s, 0.0) / actor.speed;
}

// The clip times of the scene's frames: frame f at c(f / fps) (scene.h).
std::vector<double> timeline_times(const SceneActor& actor, double start, const Clip& clip, int frames, double fps) {
  const double trim_end = std::min(actor.trim_end_s.value_or(clip.duration()), clip.duration());
  if (actor.trim_start_s > trim_end) {
    throw std::invalid_argument("actor '" + actor.name + "': trim starts at " + std::to_string(actor.trim_start_s) +
                                " s, after the clip's end at " + std::to_string(clip.duration()) + " s");
  }
  std::vector<double> times(frames);
  for (int f = 0; f < frames; ++f) {
    times[f] = std::clamp(actor.trim_start_s + actor.speed * (f / fps - start), actor.trim_start_s, trim_end);
  }
  return times;
}

// Turns the whole clip by `rotation` about the origin, then moves it by `shift`: every root joint's
// local transform (its world transform) T becomes (R, d) T.
void move_clip(Clip& clip, const Eigen::Matrix3d& rotation, const Eigen::Vector3d& shift) {
  const int joints = clip.joint_count();
  const int frames = clip.frame_count();
  std::vector<int> translated = clip.translated_joints;
  for (int j = 0; j < joints; ++j) {
    if (clip.skeleton.parent(j) == -1 && std::find(translated.begin(), translated.end(), j) == translated.end()) {
      translated.push_back(j);
    }
  }
  std::vector<Eigen::Vector3d> translations(std::size_t(frames) * translated.size());
  const std::size_t old_k = clip.translated_joints.size();
  for (int f = 0; f < frames; ++f) {
    for (std::size_t t = 0; t < translated.size(); ++t) {
      translations[f * translated.size() + t] =
          t < old_k ? clip.translations[f * old_k + t] : clip.skeleton.rest_offsets()[translated[t]];
    }
  }
  clip.translated_joints = translated;
  clip.translations = std::move(translations);
  const Eigen::Quaterniond q(rotation);
  for (int f = 0; f < frames; ++f) {
    for (std::size_t t = 0; t < translated.size(); ++t) {
      const int j = translated[t];
      if (clip.skeleton.parent(j) != -1) continue;
      Eigen::Vector3d& translation = clip.translations[f * translated.size() + t];
      translation = rotation * translation + shift;
      Eigen::Quaterniond& r = clip.rotations[std::size_t(f) * joints + j];
      r = (q * r).normalized();
    }
  }
}

// The direction the actor faces in a pose (degrees from +x, counter-clockwise seen from above):
// its rest facing (camera_rigs.h, actor_source.h) turned as its root (the pelvis) has turned from rest.
double heading_deg(const ActorMotion& actor, std::span<const RigidTransform<double>> world) {
  const Skeleton& skeleton = actor.character.skeleton;
  const int root = actor.root_joint;
  const Eigen::Matrix3d turn = world[root].rotation * skeleton.rest_world()[root].rotation.transpose();
  const Eigen::Vector3d facing = turn * actor.rest_facing;
  return std::atan2(facing.y(), facing.x()) * 180 / std::numbers::pi;
}

// The root's horizontal track over the scene's frames.
std::vector<Eigen::Vector2d> root_track(const Clip& clip, int root) {
  std::vector<RigidTransform<double>> world(clip.joint_count());
  std::vector<Eigen::Vector2d> track(clip.frame_count());
  for (int f = 0; f < clip.frame_count(); ++f) {
    clip.world_pose(f, world);
    track[f] = world[root].translation.head<2>();
  }
  return track;
}

// The first frame where two footprints overlap, or -1.
int overlap_frame(const std::vector<Eigen::Vector2d>& a, double radius_a, const std::vector<Eigen::Vector2d>& b,
                  double radius_b) {
  for (std::size_t f = 0; f < a.size(); ++f) {
    if ((a[f] - b[f]).norm() < radius_a + radius_b) return static_cast<int>(f);
  }
  return -1;
}

// A static character of one joint at the identity whose meshes are the props in world
// coordinates, rigidly bound to it.
StreamProps build_props(const std::vector<Prop>& props) {
  StreamProps out;
  out.character.name = "props";
  out.character.skeleton = Skeleton({"props"}, {-1}, {Eigen::Vector3d::Zero()}, {Eigen::Quaterniond::Identity()});
  for (const Prop& prop : props) {
    std::vector<Eigen::Vector3d> positions;
    std::vector<std::uint32_t> triangles;
    if (prop.kind == Prop::Kind::ground) {
      const double x = prop.size.x() / 2, y = prop.size.y() / 2;
      if (!(x > 0 && y > 0 && std::isfinite(x) && std::isfinite(y))) {
        throw std::invalid_argument("prop '" + prop.name + "': a ground needs a positive size x, y");
      }
      positions = {{-x, -y, 0}, {x, -y, 0}, {x, y, 0}, {-x, y, 0}};
      triangles = {0, 1, 2, 0, 2, 3};
    } else if (prop.kind == Prop::Kind::box) {
      const Eigen::Vector3d h(prop.size.x() / 2, prop.size.y() / 2, prop.size.z());
      if (!((h.array() > 0).all() && h.allFinite())) {
        throw std::invalid_argument("prop '" + prop.name + "': a box needs a positive size x, y, z");
      }
      for (int c = 0; c < 8; ++c) positions.emplace_back(c & 1 ? h.x() : -h.x(), c & 2 ? h.y() : -h.y(), c & 4 ? h.z() : 0.0);
      // Two triangles per face, outward winding.
      triangles = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
                   2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5};
    } else {
      std::string extension = std::filesystem::path(prop.path).extension().string();
      std::transform(extension.begin(), extension.end(), extension.begin(), [](unsigned char c) { return char(std::tolower(c)); });
      if (extension == ".obj") {
        const io::ObjMesh mesh = io::load_obj(prop.path);
        for (const Eigen::Vector3f& p : mesh.positions) {
          // OBJ files from Blender's default export are Y up, -Z forward: (x, y, z) -> (x, -z, y).
          positions.push_back(prop.up_z ? p.cast<double>() : Eigen::Vector3d(p.x(), -p.z(), p.y()));
        }
        triangles = mesh.triangles;
      } else if (extension == ".glb" || extension == ".gltf") {
        const Character character = io::load_character(prop.path);
        const std::vector<RigidTransform<double>> rest = character.skeleton.rest_world();
        for (const CharacterMesh& mesh : character.meshes) {
          const auto offset = static_cast<std::uint32_t>(positions.size());
          const std::vector<Eigen::Vector3d> skinned = skin_mesh_reference(mesh, rest);
          positions.insert(positions.end(), skinned.begin(), skinned.end());
          for (const std::uint32_t corner : mesh.triangles) triangles.push_back(offset + corner);
        }
        if (triangles.empty()) throw io::InputError(prop.path, "no triangles: a prop mesh needs some");
      } else {
        throw io::InputError(prop.path, "unsupported prop mesh type '" + extension + "' (expected .glb, .gltf or .obj)");
      }
    }
    const Eigen::Matrix3d rotation = yaw_rotation(prop.yaw_deg) * prop.scale;
    CharacterMesh mesh;
    mesh.name = prop.name;
    for (const Eigen::Vector3d& p : positions) {
      const Eigen::Vector3d world = rotation * p + prop.position;
      if (!world.allFinite()) throw std::invalid_argument("prop '" + prop.name + "': a vertex is not finite");
      mesh.positions.push_back(world.cast<float>());
    }
    mesh.triangles = std::move(triangles);
    mesh.skin_joints = {0};
    mesh.inverse_bind = {Eigen::Matrix4d::Identity()};
    mesh.influence_slots.assign(mesh.positions.size(), {0, 0, 0, 0});
    mesh.influence_weights.assign(mesh.positions.size(), {1, 0, 0, 0});
    out.character.meshes.push_back(std::move(mesh));
    out.character.source_node_of_joint = {0};
    out.character.source_scale_of_joint = {1};
    out.names.push_back(prop.name);
  }
  return out;
}

struct Framing {
  double height = 0;
  Eigen::Vector3d target;
  double distance = 0;
  Eigen::Vector3d facing;
};

Framing frame_actors(const std::vector<PlacedActor>& actors) {
  Framing framing;
  double floor = INFINITY;
  std::vector<std::vector<Eigen::Vector2d>> tracks;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  long samples = 0;
  for (const PlacedActor& actor : actors) {
    const Eigen::AlignedBox3d bounds = actor.motion->character.rest_bounds();
    framing.height = std::max(framing.height, bounds.sizes().z());
    floor = std::min(floor, bounds.min().z());
    tracks.push_back(root_track(actor.clip, root_joint(actor)));
    for (const Eigen::Vector2d& p : tracks.back()) mean += p;
    samples += static_cast<long>(tracks.back().size());
  }
  if (!(framing.height > 0)) throw std::invalid_argument("the actors have no height at rest");
  mean /= static_cast<double>(std::max(samples, 1L));
  double extent = 0;
  for (const auto& track : tracks) {
    for (const Eigen::Vector2d& p : track) extent = std::max(extent, (p - mean).norm());
  }
  framing.target = Eigen::Vector3d(mean.x(), mean.y(), floor + 0.55 * framing.height);
  framing.distance = 2.5 * framing.height + extent;
  const Eigen::Vector3d rest = actors[0].motion->rest_facing;
  // The rest facing, turned as the first actor's placement turned its motion.
  framing.facing = yaw_rotation(actors[0].turn_deg) * rest;
  return framing;
}

// The actors' mean root position per frame, at the framing target's height: what an imported
// camera is re-aimed at.
std::vector<Eigen::Vector3d> actors_centre_track(const std::vector<PlacedActor>& actors, int frames, double height) {
  std::vector<Eigen::Vector3d> track(frames, Eigen::Vector3d::Zero());
  for (const PlacedActor& actor : actors) {
    const std::vector<Eigen::Vector2d> roots = root_track(actor.clip, root_joint(actor));
    for (int f = 0; f < frames; ++f) track[f].head<2>() += roots[f] / static_cast<double>(actors.size());
  }
  for (Eigen::Vector3d& point : track) point.z() = height;
  return track;
}

// The camera's path before any handheld shake; notes of imported tracks go to `notes`.
CameraPath camera_rig_path(const SceneCamera& camera, const Scene& scene, const std::vector<PlacedActor>& actors,
                           const Framing& framing, int frames, std::size_t index, std::vector<std::string>& notes) {
  const std::string who = "camera '" + camera.name + "': ";
  const double facing_deg = std::atan2(framing.facing.y(), framing.facing.x()) * 180 / std::numbers::pi;
  if (camera.kind == SceneCamera::Kind::realestate10k || camera.kind == SceneCamera::Kind::colmap) {
    const io::CameraTrack track = camera.kind == SceneCamera::Kind::realestate10k
                                      ? io::read_realestate10k(camera.path)
                                      : io::read_colmap_text(camera.path, camera.source_fps);
    ImportedCameraOptions options;
    options.width = camera.width;
    options.height = camera.height;
    options.extent_m = camera.extent_m;
    options.anchor = camera.anchor_focus ? ImportedCameraOptions::Anchor::focus : ImportedCameraOptions::Anchor::centroid;
    options.centre = camera.target.value_or(framing.target).head<2>();
    options.height_m = camera.height_m.value_or(0.9 * framing.height);
    options.start_angle_deg = camera.start_angle_deg.value_or(facing_deg);
    options.speed = camera.speed;
    options.up = camera.up;
    if (camera.aim_smoothing_s) {
      options.look_at = actors_centre_track(actors, frames, framing.target.z());
      options.aim_smoothing_s = *camera.aim_smoothing_s;
    }
    std::vector<std::string> track_notes;
    try {
      CameraPath path = imported_camera_path(track, frames, scene.fps, options, &track_notes);
      for (const std::string& note : track_notes) notes.push_back(who + note);
      return path;
    } catch (const std::invalid_argument& error) {
      throw std::invalid_argument(who + error.what());
    }
  }
  if (camera.kind == SceneCamera::Kind::file) {
    CameraPath path = io::read_camera_path_json(camera.path);
    if (path.frame_count() != frames || std::abs(path.fps - scene.fps) > 1e-9 * scene.fps) {
      throw io::InputError(camera.path, "the camera path has " + std::to_string(path.frame_count()) + " frames at " +
                                            std::to_string(path.fps) + " fps; the shot has " + std::to_string(frames) +
                                            " at " + std::to_string(scene.fps));
    }
    return path;
  }
  PinholeIntrinsics intrinsics;
  try {
    intrinsics = intrinsics_from_hfov(camera.width, camera.height, camera.hfov_deg);
  } catch (const std::invalid_argument& error) {
    throw std::invalid_argument(who + error.what());
  }
  SeededUniform jitter(scene.seed, 2000 + index);
  const Eigen::Vector3d shake(jitter.between(-1, 1), jitter.between(-1, 1), jitter.between(-1, 1));
  const Eigen::Vector3d offset = camera.jitter_m * shake;
  // The static camera's default centre: in front of the actors, looking back at `target`.
  const auto default_centre = [&](const Eigen::Vector3d& target) {
    return Eigen::Vector3d(target.x() + framing.distance * framing.facing.x(), target.y() + framing.distance * framing.facing.y(),
                           0.9 * framing.height);
  };
  try {
    if (camera.kind == SceneCamera::Kind::fixed) {
      StaticCameraOptions options;
      options.target = camera.target.value_or(framing.target);
      options.centre = camera.position.value_or(default_centre(options.target)) + offset;
      return static_camera_path(frames, scene.fps, intrinsics, options);
    }
    if (camera.kind == SceneCamera::Kind::swoop) {
      SwoopCameraOptions options;
      options.target = camera.target.value_or(framing.target);
      options.radius = camera.radius.value_or(framing.distance);
      options.start_height = camera.height_m.value_or(0.9 * framing.height);
      options.end_height = camera.height_end_m.value_or(2.5 * framing.height);
      options.start_angle_deg = camera.start_angle_deg.value_or(facing_deg);
      options.sweep_deg = camera.sweep_deg;
      return swoop_camera_path(frames, scene.fps, intrinsics, options);
    }
    if (camera.kind == SceneCamera::Kind::dolly_zoom) {
      DollyZoomOptions options;
      options.target = camera.target.value_or(framing.target);
      options.start_centre = camera.position.value_or(default_centre(options.target));
      options.end_distance = camera.end_distance.value_or((options.target - options.start_centre).norm() / 2);
      return dolly_zoom_camera_path(frames, scene.fps, intrinsics, options);
    }
    if (camera.kind == SceneCamera::Kind::zoom) {
      ZoomCameraOptions options;
      options.target = camera.target.value_or(framing.target);
      options.centre = camera.position.value_or(default_centre(options.target));
      options.end_hfov_deg = camera.hfov_end_deg.value_or(camera.hfov_deg / 2);
      return zoom_camera_path(frames, scene.fps, intrinsics, options);
    }
    if (camera.kind == SceneCamera::Kind::orbit) {
      OrbitCameraOptions options;
      options.target = camera.target.value_or(framing.target) + Eigen::Vector3d(offset.x(), offset.y(), 0);
      options.radius = camera.radius.value_or(framing.distance);
      options.height = camera.height_m.value_or(0.9 * framing.height) + offset.z();
      options.period_s = camera.period_s;
      options.start_angle_deg = camera.start_angle_deg.value_or(facing_deg);
      return orbit_camera_path(frames, scene.fps, intrinsics, options);
    }
    const PlacedActor& actor = actors[camera.actor];
    if (!actor.retargeted) {
      throw std::invalid_argument("rides on actor '" + actor.name + "', whose source (" + actor_source_name(actor.motion->kind) +
                                  ") has no bone map: an ego camera needs the head and hips of a retargeted character's");
    }
    const double height = actor.retargeted->character.rest_bounds().sizes().z();
    EgoHeadOptions options;
    options.forward_offset = camera.eye_forward.value_or(0.06 * height);
    options.up_offset = camera.eye_up.value_or(0.047 * height);
    options.smoothing_sigma_s = camera.smoothing_s;
    return ego_head_camera_path(actor.clip, actor.retargeted->target_map, intrinsics, options);
  } catch (const std::invalid_argument& error) {
    throw std::invalid_argument(who + error.what());
  }
}

CameraPath make_camera(const SceneCamera& camera, const Scene& scene, const std::vector<PlacedActor>& actors,
                       const Framing& framing, int frames, std::size_t index, std::vector<std::string>& notes) {
  CameraPath path = camera_rig_path(camera, scene, actors, framing, frames, index, notes);
  if (camera.handheld) {
    try {
      apply_handheld(path, *camera.handheld, scene.seed, 4000 + index);
    } catch (const std::invalid_argument& error) {
      throw std::invalid_argument("camera '" + camera.name + "': " + error.what());
    }
  }
  return path;
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

// The rest OBJ beside a point cache: the same path with .obj.
std::string obj_beside(const std::string& pc2) { return std::filesystem::path(pc2).replace_extension(".obj").string(); }

// Builds each distinct source once (retarget a motion, play an animation, read an anime) and
// gives every actor of the scene its own placed copy to fill.
void build_actors(const Scene& scene, const ProgressCallback& progress, LoadCache* cache, SceneResult& result) {
  std::map<std::string, std::shared_ptr<const ActorMotion>> built;
  for (const SceneActor& actor : scene.actors) {
    std::shared_ptr<const ActorMotion>& slot = built[source_key(actor)];
    if (!slot) slot = std::make_shared<const ActorMotion>(build_motion(actor, progress, cache));
    PlacedActor placed;
    placed.name = actor.name;
    placed.motion = slot;
    placed.retargeted = slot->retargeted;
    result.actors.push_back(std::move(placed));
  }
  for (const SceneActor& actor : scene.actors) {
    if (actor.source == ActorSourceKind::motion && actor.retarget.parts == retarget::Parts::body) {
      result.skipped.push_back("actor '" + actor.name + "': fingers and face not solved (parts body: they keep their rest pose)");
    }
  }
}

// Each actor's start on the timeline (drawn from its range where it has one), and the shot's
// frame count: the scene's seconds, or until the last clip ends.
int time_actors(const Scene& scene, SceneResult& result) {
  double end = 0;
  for (std::size_t a = 0; a < scene.actors.size(); ++a) {
    const SceneActor& spec = scene.actors[a];
    result.actors[a].start_s = spec.start_s;
    if (spec.start_range) {
      SeededUniform draw(scene.seed, 3000 + a);
      result.actors[a].start_s = draw.between(spec.start_range->first, spec.start_range->second);
    }
    end = std::max(end, actor_clip_end(spec, result.actors[a].start_s, result.actors[a].motion->clip));
  }
  const double seconds = scene.seconds.value_or(end);
  // Every actor's clip is held on the timeline (J quaternions and a root a frame): a shot of days
  // is a typo, refused before anything is allocated.
  constexpr double kMaxFrames = 10'000'000;
  if (seconds * scene.fps >= kMaxFrames) {
    throw std::invalid_argument("scene: " + std::to_string(seconds) + " s at " + std::to_string(scene.fps) +
                                " fps is more than 10,000,000 frames");
  }
  return static_cast<int>(std::floor(seconds * scene.fps * (1 + 1e-9) + 1e-9)) + 1;
}

// Where an actor's root goes over the shot, and how close another may come (its radius).
struct Footprint {
  std::vector<Eigen::Vector2d> track;
  double radius = 0;
};

// The index of the first footprint `candidate` overlaps, and the frame (-1 and -1: none).
int first_overlap(const Footprint& candidate, const std::vector<Footprint>& placed, int& frame) {
  for (std::size_t b = 0; b < placed.size(); ++b) {
    frame = overlap_frame(candidate.track, candidate.radius, placed[b].track, placed[b].radius);
    if (frame >= 0) return static_cast<int>(b);
  }
  frame = -1;
  return -1;
}

// Actor a's clip timed onto the shot's frames and placed as its spec says (as recorded, at a fixed
// spot, or drawn in its region), clear of the actors placed before it; returns its footprint.
Footprint place_actor(const Scene& scene, std::size_t a, int frames, const std::vector<Footprint>& placed, PlacedActor& actor) {
  const SceneActor& spec = scene.actors[a];
  const ActorMotion& motion = *actor.motion;
  const std::vector<double> times = timeline_times(spec, actor.start_s, motion.clip, frames, scene.fps);
  const Clip timed = motion.clip.sampled_at(times, scene.fps);
  if (motion.vertex_animation) actor.vertex_animation = motion.vertex_animation->sampled_at(times, scene.fps);
  const int root = root_joint(actor);
  std::vector<RigidTransform<double>> world(timed.joint_count());
  timed.world_pose(0, world);
  const Eigen::Vector3d start_root(world[root].translation.x(), world[root].translation.y(), 0);
  const double start_heading = heading_deg(motion, world);
  Footprint footprint;
  footprint.radius = 0.15 * motion.character.rest_bounds().sizes().z();
  // Turning by yaw - start_heading about the start root makes the actor face `yaw` there.
  const auto place = [&](double x, double y, double yaw) {
    actor.clip = timed;
    const Eigen::Matrix3d rotation = yaw_rotation(yaw - start_heading);
    move_clip(actor.clip, rotation, Eigen::Vector3d(x, y, 0) - rotation * start_root);
    actor.x = x;
    actor.y = y;
    actor.yaw_deg = yaw;
    actor.turn_deg = yaw - start_heading;
    footprint.track = root_track(actor.clip, root);
  };
  const Placement& placement = spec.placement;
  int frame = -1;
  if (placement.kind == Placement::Kind::random) {
    SeededUniform draw(scene.seed, a);
    constexpr int kDraws = 200;
    int other = -1;
    for (int attempt = 0; attempt < kDraws; ++attempt) {
      place(draw.between(placement.region.min().x(), placement.region.max().x()),
            draw.between(placement.region.min().y(), placement.region.max().y()), draw.between(0, 360));
      other = first_overlap(footprint, placed, frame);
      if (other < 0) break;
    }
    if (other >= 0) {
      throw std::invalid_argument("actor '" + spec.name + "': no placement in its region keeps it clear of actor '" +
                                  scene.actors[other].name + "' (" + std::to_string(kDraws) + " draws); widen the region");
    }
    return footprint;
  }
  if (placement.kind == Placement::Kind::as_recorded) {
    actor.clip = timed;
    actor.x = start_root.x();
    actor.y = start_root.y();
    actor.yaw_deg = start_heading;
    footprint.track = root_track(actor.clip, root);
  } else {
    place(placement.x, placement.y, placement.yaw_deg);
  }
  if (const int other = first_overlap(footprint, placed, frame); other >= 0) {
    throw std::invalid_argument("actors '" + scene.actors[other].name + "' and '" + spec.name + "' overlap at frame " +
                                std::to_string(frame) + ": their roots come within " +
                                std::to_string(placed[other].radius + footprint.radius) +
                                " m; place them apart or shift them in time");
  }
  return footprint;
}

// What the streams read: every actor (its points sampled when points are tracked) and the props
// (with theirs).
struct StreamInputs {
  std::vector<StreamActor> actors;
  StreamProps props;
};

StreamInputs stream_inputs(const Scene& scene, const StreamProps& props, bool tracking, SceneResult& result) {
  const SceneOutputs& outputs = scene.outputs;
  StreamInputs inputs;
  inputs.actors.resize(scene.actors.size());
  for (std::size_t a = 0; a < scene.actors.size(); ++a) {
    StreamActor& actor = inputs.actors[a];
    actor.name = scene.actors[a].name;
    const ActorMotion& motion = *result.actors[a].motion;
    actor.character = &motion.character;
    actor.clip = &result.actors[a].clip;
    if (result.actors[a].vertex_animation) actor.vertex_animation = &*result.actors[a].vertex_animation;
    actor.mesh_every_frame = !outputs.point_caches.empty() && !outputs.point_caches[a].empty();
    actor.head_joint = motion.head_joint;
    if (tracking) {
      const int count = scene.actors[a].points.value_or(outputs.points_per_actor);
      actor.points = sample_actor_points(scene.actors[a], motion, count, scene.seed + a, outputs.body_points_only);
      result.actors[a].points = count;
    }
  }
  inputs.props = props;
  if (tracking && outputs.prop_points > 0) {
    skinning::SamplingOptions options;
    options.count = outputs.prop_points;
    options.seed = scene.seed + 1000;
    inputs.props.points = skinning::sample_surface_points(inputs.props.character, options);
  }
  return inputs;
}

// The streams' sinks (contact sheets, trajectory files, point caches with their rest OBJs), each
// writing under a staged name, and the cameras as the streams see them.
struct Sinks {
  std::vector<std::unique_ptr<io::TrajectoryFileWriter>> trajectory_writers;
  std::vector<std::unique_ptr<io::Pc2Writer>> cache_writers;
  std::vector<std::unique_ptr<StreamSink>> sinks;
  std::vector<StreamCamera> cameras;
};

Sinks open_sinks(const Scene& scene, const StreamInputs& inputs, io::StagedOutputs& staged, SceneResult& result) {
  const SceneOutputs& outputs = scene.outputs;
  Sinks out;
  out.cameras.resize(scene.cameras.size());
  for (std::size_t c = 0; c < scene.cameras.size(); ++c) {
    StreamCamera& camera = out.cameras[c];
    camera.name = scene.cameras[c].name;
    camera.path = &result.cameras[c];
    camera.own_actor = scene.cameras[c].kind == SceneCamera::Kind::ego ? scene.cameras[c].actor : -1;
    camera.preview = !outputs.previews.empty() && !outputs.previews[c].empty();
    camera.tracks = (!outputs.trajectories.empty() && !outputs.trajectories[c].empty()) || camera.preview;
    if (camera.preview) {
      out.sinks.push_back(std::make_unique<ContactSheetSink>(static_cast<int>(c), staged.stage(outputs.previews[c])));
      result.outputs.push_back(outputs.previews[c]);
    }
  }
  if (any_path(outputs.trajectories)) {
    const io::TrajectoryFileHeader header =
        trajectory_file_header(inputs.actors, scene.props.empty() ? nullptr : &inputs.props, result.frames, scene.fps);
    if (header.points == 0) throw std::invalid_argument("scene: trajectories asked for, but no points to track");
    for (std::size_t c = 0; c < scene.cameras.size(); ++c) {
      if (outputs.trajectories[c].empty()) continue;
      out.trajectory_writers.push_back(
          std::make_unique<io::TrajectoryFileWriter>(staged.stage(outputs.trajectories[c]), header, outputs.compress));
      out.sinks.push_back(std::make_unique<TrajectorySink>(static_cast<int>(c), *out.trajectory_writers.back()));
      result.outputs.push_back(outputs.trajectories[c]);
    }
  }
  for (std::size_t a = 0; a < outputs.point_caches.size(); ++a) {
    if (outputs.point_caches[a].empty()) continue;
    const Character& character = result.actors[a].motion->character;
    std::size_t vertices = 0;
    for (const CharacterMesh& mesh : character.meshes) vertices += mesh.positions.size();
    if (vertices == 0) throw io::InputError(result.actors[a].motion->source_path, "the character has no mesh to cache");
    const std::string obj = a < outputs.rest_objs.size() && !outputs.rest_objs[a].empty() ? outputs.rest_objs[a]
                                                                                          : obj_beside(outputs.point_caches[a]);
    io::write_rest_obj(staged.stage(obj), character);
    out.cache_writers.push_back(std::make_unique<io::Pc2Writer>(staged.stage(outputs.point_caches[a]), vertices, result.frames));
    out.sinks.push_back(std::make_unique<PointCacheSink>(static_cast<int>(a), *out.cache_writers.back()));
    result.outputs.push_back(outputs.point_caches[a]);
    result.outputs.push_back(obj);
  }
  return out;
}

// Runs the streams into the sinks and closes their files; notes the actors whose mesh was skinned
// in fewer frames than the shot has.
void run_sinks(const Scene& scene, const StreamInputs& inputs, Sinks& sinks, bool tracking, const ProgressCallback& progress,
               SceneResult& result) {
  if (sinks.sinks.empty()) return;
  StreamOptions options;
  options.chunk_frames = scene.outputs.chunk_frames;
  options.threads = scene.outputs.threads;
  if (progress) {
    options.on_chunk = [&](int done, int total) {
      progress(ProgressEvent{"export", std::to_string(done) + " of " + std::to_string(total) + " frames", nullptr, done, total});
    };
  }
  std::vector<StreamSink*> sink_pointers;
  for (const auto& sink : sinks.sinks) sink_pointers.push_back(sink.get());
  result.streams =
      run_streams(inputs.actors, scene.props.empty() ? nullptr : &inputs.props, sinks.cameras, sink_pointers, options);
  for (const auto& writer : sinks.trajectory_writers) writer->close();
  for (const auto& writer : sinks.cache_writers) writer->close();
  for (std::size_t a = 0; a < scene.actors.size(); ++a) {
    const long skipped = result.frames - result.streams.actor_mesh_frames[a];
    if (tracking && skipped > 0) {
      result.skipped.push_back("actor '" + scene.actors[a].name + "': mesh not skinned in " + std::to_string(skipped) + " of " +
                               std::to_string(result.frames) + " frames (no camera could see it, no point cache asked)");
    }
  }
}

// The camera paths and GLBs the scene asks for, staged.
void write_scene_files(const Scene& scene, io::StagedOutputs& staged, SceneResult& result) {
  const SceneOutputs& outputs = scene.outputs;
  for (std::size_t c = 0; c < outputs.camera_paths.size(); ++c) {
    if (outputs.camera_paths[c].empty()) continue;
    io::write_camera_path_json(staged.stage(outputs.camera_paths[c]), result.cameras[c]);
    result.outputs.push_back(outputs.camera_paths[c]);
  }
  if (!outputs.glb.empty()) {
    const RetargetedActor& actor = *result.actors[0].retargeted;
    io::GlbExportOptions options;
    options.animation_name = std::filesystem::path(actor.request.motion_path).stem().string();
    if (!result.cameras.empty()) {
      options.camera = &result.cameras[0];
      options.camera_name = scene.cameras[0].name;
    }
    io::write_animated_glb(actor.request.character_path, actor.character, result.actors[0].clip, staged.stage(outputs.glb),
                           options);
    result.outputs.push_back(outputs.glb);
  }
  if (!outputs.scene_glb.empty()) {
    std::vector<io::SceneGlbActor> glb_actors;
    for (const PlacedActor& actor : result.actors) {
      glb_actors.push_back({actor.name, &actor.motion->character, &actor.clip,
                            actor.vertex_animation ? &*actor.vertex_animation : nullptr});
    }
    std::vector<io::SceneGlbCamera> glb_cameras;
    for (std::size_t c = 0; c < result.cameras.size(); ++c) glb_cameras.push_back({result.camera_names[c], &result.cameras[c]});
    io::write_scene_glb(staged.stage(outputs.scene_glb), glb_actors, scene.props.empty() ? nullptr : &result.props, glb_cameras,
                        result.fps);
    result.outputs.push_back(outputs.scene_glb);
  }
}

// Each actor's report (its retargeting report with the scene's camera and timings) and the
// scene's, staged; they list every output, so they come last.
void write_reports(const Scene& scene, io::StagedOutputs& staged, SceneResult& result) {
  const SceneOutputs& outputs = scene.outputs;
  for (std::size_t a = 0; a < outputs.actor_reports.size(); ++a) {
    if (outputs.actor_reports[a].empty()) continue;
    nlohmann::ordered_json json = actor_motion_report_json(*result.actors[a].motion);
    // Relative to the report's folder, so the pair can move together (a batch builds them in a
    // staging folder and renames it) and a report does not depend on where the run wrote.
    namespace fs = std::filesystem;
    json["inputs"]["output"] = nullptr;
    if (!outputs.glb.empty()) {
      const fs::path report_folder = fs::absolute(outputs.actor_reports[a]).parent_path().lexically_normal();
      json["inputs"]["output"] = fs::absolute(outputs.glb).lexically_normal().lexically_relative(report_folder).generic_string();
    }
    json["settings"]["camera"] = result.cameras.empty() ? nlohmann::ordered_json() : nlohmann::ordered_json(result.cameras[0].kind);
    json["timings_s"]["command"]["write_outputs"] = result.seconds.streams;
    json["timings_s"]["command"]["total"] = result.seconds.total;
    io::write_file_atomically(staged.stage(outputs.actor_reports[a]), json.dump(2) + "\n");
  }
  if (!outputs.report.empty()) {
    io::write_file_atomically(staged.stage(outputs.report), scene_report_json(result).dump(2) + "\n");
  }
}

}  // namespace

SceneResult run_scene(const Scene& scene, const ProgressCallback& progress, LoadCache* cache) {
  const auto total_start = Clock::now();
  validate_scene(scene);
  SceneResult result;
  result.name = scene.name;
  result.fps = scene.fps;
  result.seed = scene.seed;
  const SceneOutputs& outputs = scene.outputs;
  // Points are tracked when some camera writes trajectories or a contact sheet.
  const bool tracking = any_path(outputs.trajectories) || any_path(outputs.previews);

  auto start = Clock::now();
  build_actors(scene, progress, cache, result);
  result.seconds.retarget = seconds_since(start);
  result.frames = time_actors(scene, result);
  std::vector<Footprint> placed;
  for (std::size_t a = 0; a < scene.actors.size(); ++a) {
    placed.push_back(place_actor(scene, a, result.frames, placed, result.actors[a]));
  }

  // Props, cameras, points.
  const StreamProps props = build_props(scene.props);
  const Framing framing = frame_actors(result.actors);
  for (std::size_t c = 0; c < scene.cameras.size(); ++c) {
    result.cameras.push_back(make_camera(scene.cameras[c], scene, result.actors, framing, result.frames, c, result.notes));
    result.camera_names.push_back(scene.cameras[c].name);
  }
  result.prop_names = props.names;
  result.props = props.character;
  const StreamInputs inputs = stream_inputs(scene, props, tracking, result);
  if (!tracking) {
    result.skipped.push_back("tracked points, visibility and occluder rasterising: no trajectories or previews asked for");
  }

  io::StagedOutputs staged;
  Sinks sinks = open_sinks(scene, inputs, staged, result);
  start = Clock::now();
  run_sinks(scene, inputs, sinks, tracking, progress, result);
  result.seconds.streams = seconds_since(start);
  write_scene_files(scene, staged, result);
  if (!outputs.report.empty()) result.outputs.push_back(outputs.report);
  for (const std::string& path : outputs.actor_reports) {
    if (!path.empty()) result.outputs.push_back(path);
  }
  result.seconds.total = seconds_since(total_start);
  write_reports(scene, staged, result);
  staged.commit();
  return result;
}

nlohmann::ordered_json scene_report_json(const SceneResult& result) {
  nlohmann::ordered_json json;
  json["scene"] = result.name;
  json["fps"] = result.fps;
  json["frames"] = result.frames;
  json["seed"] = result.seed;
  json["actors"] = nlohmann::ordered_json::array();
  for (std::size_t a = 0; a < result.actors.size(); ++a) {
    const PlacedActor& actor = result.actors[a];
    nlohmann::ordered_json entry;
    entry["name"] = actor.name;
    entry["id"] = a;
    entry["placement"] = {{"x", actor.x}, {"y", actor.y}, {"yaw_deg", actor.yaw_deg}};
    entry["start_s"] = actor.start_s;
    entry["points"] = actor.points;
    if (a < result.streams.actor_mesh_frames.size()) entry["mesh_frames_skinned"] = result.streams.actor_mesh_frames[a];
    // A motion's entry keeps its key "retarget"; the other sources report under "source".
    entry[actor.retargeted ? "retarget" : "source"] = actor_motion_report_json(*actor.motion);
    json["actors"].push_back(entry);
  }
  json["props"] = nlohmann::ordered_json::array();
  for (std::size_t p = 0; p < result.prop_names.size(); ++p) {
    json["props"].push_back({{"name", result.prop_names[p]}, {"id", -1 - static_cast<int>(p)}});
  }
  json["cameras"] = nlohmann::ordered_json::array();
  for (std::size_t c = 0; c < result.cameras.size(); ++c) {
    const CameraPath& path = result.cameras[c];
    nlohmann::ordered_json entry = {{"name", result.camera_names[c]},
                                    {"kind", path.kind},
                                    {"width", path.intrinsics.at(0).width},
                                    {"height", path.intrinsics.at(0).height},
                                    {"hfov_deg", path.intrinsics.at(0).horizontal_fov_deg()}};
    if (c < result.streams.cameras.size()) {
      const CameraStreamSummary& s = result.streams.cameras[c];
      entry["point_frames"] = {{"valid", s.valid_fraction},
                               {"visible", s.visible_fraction},
                               {"occluded_by_actor", s.occluded_by_actor_fraction},
                               {"occluded_by_prop", s.occluded_by_prop_fraction}};
      entry["actor_frames_culled"] = s.actor_frames_culled;
    }
    json["cameras"].push_back(entry);
  }
  json["points"] = result.streams.points;
  json["skipped"] = result.skipped;
  json["notes"] = result.notes;
  json["outputs"] = result.outputs;
  json["timings_s"] = {{"retarget", result.seconds.retarget},
                       {"streams", result.seconds.streams},
                       {"total", result.seconds.total}};
  return json;
}

}  // namespace odyssey::scene
