// The one place where the two math libraries meet: Eigen (double) carries kinematics, rotations and
// everything Ceres touches; GLM (float32, column-major like glTF) carries the skinning kernels and
// the renderer boundary. Both store matrices column-major, so element (row r, column c) is
// eigen(r, c) and glm[c][r]. Conversions to GLM round double to the nearest float.
#pragma once

#include <Eigen/Core>
#include <glm/glm.hpp>

namespace odyssey::skinning {

// The affine map x -> A x + t given as the 3x4 block [A | t], as a 4x4 with bottom row (0, 0, 0, 1).
inline glm::mat4 to_glm_affine(const Eigen::Matrix<double, 3, 4>& affine) {
  glm::mat4 out(1.0f);
  for (int c = 0; c < 4; ++c) {
    for (int r = 0; r < 3; ++r) out[c][r] = static_cast<float>(affine(r, c));
  }
  return out;
}

// A point in homogeneous coordinates (w = 1: translations apply) and a direction (w = 0: they do not).
inline glm::vec4 to_glm_point(const Eigen::Vector3f& point) { return {point.x(), point.y(), point.z(), 1.0f}; }
inline glm::vec4 to_glm_direction(const Eigen::Vector3f& direction) {
  return {direction.x(), direction.y(), direction.z(), 0.0f};
}

}  // namespace odyssey::skinning
