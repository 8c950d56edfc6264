// Rotation conversions. Internally rotations are unit quaternions (Eigen, Hamilton convention,
// active, acting on column vectors); axis-angle appears at SMPL boundaries and Euler angles at
// BVH boundaries. Every conversion is templated on the scalar where Ceres may differentiate it,
// and is numerically safe near 0 and near pi.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <optional>
#include <string_view>

namespace odyssey {

// Rodrigues' formula for an axis-angle vector r = theta * axis:
//   R = I + a [r]x + b [r]x^2,  a = sin(theta)/theta,  b = (1 - cos(theta))/theta^2.
// b is evaluated as 2 sin^2(theta/2)/theta^2, which keeps full relative precision near 0 and
// near pi (1 - cos loses digits as theta -> 0). Below theta^2 = 1e-12 (theta < 1e-6) the
// Taylor series a = 1 - theta^2/6, b = 1/2 - theta^2/24 is exact to double precision (the next
// terms are theta^4/120 < 1e-24) and, unlike the closed form, differentiable at r = 0 for
// Ceres jets. Angles beyond 2 pi need no reduction: sin and cos are periodic.
template <class T>
Eigen::Matrix<T, 3, 3> rodrigues(const Eigen::Matrix<T, 3, 1>& r) {
  using std::sin;
  using std::sqrt;
  const T theta_sq = r.squaredNorm();
  T a, b;
  if (theta_sq < T(1e-12)) {
    a = T(1) - theta_sq / T(6);
    b = T(0.5) - theta_sq / T(24);
  } else {
    const T theta = sqrt(theta_sq);
    const T half_sin = sin(theta / T(2));
    a = sin(theta) / theta;
    b = T(2) * half_sin * half_sin / theta_sq;
  }
  Eigen::Matrix<T, 3, 3> k;
  k << T(0), -r.z(), r.y(), r.z(), T(0), -r.x(), -r.y(), r.x(), T(0);
  return Eigen::Matrix<T, 3, 3>::Identity() + a * k + b * (k * k);
}

// q = (cos(theta/2), sin(theta/2)/theta * r), with the Taylor series 1/2 - theta^2/48 for the
// vector factor below theta = 1e-6.
template <class T>
Eigen::Quaternion<T> quaternion_from_axis_angle(const Eigen::Matrix<T, 3, 1>& r) {
  using std::cos;
  using std::sin;
  using std::sqrt;
  const T theta_sq = r.squaredNorm();
  T w, s;
  if (theta_sq < T(1e-12)) {
    w = T(1) - theta_sq / T(8);
    s = T(0.5) - theta_sq / T(48);
  } else {
    const T theta = sqrt(theta_sq);
    w = cos(theta / T(2));
    s = sin(theta / T(2)) / theta;
  }
  return Eigen::Quaternion<T>(w, s * r.x(), s * r.y(), s * r.z());
}

// Inverse of quaternion_from_axis_angle, returning theta in [0, pi]: theta = 2 atan2(|v|, |w|)
// (atan2 stays accurate at both ends where acos/asin do not); the sign of q is chosen so w >= 0.
inline Eigen::Vector3d axis_angle_from_quaternion(const Eigen::Quaterniond& q_in) {
  Eigen::Quaterniond q = q_in.w() < 0 ? Eigen::Quaterniond(-q_in.coeffs()) : q_in;
  const Eigen::Vector3d v = q.vec();
  const double s = v.norm();
  if (s < 1e-12) return 2.0 * v / q.w();  // theta ~ 2 s / w, exact to O(s^3)
  const double theta = 2.0 * std::atan2(s, q.w());
  return v * (theta / s);
}

// Shepperd's method (Eigen picks the largest diagonal pivot), then renormalised.
inline Eigen::Quaterniond quaternion_from_matrix(const Eigen::Matrix3d& m) {
  return Eigen::Quaterniond(m).normalized();
}

inline Eigen::Vector3d axis_angle_from_matrix(const Eigen::Matrix3d& m) {
  return axis_angle_from_quaternion(quaternion_from_matrix(m));
}

// Tait-Bryan Euler angles in any of the six axis orders. The order names the axes as they are
// applied in the local (intrinsic) frame, which is how BVH channel lists read:
// "Zrotation Xrotation Yrotation" is EulerOrder::ZXY and means R = Rz(a0) * Rx(a1) * Ry(a2).
enum class EulerOrder { XYZ, XZY, YXZ, YZX, ZXY, ZYX };

constexpr std::array<int, 3> euler_axes(EulerOrder order) {
  switch (order) {
    case EulerOrder::XYZ: return {0, 1, 2};
    case EulerOrder::XZY: return {0, 2, 1};
    case EulerOrder::YXZ: return {1, 0, 2};
    case EulerOrder::YZX: return {1, 2, 0};
    case EulerOrder::ZXY: return {2, 0, 1};
    case EulerOrder::ZYX: return {2, 1, 0};
  }
  return {0, 1, 2};
}

// Parses "XYZ", "zxy", ...; nullopt for anything else (repeated axes included).
std::optional<EulerOrder> parse_euler_order(std::string_view text);
const char* euler_order_name(EulerOrder order);

// R = R_axis0(angles[0]) * R_axis1(angles[1]) * R_axis2(angles[2]), angles in radians.
template <class T>
Eigen::Quaternion<T> quaternion_from_euler(EulerOrder order, const Eigen::Matrix<T, 3, 1>& angles) {
  const auto axes = euler_axes(order);
  Eigen::Quaternion<T> q = Eigen::Quaternion<T>::Identity();
  for (int k = 0; k < 3; ++k) {
    q = q * Eigen::Quaternion<T>(Eigen::AngleAxis<T>(angles[k], Eigen::Matrix<T, 3, 1>::Unit(axes[k])));
  }
  return q;
}

// Inverse of quaternion_from_euler with the middle angle in [-pi/2, pi/2] and the others in
// (-pi, pi]. At gimbal lock (middle angle +-pi/2) the third angle is set to 0.
Eigen::Vector3d euler_from_quaternion(EulerOrder order, const Eigen::Quaterniond& q);

// The quaternion of the two that is closest to `reference` (q and -q are the same rotation).
// Used to keep animation samples sign-continuous and to make interpolation take the short way.
inline Eigen::Quaterniond sign_aligned(const Eigen::Quaterniond& q, const Eigen::Quaterniond& reference) {
  return q.dot(reference) < 0 ? Eigen::Quaterniond(-q.coeffs()) : q;
}

// The change of basis from a Y-up world (glTF, BVH, SMPL body templates) to the toolkit's Z-up
// world: +90 degrees about X, (x, y, z) -> (x, -z, y). Up (0,1,0) maps to (0,0,1) and the Y-up
// forward axis +Z maps to -Y, the same convention Blender uses on import.
inline Eigen::Matrix3d y_up_to_z_up() {
  Eigen::Matrix3d c;
  c << 1, 0, 0, 0, 0, -1, 0, 1, 0;
  return c;
}

}  // namespace odyssey
