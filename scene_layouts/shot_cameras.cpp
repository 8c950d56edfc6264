#include "scene_layouts/shot_cameras.h"

#include <cmath>
#include <numbers>
#include <stdexcept>

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
