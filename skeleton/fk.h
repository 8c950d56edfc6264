// Forward kinematics over a skeleton whose parents precede their children: one flat loop,
//   world[i] = world[parent[i]] * local[i]   (world[root] = base * local[root]),
// templated on the scalar so the same code runs on doubles and on Ceres jets. Callers own every
// buffer; nothing here allocates.
#pragma once

#include <Eigen/Core>
#include <cassert>
#include <span>

namespace odyssey {

// x -> rotation * x + translation. Plain data so arrays of it can be filled and reused.
template <class T>
struct RigidTransform {
  Eigen::Matrix<T, 3, 3> rotation = Eigen::Matrix<T, 3, 3>::Identity();
  Eigen::Matrix<T, 3, 1> translation = Eigen::Matrix<T, 3, 1>::Zero();

  RigidTransform operator*(const RigidTransform& child) const {
    return {rotation * child.rotation, rotation * child.translation + translation};
  }
  Eigen::Matrix<T, 3, 1> operator*(const Eigen::Matrix<T, 3, 1>& point) const { return rotation * point + translation; }
  RigidTransform inverse() const {
    const Eigen::Matrix<T, 3, 3> rt = rotation.transpose();
    return {rt, -(rt * translation)};
  }
};

template <class T>
void forward_kinematics(std::span<const int> parents, std::span<const RigidTransform<T>> local,
                        std::span<RigidTransform<T>> world, const RigidTransform<T>& base = {}) {
  assert(local.size() == parents.size() && world.size() == parents.size());
  for (std::size_t i = 0; i < parents.size(); ++i) {
    const int parent = parents[i];
    const RigidTransform<T>& frame = parent < 0 ? base : world[parent];
    world[i].rotation.noalias() = frame.rotation * local[i].rotation;
    world[i].translation.noalias() = frame.rotation * local[i].translation;
    world[i].translation += frame.translation;
  }
}

}  // namespace odyssey
