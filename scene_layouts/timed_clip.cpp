#include "scene_layouts/timed_clip.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "skeleton/node_animation.h"

namespace odyssey::scene {

namespace {

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

}  // namespace

TimedClip::TimedClip(Clip clip) {
  ClipTiming timing;
  timing.fps = clip.fps;
  timing.frames = clip.frame_count();
  timing.trim_end = clip.duration();
  *this = TimedClip(std::make_shared<const Clip>(std::move(clip)), nullptr, nullptr, timing);
}

TimedClip::TimedClip(std::shared_ptr<const Clip> source, std::shared_ptr<const MeshAnimation> vertices,
                     std::shared_ptr<const NodeAnimationPlayer> keys, const ClipTiming& timing)
    : source_(std::move(source)), vertices_(std::move(vertices)), keys_(std::move(keys)), timing_(timing) {
  if (!source_) throw std::invalid_argument("a timed clip needs a clip");
  source_->validate();
  if (source_->frame_count() < 1) throw std::invalid_argument("the clip has no frames");
  if (!(timing.fps > 0) || !std::isfinite(timing.fps) || timing.frames < 0 || !std::isfinite(timing.start) ||
      !std::isfinite(timing.speed) || !std::isfinite(timing.trim_start) || !std::isfinite(timing.trim_end)) {
    throw std::invalid_argument("a clip's timing needs a positive rate, a frame count and finite times");
  }
  if (vertices_ && !(vertices_->frame_count() >= 1 && std::abs(vertices_->duration() - source_->duration()) <= 1e-9 * (1 + source_->duration()))) {
    throw std::invalid_argument("the vertex animation lasts " + std::to_string(vertices_->duration()) + " s, the clip " +
                                std::to_string(source_->duration()) + " s");
  }
}

void TimedClip::place(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& shift) { placement_ = {rotation, shift}; }

double TimedClip::source_time(int frame) const {
  const double played =
      std::clamp(timing_.trim_start + timing_.speed * (frame / timing_.fps - timing_.start), timing_.trim_start, timing_.trim_end);
  return timing_.loops ? loop_time(played, source_->duration(), timing_.fps) : played;
}

void TimedClip::local_pose(int frame, std::span<RigidTransform<double>> local) const {
  const double u = source_time(frame);
  if (keys_) {
    keys_->local_pose(keys_->animation().start + u, local);
  } else {
    source_->local_pose_at(u, local);
  }
}

void TimedClip::world_pose(int frame, KinematicData<double>& data) const {
  data.base = placement_;
  local_pose(frame, data.local);
  forward_kinematics(source_->skeleton.kinematics(), data);
}

void TimedClip::world_pose(int frame, std::span<RigidTransform<double>> world) const {
  KinematicData<double> data(source_->skeleton.kinematics());
  world_pose(frame, data);
  std::copy(data.world.begin(), data.world.end(), world.begin());
}

void TimedClip::local_vertices(int frame, std::span<float> out) const {
  if (!vertices_) throw std::invalid_argument("the clip has no vertex animation");
  vertices_->sample(source_time(frame), out);
}

Clip TimedClip::stored_clip() const {
  Clip clip;
  clip.skeleton = source_->skeleton;
  clip.fps = timing_.fps;
  clip.translated_joints = source_->translated_joints;
  const int joints = joint_count();
  const std::size_t k = clip.translated_joints.size();
  clip.rotations.resize(std::size_t(timing_.frames) * joints);
  clip.translations.resize(std::size_t(timing_.frames) * k);
  std::vector<RigidTransform<double>> local(joints);
  for (int f = 0; f < timing_.frames; ++f) {
    local_pose(f, local);
    for (int j = 0; j < joints; ++j) clip.rotations[std::size_t(f) * joints + j] = Eigen::Quaterniond(local[j].rotation).normalized();
    for (std::size_t t = 0; t < k; ++t) clip.translations[f * k + t] = local[clip.translated_joints[t]].translation;
  }
  clip.make_signs_continuous();
  move_clip(clip, placement_.rotation, placement_.translation);
  return clip;
}

MeshAnimation TimedClip::stored_vertices() const {
  if (!vertices_) throw std::invalid_argument("the clip has no vertex animation");
  std::vector<double> times(timing_.frames);
  for (int f = 0; f < timing_.frames; ++f) times[f] = source_time(f);
  return vertices_->sampled_at(times, timing_.fps);
}

}  // namespace odyssey::scene
