// A clip: a skeleton, a fixed frame rate, and per frame the local rotation of every joint plus
// the local translation of the joints whose position is animated (the root, and any BVH joint
// with position channels). A frame's local rotation replaces the joint's rest rotation; joints
// without animated translation keep their rest offset.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <span>
#include <vector>

#include "skeleton/fk.h"
#include "skeleton/skeleton.h"

namespace odyssey {

struct Clip {
  Skeleton skeleton;
  double fps = 30.0;
  // rotations[frame * joint_count + joint]
  std::vector<Eigen::Quaterniond> rotations;
  // Joints whose local translation is animated, and their translations[frame * size + k].
  std::vector<int> translated_joints;
  std::vector<Eigen::Vector3d> translations;

  int joint_count() const { return skeleton.joint_count(); }
  int frame_count() const;
  double duration() const { return frame_count() > 0 ? (frame_count() - 1) / fps : 0.0; }
  const Eigen::Quaterniond& rotation(int frame, int joint) const { return rotations[std::size_t(frame) * joint_count() + joint]; }

  // Throws std::invalid_argument on inconsistent sizes, a non-positive frame rate, or a
  // non-finite value (naming the first bad frame and joint).
  void validate() const;

  // Flips quaternion signs (q and -q are the same rotation) so that each joint's track is
  // continuous: every frame's rotation is sign_aligned (rotation.h) with the previous frame's, the
  // first frame's with the identity (w >= 0).
  void make_signs_continuous();

  // Local transforms of one frame (rest offsets where not animated), rotations as matrices or as
  // the clip's quaternions.
  void local_pose(int frame, std::span<RigidTransform<double>> local) const;
  void local_pose(int frame, std::span<QuaternionTransform<double>> local) const;
  // One frame posed on skeleton.kinematics(): data.local from local_pose, data.world by forward
  // kinematics from data.base (kept as the caller set it: a levelling, say). Allocates nothing.
  void world_pose(int frame, KinematicData<double>& data) const;
  void world_pose(int frame, QuaternionKinematicData<double>& data) const;
  // World transforms of one frame (roots hung from the origin).
  void world_pose(int frame, std::span<RigidTransform<double>> world) const;

  // The local transforms at any time (seconds from the first frame, clamped to [0, duration()]),
  // interpolated between the two neighbouring frames as sampled_at does. Allocates nothing. Throws
  // std::invalid_argument for a non-finite time or a clip without frames.
  void local_pose_at(double time, std::span<RigidTransform<double>> local) const;

  // The clip sampled at `target_fps` over the same duration: frame k sits at time k / target_fps;
  // rotations are slerped (short way) and translations interpolated linearly between the two
  // neighbouring source frames. The last frame is the last time <= the source duration.
  Clip resampled(double target_fps) const;
  // The clip at any times (seconds from its first frame, clamped to [0, duration()]): frame k of
  // the result, at `target_fps`, is the pose at times[k], interpolated as resampled() does.
  // Throws std::invalid_argument for a non-finite time or a non-positive rate.
  Clip sampled_at(std::span<const double> times, double target_fps) const;
};

// Joint `joint`'s local rotation in a clip frame from world transforms (the inverse of
// Clip::world_pose): W(parent)^-1 W(joint), normalised; a root's (parent < 0) is its world rotation.
inline Eigen::Quaterniond local_rotation_from_world(std::span<const QuaternionTransform<double>> world, int joint, int parent) {
  const Eigen::Quaterniond& rotation = world[joint].rotation;
  return (parent < 0 ? rotation : world[parent].rotation.conjugate() * rotation).normalized();
}

// Its local translation likewise: W(parent)^-1 (P(joint) - P(parent)); a root's is its position.
inline Eigen::Vector3d local_translation_from_world(std::span<const QuaternionTransform<double>> world, int joint, int parent) {
  if (parent < 0) return world[joint].translation;
  return world[parent].rotation.conjugate() * (world[joint].translation - world[parent].translation);
}

}  // namespace odyssey
