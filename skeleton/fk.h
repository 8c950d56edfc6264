// Forward kinematics, split as Pinocchio splits it: a KinematicModel (the tree and its rest pose,
// built once, read-only, shareable between threads), a KinematicData<T> (the transforms one
// evaluation reads and writes, owned by the caller, one per thread and scalar type), and one
// algorithm, forward_kinematics(model, data[, joints]). It is templated on the scalar so that
// Ceres jets run through the same code as doubles, and it never allocates.
//
// Joint j hangs from parents[j] (-1: from data.base) and is placed by its local transform:
//   world[j] = world[parents[j]] * local[j]
// except that a joint whose rotation is held in world (rotation_in_world[j]) rides on its
// parent for its position only:
//   world[j].rotation = local[j].rotation,   world[j].translation = world[parents[j]] * local[j].translation
// (the refinement places an IK foot at the end of its shin that way while its rotation is driven
// on its own). A skeleton's parents precede their children; a tree that hangs joints from anchors
// elsewhere in the skeleton need not, and lists in `order` every joint after its parent.
//
// Rotations are 3x3 matrices by default (cheap to apply; what skinning and the exporters read)
// or unit quaternions (Eigen::Quaternion<T>): composing two costs 16 multiplications instead of
// 27, which is what counts on the Ceres jets of the rest alignment and the refinement, whose
// unknowns are quaternions already. The algorithm is the same for both.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cassert>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace odyssey {

namespace kinematics_detail {

template <class Rotation, class U>
struct WithScalar;
template <class T, class U>
struct WithScalar<Eigen::Matrix<T, 3, 3>, U> {
  using type = Eigen::Matrix<U, 3, 3>;
};
template <class T, class U>
struct WithScalar<Eigen::Quaternion<T>, U> {
  using type = Eigen::Quaternion<U>;
};

[[noreturn]] inline void size_mismatch(std::size_t data, std::size_t model) {
  throw std::invalid_argument("forward_kinematics: data for " + std::to_string(data) + " joints, model of " +
                              std::to_string(model));
}

// world = parent * local, or with local's rotation as it is (above). Matrix products are
// written straight into `world` (noalias); quaternions have no such form.
template <class Transform>
void place(const Transform& parent, const Transform& local, bool rotation_in_world, Transform& world) {
  if (rotation_in_world) {
    world.rotation = local.rotation;
  } else if constexpr (Transform::kQuaternion) {
    world.rotation = parent.rotation * local.rotation;
  } else {
    world.rotation.noalias() = parent.rotation * local.rotation;
  }
  if constexpr (Transform::kQuaternion) {
    world.translation = parent.rotation * local.translation;
  } else {
    world.translation.noalias() = parent.rotation * local.translation;
  }
  world.translation += parent.translation;
}

}  // namespace kinematics_detail

// x -> rotation * x + translation. Plain data so arrays of it can be filled and reused.
template <class T, class Rotation = Eigen::Matrix<T, 3, 3>>
struct RigidTransform {
  static constexpr bool kQuaternion = std::is_same_v<Rotation, Eigen::Quaternion<T>>;
  static_assert(kQuaternion || std::is_same_v<Rotation, Eigen::Matrix<T, 3, 3>>, "a rotation is a 3x3 matrix or a quaternion");

  Rotation rotation = Rotation::Identity();
  Eigen::Matrix<T, 3, 1> translation = Eigen::Matrix<T, 3, 1>::Zero();

  RigidTransform operator*(const RigidTransform& child) const {
    return {rotation * child.rotation, rotation * child.translation + translation};
  }
  Eigen::Matrix<T, 3, 1> operator*(const Eigen::Matrix<T, 3, 1>& point) const { return rotation * point + translation; }
  RigidTransform inverse() const {
    Rotation inverse_rotation;
    if constexpr (kQuaternion) {
      inverse_rotation = rotation.conjugate();
    } else {
      inverse_rotation = rotation.transpose();
    }
    return {inverse_rotation, -(inverse_rotation * translation)};
  }
  template <class U>
  RigidTransform<U, typename kinematics_detail::WithScalar<Rotation, U>::type> cast() const {
    return {rotation.template cast<U>(), translation.template cast<U>()};
  }
};

