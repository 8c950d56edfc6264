#include "scene_layouts/placement.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>

#include "mocap_io/input_error.h"
#include "scene_layouts/seeded_uniform.h"

namespace odyssey::scene {

Eigen::Matrix3d yaw_rotation(double degrees) {
  return Eigen::AngleAxisd(degrees * std::numbers::pi / 180, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

std::vector<Eigen::Vector2d> root_track(const TimedClip& clip, int root) {
  KinematicData<double> data(clip.skeleton().kinematics());
  std::vector<Eigen::Vector2d> track(clip.frame_count());
  for (int f = 0; f < clip.frame_count(); ++f) {
    clip.world_pose(f, data);
    track[f] = data.world[root].translation.head<2>();
  }
  return track;
}

namespace {

double actor_clip_end(const SceneActor& actor, double start, const ActorMotion& motion) {
  const double played = motion.played_seconds;
  const double trim_end = std::min(actor.trim_end_s.value_or(played), played);
  return start + std::max(trim_end - actor.trim_start_s, 0.0) / actor.speed;
}

// Actor a's problem, named by the scene file and the JSON path (`key` below actors[a]) where the
// scene came from a file (io::InputError), else by the actor's name (std::invalid_argument).
[[noreturn]] void actor_error(const Scene& scene, std::size_t a, const std::string& key, const std::string& problem) {
  if (!scene.file.empty()) throw io::InputError(scene.file, "actors[" + std::to_string(a) + "]" + key + ": " + problem);
  throw std::invalid_argument("actor '" + scene.actors[a].name + "': " + problem);
}

// Actor a's time map (scene.h) over the shot's frames, checked against its played length.
ClipTiming actor_timing(const Scene& scene, std::size_t a, double start, const ActorMotion& motion, int frames) {
  const SceneActor& actor = scene.actors[a];
  const double played = motion.played_seconds;
  const double trim_end = std::min(actor.trim_end_s.value_or(played), played);
  if (actor.trim_start_s > trim_end) {
    char problem[160];
    std::snprintf(problem, sizeof problem, "the trim starts at %.6g s, after the clip's end at %.6g s", actor.trim_start_s, played);
    actor_error(scene, a, ".trim", problem);
  }
  ClipTiming timing;
  timing.fps = scene.fps;
  timing.frames = frames;
  timing.start = start;
  timing.speed = actor.speed;
  timing.trim_start = actor.trim_start_s;
  timing.trim_end = trim_end;
  timing.loops = motion.loops;
  return timing;
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

// The first frame where two footprints overlap, or -1.
int overlap_frame(const std::vector<Eigen::Vector2d>& a, double radius_a, const std::vector<Eigen::Vector2d>& b,
                  double radius_b) {
  for (std::size_t f = 0; f < a.size(); ++f) {
    if ((a[f] - b[f]).norm() < radius_a + radius_b) return static_cast<int>(f);
  }
  return -1;
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
  // The motion's clip and vertices stay with it (shared); the timed clip only points at them.
  const TimedClip timed(std::shared_ptr<const Clip>(actor.motion, &motion.clip), motion.vertex_animation, motion.keys,
                        actor_timing(scene, a, actor.start_s, motion, frames));
  const int root = motion.root_joint;
  std::vector<RigidTransform<double>> world(timed.joint_count());
  timed.world_pose(0, world);
  const Eigen::Vector3d start_root(world[root].translation.x(), world[root].translation.y(), 0);
  const double start_heading = heading_deg(motion, world);
  Footprint footprint;
  footprint.radius = 0.15 * motion.character.rest_bounds().sizes().z();
  // The root's track as recorded; a placement moves it rigidly with the clip.
  const std::vector<Eigen::Vector2d> recorded = root_track(timed, root);
  // Turning by yaw - start_heading about the start root makes the actor face `yaw` there.
  const auto place = [&](double x, double y, double yaw) {
    actor.clip = timed;
    const Eigen::Matrix3d rotation = yaw_rotation(yaw - start_heading);
    const Eigen::Vector3d shift = Eigen::Vector3d(x, y, 0) - rotation * start_root;
    actor.clip.place(rotation, shift);
    actor.x = x;
    actor.y = y;
    actor.yaw_deg = yaw;
    actor.turn_deg = yaw - start_heading;
    footprint.track.resize(recorded.size());
    for (std::size_t f = 0; f < recorded.size(); ++f) footprint.track[f] = rotation.topLeftCorner<2, 2>() * recorded[f] + shift.head<2>();
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
      actor_error(scene, a, ".placement.region",
                  "no placement in the region keeps it clear of actor '" + scene.actors[other].name + "' (" + std::to_string(kDraws) +
                      " draws); widen the region");
    }
    return footprint;
  }
  if (placement.kind == Placement::Kind::as_recorded) {
    actor.clip = timed;
    actor.x = start_root.x();
    actor.y = start_root.y();
    actor.yaw_deg = start_heading;
    footprint.track = recorded;
  } else {
    place(placement.x, placement.y, placement.yaw_deg);
  }
  if (const int other = first_overlap(footprint, placed, frame); other >= 0) {
    const std::string problem = "actors '" + scene.actors[other].name + "' and '" + spec.name + "' overlap at frame " +
                                std::to_string(frame) + ": their roots come within " +
                                std::to_string(placed[other].radius + footprint.radius) + " m; place them apart or shift them in time";
    if (!scene.file.empty()) throw io::InputError(scene.file, "actors[" + std::to_string(a) + "].placement: " + problem);
    throw std::invalid_argument(problem);
  }
  return footprint;
}

}  // namespace

// Each actor's start on the timeline (drawn from its range where it has one), and the shot's
// frame count: the scene's seconds, or until the last clip ends.
int time_actors(const Scene& scene, std::vector<PlacedActor>& actors) {
  double end = 0;
  for (std::size_t a = 0; a < scene.actors.size(); ++a) {
    const SceneActor& spec = scene.actors[a];
    actors[a].start_s = spec.start_s;
    if (spec.start_range) {
      SeededUniform draw(scene.seed, 3000 + a);
      actors[a].start_s = draw.between(spec.start_range->first, spec.start_range->second);
    }
    end = std::max(end, actor_clip_end(spec, actors[a].start_s, *actors[a].motion));
  }
  const double seconds = scene.seconds.value_or(end);
  // Cameras and moving props are held a pose a frame: a shot of days is a typo, refused before
  // anything is allocated.
  constexpr double kMaxFrames = 10'000'000;
  if (seconds * scene.fps >= kMaxFrames) {
    throw std::invalid_argument("scene: " + std::to_string(seconds) + " s at " + std::to_string(scene.fps) +
                                " fps is more than 10,000,000 frames");
  }
  return static_cast<int>(std::floor(seconds * scene.fps * (1 + 1e-9) + 1e-9)) + 1;
}

void place_actors(const Scene& scene, int frames, std::vector<PlacedActor>& actors) {
  std::vector<Footprint> placed;
  for (std::size_t a = 0; a < scene.actors.size(); ++a) placed.push_back(place_actor(scene, a, frames, placed, actors[a]));
}

}  // namespace odyssey::scene
