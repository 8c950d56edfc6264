#include "skeleton/clip.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "skeleton/rotation.h"

namespace odyssey {

int Clip::frame_count() const {
  return joint_count() == 0 ? 0 : static_cast<int>(rotations.size() / joint_count());
}

void Clip::validate() const {
  const std::size_t joints = joint_count();
  if (joints == 0) throw std::invalid_argument("clip has no joints");
  if (!(fps > 0) || !std::isfinite(fps)) throw std::invalid_argument("frame rate " + std::to_string(fps) + " is not positive");
  if (rotations.size() % joints != 0) throw std::invalid_argument("rotation count is not a multiple of the joint count");
  const std::size_t frames = rotations.size() / joints;
  if (translations.size() != frames * translated_joints.size()) {
    throw std::invalid_argument("clip has " + std::to_string(translations.size()) + " translations, expected " +
                                std::to_string(frames * translated_joints.size()));
  }
  for (int joint : translated_joints) {
    if (joint < 0 || joint >= static_cast<int>(joints)) throw std::invalid_argument("translated joint index out of range");
  }
  for (std::size_t i = 0; i < rotations.size(); ++i) {
    if (!rotations[i].coeffs().allFinite() || rotations[i].squaredNorm() < 1e-12) {
      throw std::invalid_argument("frame " + std::to_string(i / joints) + ", joint '" + skeleton.name(int(i % joints)) +
                                  "': rotation is not finite");
    }
  }
  for (std::size_t i = 0; i < translations.size(); ++i) {
    if (!translations[i].allFinite()) {
      const std::size_t k = translations.size() / std::max<std::size_t>(frames, 1);
      throw std::invalid_argument("frame " + std::to_string(i / k) + ", joint '" + skeleton.name(translated_joints[i % k]) +
                                  "': translation is not finite");
    }
  }
}

void Clip::make_signs_continuous() {
  const int joints = joint_count();
  for (int f = 0; f < frame_count(); ++f) {
    Eigen::Quaterniond* now = &rotations[std::size_t(f) * joints];
    for (int j = 0; j < joints; ++j) now[j] = sign_aligned(now[j], f > 0 ? now[j - joints] : Eigen::Quaterniond::Identity());
  }
}

namespace {

template <class Transform>
void local_pose_of(const Clip& clip, int frame, std::span<Transform> local) {
  const int joints = clip.joint_count();
  const auto& offsets = clip.skeleton.rest_offsets();
  const Eigen::Quaterniond* frame_rotations = &clip.rotations[std::size_t(frame) * joints];
  for (int j = 0; j < joints; ++j) {
    if constexpr (Transform::kQuaternion) {
      local[j].rotation = frame_rotations[j];
    } else {
      local[j].rotation = frame_rotations[j].toRotationMatrix();
    }
    local[j].translation = offsets[j];
  }
  const std::size_t k = clip.translated_joints.size();
  for (std::size_t t = 0; t < k; ++t) local[clip.translated_joints[t]].translation = clip.translations[frame * k + t];
}

}  // namespace

void Clip::local_pose(int frame, std::span<RigidTransform<double>> local) const { local_pose_of(*this, frame, local); }
void Clip::local_pose(int frame, std::span<QuaternionTransform<double>> local) const { local_pose_of(*this, frame, local); }

void Clip::world_pose(int frame, KinematicData<double>& data) const {
  local_pose(frame, data.local);
  forward_kinematics(skeleton.kinematics(), data);
}

void Clip::world_pose(int frame, QuaternionKinematicData<double>& data) const {
  local_pose(frame, data.local);
  forward_kinematics(skeleton.kinematics(), data);
}

void Clip::world_pose(int frame, std::span<RigidTransform<double>> world) const {
  KinematicData<double> data(skeleton.kinematics());
  world_pose(frame, data);
  std::copy(data.world.begin(), data.world.end(), world.begin());
}

Clip Clip::resampled(double target_fps) const {
  if (!(target_fps > 0) || !std::isfinite(target_fps)) {
    throw std::invalid_argument("target frame rate " + std::to_string(target_fps) + " is not positive");
  }
  if (frame_count() == 0) return sampled_at({}, target_fps);
  // A 1e-9 relative slack keeps the final frame when duration * fps is an integer up to rounding.
  const double frames = std::floor(duration() * target_fps * (1 + 1e-9) + 1e-9) + 1;
  // Frame indices are ints: a count past that is refused before anything is allocated (callers cap
  // far lower, io::require_frames_within_cap).
  if (!(frames < double(std::numeric_limits<int>::max()) / std::max(joint_count(), 1))) {
    throw std::invalid_argument("resampling " + std::to_string(duration()) + " s at " + std::to_string(target_fps) +
                                " fps makes more frames than a clip holds");
  }
  const int target_frames = static_cast<int>(frames);
  std::vector<double> times(target_frames);
  for (int f = 0; f < target_frames; ++f) times[f] = f / target_fps;
  return sampled_at(times, target_fps);
}

namespace {

// Where time t falls between the frames: frames f0 and f1 = f0 + 1 (or f0 at the end), weight alpha
// on f1. The source position is t fps, clamped to [0, frames - 1].
struct Bracket {
  int f0 = 0, f1 = 0;
  double alpha = 0;
};

Bracket bracket(double time, double fps, int frames) {
  double position = std::clamp(time * fps, 0.0, double(frames - 1));
  // A time on a frame up to rounding (k / fps * fps) is that frame, exactly.
  if (const double nearest = std::round(position); std::abs(position - nearest) < 1e-9) position = nearest;
  Bracket b;
  b.f0 = std::min(static_cast<int>(std::floor(position)), frames - 1);
  b.f1 = std::min(b.f0 + 1, frames - 1);
  b.alpha = std::clamp(position - b.f0, 0.0, 1.0);
  return b;
}

// Joint j's rotation and translated joint t's translation at a bracket: rotations slerped the short
// way, translations linearly.
Eigen::Quaterniond rotation_at(const Clip& clip, const Bracket& b, int j) {
  const Eigen::Quaterniond& q0 = clip.rotation(b.f0, j);
  return q0.slerp(b.alpha, sign_aligned(clip.rotation(b.f1, j), q0)).normalized();
}

Eigen::Vector3d translation_at(const Clip& clip, const Bracket& b, std::size_t t) {
  const std::size_t k = clip.translated_joints.size();
  return (1 - b.alpha) * clip.translations[b.f0 * k + t] + b.alpha * clip.translations[b.f1 * k + t];
}

Bracket checked_bracket(const Clip& clip, double time) {
  if (!std::isfinite(time)) throw std::invalid_argument("sample time " + std::to_string(time) + " is not finite");
  if (clip.frame_count() == 0) throw std::invalid_argument("the clip has no frames to sample");
  return bracket(time, clip.fps, clip.frame_count());
}

}  // namespace

void Clip::local_pose_at(double time, std::span<RigidTransform<double>> local) const {
  const Bracket b = checked_bracket(*this, time);
  const auto& offsets = skeleton.rest_offsets();
  for (int j = 0; j < joint_count(); ++j) local[j] = {rotation_at(*this, b, j).toRotationMatrix(), offsets[j]};
  for (std::size_t t = 0; t < translated_joints.size(); ++t) local[translated_joints[t]].translation = translation_at(*this, b, t);
}

Clip Clip::sampled_at(std::span<const double> times, double target_fps) const {
  if (!(target_fps > 0) || !std::isfinite(target_fps)) {
    throw std::invalid_argument("target frame rate " + std::to_string(target_fps) + " is not positive");
  }
  Clip out;
  out.skeleton = skeleton;
  out.fps = target_fps;
  out.translated_joints = translated_joints;
  const int frames = frame_count();
  if (frames == 0) return out;
  const int joints = joint_count();
  const std::size_t k = translated_joints.size();
  out.rotations.resize(times.size() * joints);
  out.translations.resize(times.size() * k);
  for (std::size_t f = 0; f < times.size(); ++f) {
    if (!std::isfinite(times[f])) throw std::invalid_argument("sample time " + std::to_string(f) + " is not finite");
    const Bracket b = bracket(times[f], fps, frames);
    for (int j = 0; j < joints; ++j) out.rotations[f * joints + j] = rotation_at(*this, b, j);
    for (std::size_t t = 0; t < k; ++t) out.translations[f * k + t] = translation_at(*this, b, t);
  }
  return out;
}

}  // namespace odyssey
