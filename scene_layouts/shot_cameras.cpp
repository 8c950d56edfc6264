#include "scene_layouts/shot_cameras.h"

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <variant>

#include "mocap_io/camera_import.h"
#include "mocap_io/camera_path_file.h"
#include "mocap_io/input_error.h"
#include "scene_layouts/camera_rigs.h"
#include "scene_layouts/imported_camera.h"
#include "scene_layouts/placement.h"
#include "scene_layouts/seeded_uniform.h"

namespace odyssey::scene {
namespace {

// The actors' mean root position per frame, at the framing target's height: what an imported
// camera is re-aimed at.
std::vector<Eigen::Vector3d> actors_centre_track(const std::vector<PlacedActor>& actors, int frames, double height) {
  std::vector<Eigen::Vector3d> track(frames, Eigen::Vector3d::Zero());
  for (const PlacedActor& actor : actors) {
    const std::vector<Eigen::Vector2d> roots = root_track(actor.clip, actor.motion->root_joint);
    for (int f = 0; f < frames; ++f) track[f].head<2>() += roots[f] / static_cast<double>(actors.size());
  }
  for (Eigen::Vector3d& point : track) point.z() = height;
  return track;
}

// What every rig's path maker sees: the camera, the shot so far and the framing.
struct RigContext {
  const SceneCamera& camera;
  const Scene& scene;
  const std::vector<PlacedActor>& actors;
  const Framing& framing;
  int frames;
  std::size_t index;
  std::vector<std::string>& notes;

