#include "scene_layouts/actor_source.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <stdexcept>

#include "mocap_io/anime_file.h"
#include "mocap_io/gltf_character.h"
#include "mocap_io/input_error.h"
#include "retarget/canonical.h"
#include "scene_layouts/camera_rigs.h"
#include "skeleton/node_animation.h"
#include "skeleton/rotation.h"

namespace odyssey::scene {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

void check_scale(double scale, const std::string& path) {
  if (!(scale > 0) || !std::isfinite(scale)) throw io::InputError(path, "the scale must be a positive number");
}

// Lengths times s: joint offsets and clip translations scale; a vertex bound by W inverse_bind
// stays put relative to its joint only if inverse_bind's output scales too:
//   s (R (IB v) + t) = R (diag(s, s, s, 1) IB v) + s t.
void scale_character_and_clip(Character& character, Clip& clip, double s) {
  if (s == 1) return;
  const Skeleton& skeleton = character.skeleton;
  std::vector<Eigen::Vector3d> offsets = skeleton.rest_offsets();
  for (Eigen::Vector3d& offset : offsets) offset *= s;
  character.skeleton = Skeleton(skeleton.names(), skeleton.parents(), std::move(offsets), skeleton.rest_rotations());
  const Eigen::Matrix4d scaling = Eigen::Vector4d(s, s, s, 1).asDiagonal();
  for (CharacterMesh& mesh : character.meshes) {
    for (Eigen::Matrix4d& inverse_bind : mesh.inverse_bind) inverse_bind = scaling * inverse_bind;
  }
  for (double& joint_scale : character.source_scale_of_joint) joint_scale *= s;
  clip.skeleton = character.skeleton;
  for (Eigen::Vector3d& translation : clip.translations) translation *= s;
}

std::vector<int> joint_depths(const Skeleton& skeleton) {
  std::vector<int> depth(skeleton.joint_count(), 0);
  for (int j = 0; j < skeleton.joint_count(); ++j) depth[j] = skeleton.parent(j) < 0 ? 0 : depth[skeleton.parent(j)] + 1;
  return depth;
}

// The topmost joint whose offset the clip moves, else joint 0.
int moving_root(const Clip& clip) {
  const std::vector<int> depth = joint_depths(clip.skeleton);
  int root = -1;
  for (const int j : clip.translated_joints) {
    if (root < 0 || depth[j] < depth[root] || (depth[j] == depth[root] && j < root)) root = j;
  }
  return root < 0 ? 0 : root;
}

// The glTF front (+Z) in the world, flattened.
Eigen::Vector3d gltf_front() { return (y_up_to_z_up() * Eigen::Vector3d::UnitZ()).normalized(); }

std::string length_text(const PlaybackLength& length) {
  if (length.loops) return std::to_string(*length.loops) + " loop" + (*length.loops == 1 ? "" : "s");
  if (length.seconds) {
    char text[64];
    std::snprintf(text, sizeof text, "%.6g s, looping", *length.seconds);
    return text;
  }
  return "once";
}

// The played length of a source of `duration` s (node_animation.h's played_seconds), and whether it
// wraps. A pass is stored whole, so it too must stay within the frame cap.
void set_playback(ActorMotion& motion, const std::string& who, double duration, double fps, const PlaybackLength& length) {
  constexpr double kMaxFrames = 10'000'000;
  if (duration * fps >= kMaxFrames) {
    throw std::invalid_argument(who + "one pass of " + std::to_string(duration) + " s at " + std::to_string(fps) +
                                " fps is more than 10000000 frames");
  }
  const double played = played_seconds(who, duration, fps, length.loops, length.seconds, kMaxFrames);
  // Key times are float32 (17 / 24 s is a little short): a length within 1e-4 of a frame period of
  // a whole number of frames is that many, so its last frame is played (loop_time shows the end).
  const double whole = std::round(played * fps);
  motion.played_seconds = std::abs(played * fps - whole) < 1e-4 ? whole / fps : played;
  motion.loops = length.loops.value_or(1) > 1 || length.seconds.has_value();
}

}  // namespace

const char* actor_source_name(ActorSourceKind kind) {
  switch (kind) {
    case ActorSourceKind::motion:
      return "motion";
    case ActorSourceKind::animation:
      return "animation";
    case ActorSourceKind::anime:
      return "anime";
  }
  return "?";
}

