// Small geometric helpers the retargeting stages share.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <numbers>

#include "skeleton/skeleton.h"

namespace odyssey::retarget {

// The shortest rotation taking unit vector x to unit vector y: normalise(1 + x.y, x cross y) is
// (cos(theta/2), sin(theta/2) n) for the angle theta between them and n = unit(x cross y). At
// theta = pi every axis perpendicular to x is shortest; one is picked. (Eigen's FromTwoVectors
// does the same through an SVD, which is slower and which GCC 12 cannot compile warning-free
// for AVX-512.)
inline Eigen::Quaterniond shortest_rotation(const Eigen::Vector3d& x, const Eigen::Vector3d& y) {
  const double w = 1.0 + x.dot(y);
  if (w < 1e-12) {
    Eigen::Vector3d axis = x.cross(Eigen::Vector3d::UnitX());
    if (axis.squaredNorm() < 1e-6) axis = x.cross(Eigen::Vector3d::UnitY());
    axis.normalize();
    return Eigen::Quaterniond(0.0, axis.x(), axis.y(), axis.z());
  }
  const Eigen::Vector3d v = x.cross(y);
  return Eigen::Quaterniond(w, v.x(), v.y(), v.z()).normalized();
}

// The part of a rotation that turns about world z (swing-twist decomposition: the twist keeps the
// quaternion's w and z). A rotation that tips z upside down has none; identity then.
inline Eigen::Quaterniond heading_of(const Eigen::Quaterniond& q) {
  const double norm = std::hypot(q.w(), q.z());
  if (norm < 1e-9) return Eigen::Quaterniond::Identity();
  return Eigen::Quaterniond(q.w() / norm, 0.0, 0.0, q.z() / norm);
}

// 2 vec(a^-1 b), its sign chosen so that the scalar part of a^-1 b counts as >= 0: for small
// angles the rotation vector that turns a into b (in a's frame), the same for b and -b. Templated
// for Ceres jets (the rest alignment's and the refinement's pose regularisers).
template <class T>
Eigen::Matrix<T, 3, 1> rotation_difference(const Eigen::Quaternion<T>& a, const Eigen::Quaternion<T>& b) {
  const Eigen::Quaternion<T> change = a.conjugate() * b;
  const T sign = change.w() < T(0) ? T(-2) : T(2);
  return sign * change.vec();
}

// The angle between two vectors in degrees; atan2(|a x b|, a . b) stays accurate near 0 and pi,
// where acos does not.
inline double angle_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) * (180.0 / std::numbers::pi);
}

// Whether `ancestor` is `joint` or lies on its way to the root.
inline bool is_ancestor(const Skeleton& skeleton, int ancestor, int joint) {
  for (int j = joint; j >= 0; j = skeleton.parent(j)) {
    if (j == ancestor) return true;
  }
  return false;
}

}  // namespace odyssey::retarget
