#include "skeleton/clip.h"

#include <algorithm>
#include <cmath>
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
  const int target_frames = static_cast<int>(std::floor(duration() * target_fps * (1 + 1e-9) + 1e-9)) + 1;
  std::vector<double> times(target_frames);
  for (int f = 0; f < target_frames; ++f) times[f] = f / target_fps;
  return sampled_at(times, target_fps);
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
    const double source_position = std::clamp(times[f] * fps, 0.0, double(frames - 1));
    const int f0 = std::min(static_cast<int>(std::floor(source_position)), frames - 1);
    const int f1 = std::min(f0 + 1, frames - 1);
    const double alpha = std::clamp(source_position - f0, 0.0, 1.0);
    for (int j = 0; j < joints; ++j) {
      const Eigen::Quaterniond& q0 = rotation(f0, j);
      out.rotations[f * joints + j] = q0.slerp(alpha, sign_aligned(rotation(f1, j), q0)).normalized();
    }
    for (std::size_t t = 0; t < k; ++t) {
      out.translations[f * k + t] = (1 - alpha) * translations[f0 * k + t] + alpha * translations[f1 * k + t];
    }
  }
  return out;
}

}  // namespace odyssey