ActorMotion play_character_animation(const AnimationRequest& request, LoadCache* cache) {
  const auto start = Clock::now();
  const std::string& path = request.character_path;
  check_scale(request.scale, path);
  ActorMotion motion;
  motion.kind = ActorSourceKind::animation;
  motion.source_path = path;
  motion.character = cache ? *cache->character(path) : io::load_character(path);
  const NodeAnimation animation = io::load_gltf_animation(path, request.animation);
  motion.warnings = animation.warnings;
  // One pass, first key to last, at the request's rate rounded up to n frame periods a pass, so
  // that a frame falls on the last key; the shot evaluates the keys themselves (motion.keys).
  const double duration = animation.duration();
  try {
    set_playback(motion, "animation '" + request.animation + "': ", duration, request.fps, request.length);
    const int periods = duration > 0 ? std::max(1, static_cast<int>(std::ceil(duration * request.fps - 1e-4))) : 0;
    std::vector<double> times(periods + 1);
    for (int k = 0; k <= periods; ++k) times[k] = animation.start + (k == periods ? duration : k * (duration / periods));
    motion.clip = play_node_animation(motion.character, animation, times, periods > 0 ? periods / duration : request.fps);
    motion.keys = std::make_shared<const NodeAnimationPlayer>(motion.character, animation, request.scale);
  } catch (const std::invalid_argument& error) {
    throw io::InputError(path, error.what());
  }
  scale_character_and_clip(motion.character, motion.clip, request.scale);
  motion.root_joint = moving_root(motion.clip);
  motion.rest_facing = gltf_front();
  char line[512];
  std::snprintf(line, sizeof line, "animation '%s' (%.6g s, %zu channels) played %s: %.6g s from a pass of %d frames at %.6g fps",
                request.animation.c_str(), duration, animation.channels.size(), length_text(request.length).c_str(),
                motion.played_seconds, motion.clip.frame_count(), motion.clip.fps);
  motion.description = line;
  motion.seconds_to_build = seconds_since(start);
  return motion;
}

ActorMotion play_anime(const AnimeRequest& request) {
  const auto start = Clock::now();
  const std::string& path = request.path;
  check_scale(request.scale, path);
  if (!(request.source_fps > 0) || !std::isfinite(request.source_fps)) {
    throw io::InputError(path, "the source frame rate must be positive");
  }
  io::AnimeFile file = io::read_anime_file(path);
  MeshAnimation source = std::move(file.frames);
  source.fps = request.source_fps;
  // To the world: Y up turned to Z up, then scaled.
  const Eigen::Matrix3f to_world =
      (request.up_z ? Eigen::Matrix3d::Identity() : y_up_to_z_up()).cast<float>() * static_cast<float>(request.scale);
  for (std::size_t i = 0; i < source.positions.size(); i += 3) {
    const Eigen::Vector3f p = to_world * Eigen::Vector3f(source.positions[i], source.positions[i + 1], source.positions[i + 2]);
    if (!p.allFinite()) throw io::InputError(path, "a vertex overflows once scaled");
    source.positions[i] = p.x();
    source.positions[i + 1] = p.y();
    source.positions[i + 2] = p.z();
  }

  // Kept at the file's rate: the shot interpolates it at its own times (timed_clip.h).
  ActorMotion motion;
  try {
    set_playback(motion, "", source.duration(), request.fps, request.length);  // the error names the file
  } catch (const std::invalid_argument& error) {
    throw io::InputError(path, error.what());
  }

  // The joint follows the horizontal centroid; vertices are kept relative to it.
  const int frames = source.frame_count();
  const std::size_t vertices = source.vertex_count;
  motion.kind = ActorSourceKind::anime;
  motion.source_path = path;
  Clip& clip = motion.clip;
  clip.fps = request.source_fps;
  clip.rotations.assign(frames, Eigen::Quaterniond::Identity());
  clip.translated_joints = {0};
  clip.translations.resize(frames);
  for (int f = 0; f < frames; ++f) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    float* p = source.positions.data() + std::size_t(f) * vertices * 3;
    for (std::size_t v = 0; v < vertices; ++v) sum += Eigen::Vector3d(p[3 * v], p[3 * v + 1], p[3 * v + 2]);
    const Eigen::Vector3d centroid(sum.x() / double(vertices), sum.y() / double(vertices), 0.0);
    clip.translations[f] = centroid;
    for (std::size_t v = 0; v < vertices; ++v) {
      p[3 * v] = static_cast<float>(p[3 * v] - centroid.x());
      p[3 * v + 1] = static_cast<float>(p[3 * v + 1] - centroid.y());
    }
  }
  Character& character = motion.character;
  character.name = std::filesystem::path(path).stem().string();
  character.skeleton = Skeleton({"root"}, {-1}, {clip.translations[0]}, {Eigen::Quaterniond::Identity()});
  clip.skeleton = character.skeleton;
  character.source_node_of_joint = {0};
  character.source_scale_of_joint = {1};
  CharacterMesh mesh;
  mesh.name = character.name;
  const std::span<const float> rest = source.frame(0);
  for (std::size_t v = 0; v < vertices; ++v) mesh.positions.emplace_back(rest[3 * v], rest[3 * v + 1], rest[3 * v + 2]);
  mesh.triangles = std::move(file.triangles);
  mesh.skin_joints = {0};
  mesh.inverse_bind = {Eigen::Matrix4d::Identity()};
  mesh.influence_slots.assign(vertices, {0, 0, 0, 0});
  mesh.influence_weights.assign(vertices, {1, 0, 0, 0});
  character.meshes.push_back(std::move(mesh));
  motion.vertex_animation = std::make_shared<const MeshAnimation>(std::move(source));
  motion.root_joint = 0;
  motion.rest_facing = request.up_z ? Eigen::Vector3d::UnitX() : gltf_front();
  char line[512];
  std::snprintf(line, sizeof line, "%d frames of %zu vertices, %zu triangles at %.6g fps, played %s: %.6g s", frames, vertices,
                character.meshes[0].triangles.size() / 3, request.source_fps, length_text(request.length).c_str(),
                motion.played_seconds);
  motion.description = line;
  motion.seconds_to_build = seconds_since(start);
  return motion;
}