  // "camera 'NAME': ", which every error of the camera's path begins with.
  std::string who() const { return "camera '" + camera.name + "': "; }
  // The first actor's facing as an angle from +x (the default start angle of circling rigs).
  double facing_deg() const { return std::atan2(framing.facing.y(), framing.facing.x()) * 180 / std::numbers::pi; }
  // The static camera's default centre: in front of the actors, looking back at `target`.
  Eigen::Vector3d default_centre(const Eigen::Vector3d& target) const {
    return Eigen::Vector3d(target.x() + framing.distance * framing.facing.x(), target.y() + framing.distance * framing.facing.y(),
                           0.9 * framing.height);
  }
  // The camera's seeded jitter (stream 2000 + its index), each axis in [-jitter_m, jitter_m].
  Eigen::Vector3d jitter(double jitter_m) const {
    SeededUniform draws(scene.seed, 2000 + index);
    const Eigen::Vector3d shake(draws.between(-1, 1), draws.between(-1, 1), draws.between(-1, 1));
    return jitter_m * shake;
  }
  PinholeIntrinsics intrinsics() const { return intrinsics_from_hfov(camera.width, camera.height, camera.hfov_deg); }
};

// The pinhole rigs (every kind but files and imported tracks): their intrinsics are the camera's
// size and field of view. The path makers below throw std::invalid_argument unprefixed;
// pinhole_path names the camera.
CameraPath rig_path(const StaticRig& rig, const RigContext& c, const PinholeIntrinsics& intrinsics) {
  StaticCameraOptions options;
  options.target = rig.target.value_or(c.framing.target);
  options.centre = rig.position.value_or(c.default_centre(options.target)) + c.jitter(rig.jitter_m);
  return static_camera_path(c.frames, c.scene.fps, intrinsics, options);
}

CameraPath rig_path(const OrbitRig& rig, const RigContext& c, const PinholeIntrinsics& intrinsics) {
  const Eigen::Vector3d offset = c.jitter(rig.jitter_m);
  OrbitCameraOptions options;
  options.target = rig.target.value_or(c.framing.target) + Eigen::Vector3d(offset.x(), offset.y(), 0);
  options.radius = rig.radius.value_or(c.framing.distance);
  options.height = rig.height_m.value_or(0.9 * c.framing.height) + offset.z();
  options.period_s = rig.period_s;
  options.start_angle_deg = rig.start_angle_deg.value_or(c.facing_deg());
  return orbit_camera_path(c.frames, c.scene.fps, intrinsics, options);
}

CameraPath rig_path(const EgoRig& rig, const RigContext& c, const PinholeIntrinsics& intrinsics) {
  const PlacedActor& actor = c.actors[rig.actor];
  if (!actor.retargeted) {
    throw std::invalid_argument("rides on actor '" + actor.name + "', whose source (" + actor_source_name(actor.motion->kind) +
                                ") has no bone map: an ego camera needs the head and hips of a retargeted character's");
  }
  const double height = actor.retargeted->character.rest_bounds().sizes().z();
  EgoHeadOptions options;
  options.forward_offset = rig.eye_forward.value_or(0.06 * height);
  options.up_offset = rig.eye_up.value_or(0.047 * height);
  options.smoothing_sigma_s = rig.smoothing_s;
  return ego_head_camera_path(actor.clip, actor.retargeted->target_map, intrinsics, options);
}

CameraPath rig_path(const SwoopRig& rig, const RigContext& c, const PinholeIntrinsics& intrinsics) {
  SwoopCameraOptions options;
  options.target = rig.target.value_or(c.framing.target);
  options.radius = rig.radius.value_or(c.framing.distance);
  options.start_height = rig.height_m.value_or(0.9 * c.framing.height);
  options.end_height = rig.height_end_m.value_or(2.5 * c.framing.height);
  options.start_angle_deg = rig.start_angle_deg.value_or(c.facing_deg());
  options.sweep_deg = rig.sweep_deg;
  return swoop_camera_path(c.frames, c.scene.fps, intrinsics, options);
}

CameraPath rig_path(const DollyZoomRig& rig, const RigContext& c, const PinholeIntrinsics& intrinsics) {
  DollyZoomOptions options;
  options.target = rig.target.value_or(c.framing.target);
  options.start_centre = rig.position.value_or(c.default_centre(options.target));
  options.end_distance = rig.end_distance.value_or((options.target - options.start_centre).norm() / 2);
  return dolly_zoom_camera_path(c.frames, c.scene.fps, intrinsics, options);
}

CameraPath rig_path(const ZoomRig& rig, const RigContext& c, const PinholeIntrinsics& intrinsics) {
  ZoomCameraOptions options;
  options.target = rig.target.value_or(c.framing.target);
  options.centre = rig.position.value_or(c.default_centre(options.target));
  options.end_hfov_deg = rig.hfov_end_deg.value_or(c.camera.hfov_deg / 2);
  return zoom_camera_path(c.frames, c.scene.fps, intrinsics, options);
}

template <typename Rig>
CameraPath pinhole_path(const Rig& rig, const RigContext& c) {
  try {
    return rig_path(rig, c, c.intrinsics());
  } catch (const std::invalid_argument& error) {
    throw std::invalid_argument(c.who() + error.what());
  }
}

CameraPath camera_kind_path(const StaticRig& rig, const RigContext& c) { return pinhole_path(rig, c); }
CameraPath camera_kind_path(const OrbitRig& rig, const RigContext& c) { return pinhole_path(rig, c); }
CameraPath camera_kind_path(const EgoRig& rig, const RigContext& c) { return pinhole_path(rig, c); }
CameraPath camera_kind_path(const SwoopRig& rig, const RigContext& c) { return pinhole_path(rig, c); }
CameraPath camera_kind_path(const DollyZoomRig& rig, const RigContext& c) { return pinhole_path(rig, c); }
CameraPath camera_kind_path(const ZoomRig& rig, const RigContext& c) { return pinhole_path(rig, c); }

// A camera path file, read as it is: it must have the shot's frames at the shot's rate.
CameraPath camera_kind_path(const FileRig& rig, const RigContext& c) {
  CameraPath path = io::read_camera_path_json(rig.path);
  if (path.frame_count() != c.frames || std::abs(path.fps - c.scene.fps) > 1e-9 * c.scene.fps) {
    throw io::InputError(rig.path, "the camera path has " + std::to_string(path.frame_count()) + " frames at " +
                                       std::to_string(path.fps) + " fps; the shot has " + std::to_string(c.frames) + " at " +
                                       std::to_string(c.scene.fps));
  }
  return path;
}

// A track from real video, fitted about the actors; notes (a lens distortion dropped) go to c.notes.
CameraPath camera_kind_path(const ImportedRig& rig, const RigContext& c) {
  const io::CameraTrack track = rig.format == ImportedRig::Format::realestate10k ? io::read_realestate10k(rig.path)
                                                                                 : io::read_colmap_text(rig.path, rig.source_fps);
  ImportedCameraOptions options;
  options.width = c.camera.width;
  options.height = c.camera.height;
  options.extent_m = rig.extent_m;
  options.anchor = rig.anchor_focus ? ImportedCameraOptions::Anchor::focus : ImportedCameraOptions::Anchor::centroid;
  options.centre = rig.target.value_or(c.framing.target).head<2>();
  options.height_m = rig.height_m.value_or(0.9 * c.framing.height);
  options.start_angle_deg = rig.start_angle_deg.value_or(c.facing_deg());
  options.speed = rig.speed;
  options.up = rig.up;
  if (rig.aim_smoothing_s) {
    options.look_at = actors_centre_track(c.actors, c.frames, c.framing.target.z());
    options.aim_smoothing_s = *rig.aim_smoothing_s;
  }
  std::vector<std::string> track_notes;
  try {
    CameraPath path = imported_camera_path(track, c.frames, c.scene.fps, options, &track_notes);
    for (const std::string& note : track_notes) c.notes.push_back(c.who() + note);
    return path;
  } catch (const std::invalid_argument& error) {
    throw std::invalid_argument(c.who() + error.what());
  }
}

// The camera's path before any handheld shake; notes of imported tracks go to `notes`.
CameraPath camera_rig_path(const SceneCamera& camera, const Scene& scene, const std::vector<PlacedActor>& actors,
                           const Framing& framing, int frames, std::size_t index, std::vector<std::string>& notes) {
  const RigContext context{camera, scene, actors, framing, frames, index, notes};
  return std::visit([&](const auto& rig) { return camera_kind_path(rig, context); }, camera.rig);
}

}  // namespace

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
    tracks.push_back(root_track(actor.clip, actor.motion->root_joint));
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

}  // namespace odyssey::scene