template <class T>
using QuaternionTransform = RigidTransform<T, Eigen::Quaternion<T>>;

struct KinematicModel {
  std::vector<int> parents;                     // per joint; -1: hangs from the base
  std::vector<std::uint8_t> rotation_in_world;  // per joint; 1: local rotation is the world rotation
  std::vector<int> order;                       // every joint once, after its parent
  std::vector<RigidTransform<double>> rest;     // local transforms a new KinematicData starts from

  KinematicModel() = default;
  // An empty `rest` is identities, an empty `order` 0, 1, ..., n-1 and an empty
  // `rotation_in_world` all 0. Throws std::invalid_argument when the sizes differ (naming both),
  // a parent is out of range, or `order` is not every joint once with each after its parent.
  KinematicModel(std::vector<int> parents, std::vector<RigidTransform<double>> rest, std::vector<int> order = {},
                 std::vector<std::uint8_t> rotation_in_world = {});

  int joint_count() const { return static_cast<int>(parents.size()); }
};

// What forward kinematics reads (base, local) and writes (world), per joint of a model.
template <class T, class Rotation = Eigen::Matrix<T, 3, 3>>
struct KinematicData {
  using Transform = RigidTransform<T, Rotation>;
  Transform base;                // the frame the roots hang from
  std::vector<Transform> local;  // from the model's rest until the caller poses it
  std::vector<Transform> world;

  KinematicData() = default;
  explicit KinematicData(const KinematicModel& model) : local(model.rest.size()), world(model.rest.size()) {
    for (std::size_t j = 0; j < local.size(); ++j) {
      local[j] = {Rotation(model.rest[j].rotation.template cast<T>()), model.rest[j].translation.template cast<T>()};
    }
  }
};

template <class T>
using QuaternionKinematicData = KinematicData<T, Eigen::Quaternion<T>>;

// World transforms of `joints`, in that order. Each joint's parent must come earlier in the list
// or already hold its world transform in `data` (a limb's fixed part, computed once per frame,
// while the joints below what a solver moves are recomputed per evaluation).
template <class T, class Rotation>
void forward_kinematics(const KinematicModel& model, KinematicData<T, Rotation>& data, std::span<const int> joints) {
  if (data.local.size() != model.parents.size() || data.world.size() != model.parents.size()) {
    kinematics_detail::size_mismatch(data.local.size() != model.parents.size() ? data.local.size() : data.world.size(),
                                     model.parents.size());
  }
  for (const int j : joints) {
    assert(j >= 0 && j < model.joint_count());
    const int parent = model.parents[j];
    kinematics_detail::place(parent < 0 ? data.base : data.world[parent], data.local[j], model.rotation_in_world[j] != 0,
                             data.world[j]);
  }
}

// World transforms of every joint.
template <class T, class Rotation>
void forward_kinematics(const KinematicModel& model, KinematicData<T, Rotation>& data) {
  forward_kinematics(model, data, std::span<const int>(model.order));
}

// The same over bare arrays, for a tree whose parents precede their children and that has no
// KinematicModel (a body model's joints, a test's random pose).
template <class T>
void forward_kinematics(std::span<const int> parents, std::span<const RigidTransform<T>> local,
                        std::span<RigidTransform<T>> world, const RigidTransform<T>& base = {}) {
  if (local.size() != parents.size() || world.size() != parents.size()) {
    kinematics_detail::size_mismatch(local.size() != parents.size() ? local.size() : world.size(), parents.size());
  }
  for (std::size_t i = 0; i < parents.size(); ++i) {
    const int parent = parents[i];
    assert(parent < static_cast<int>(i));
    kinematics_detail::place(parent < 0 ? base : world[parent], local[i], false, world[i]);
  }
}

}  // namespace odyssey