TimedClip played_clip(const std::shared_ptr<const ActorMotion>& motion, double fps) {
  ClipTiming timing;
  timing.fps = fps;
  // The 1e-9 relative slack keeps the last frame when played_seconds * fps is whole up to rounding.
  timing.frames = static_cast<int>(std::floor(motion->played_seconds * fps * (1 + 1e-9) + 1e-9)) + 1;
  timing.trim_end = motion->played_seconds;
  timing.loops = motion->loops;
  return TimedClip(std::shared_ptr<const Clip>(motion, &motion->clip), motion->vertex_animation, motion->keys, timing);
}

ActorMotion retargeted_motion(std::shared_ptr<const RetargetedActor> retargeted) {
  ActorMotion motion;
  motion.kind = ActorSourceKind::motion;
  motion.character = retargeted->character;
  motion.clip = retargeted->clip();
  motion.played_seconds = motion.clip.duration();
  motion.source_path = retargeted->request.character_path;
  const retarget::BoneMap& map = retargeted->target_map;
  const Skeleton& skeleton = motion.character.skeleton;
  motion.root_joint = map.mapped(retarget::canonical::pelvis) ? map.joints[retarget::canonical::pelvis] : 0;
  motion.rest_facing = rest_facing(skeleton, map.joints[retarget::canonical::left_hip], map.joints[retarget::canonical::right_hip]);
  motion.head_joint = map.mapped(retarget::canonical::head) ? map.joints[retarget::canonical::head] : -1;
  for (const int canonical : {retarget::canonical::left_wrist, retarget::canonical::right_wrist}) {
    if (retargeted->full_target_map.mapped(canonical)) motion.wrists.push_back(retargeted->full_target_map.joints[canonical]);
  }
  motion.description = retargeted->motion_description;
  motion.retargeted = std::move(retargeted);
  return motion;
}

nlohmann::ordered_json actor_motion_report_json(const ActorMotion& motion) {
  if (motion.retargeted) return actor_report_json(*motion.retargeted);
  nlohmann::ordered_json json;
  json["source"] = actor_source_name(motion.kind);
  json["inputs"] = {{motion.kind == ActorSourceKind::anime ? "anime" : "character", motion.source_path}};
  json["played"] = motion.description;
  json["frames"] = motion.clip.frame_count();
  json["fps"] = motion.clip.fps;
  json["played_s"] = motion.played_seconds;
  json["loops"] = motion.loops;
  json["root_joint"] = motion.character.skeleton.name(motion.root_joint);
  json["warnings"] = motion.warnings;
  json["timings_s"] = {{"build", motion.seconds_to_build}};
  return json;
}

}  // namespace odyssey::scene
