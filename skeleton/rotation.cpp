#include "skeleton/rotation.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <string>

namespace odyssey {

std::optional<EulerOrder> parse_euler_order(std::string_view text) {
  if (text.size() != 3) return std::nullopt;
  std::string upper(3, ' ');
  std::transform(text.begin(), text.end(), upper.begin(), [](unsigned char c) { return char(std::toupper(c)); });
  for (EulerOrder order : {EulerOrder::XYZ, EulerOrder::XZY, EulerOrder::YXZ, EulerOrder::YZX, EulerOrder::ZXY, EulerOrder::ZYX}) {
    if (upper == euler_order_name(order)) return order;
  }
  return std::nullopt;
}

const char* euler_order_name(EulerOrder order) {
  switch (order) {
    case EulerOrder::XYZ: return "XYZ";
    case EulerOrder::XZY: return "XZY";
    case EulerOrder::YXZ: return "YXZ";
    case EulerOrder::YZX: return "YZX";
    case EulerOrder::ZXY: return "ZXY";
    case EulerOrder::ZYX: return "ZYX";
  }
  return "XYZ";
}

// For R = Ri(a) Rj(b) Rk(c) with distinct axes (i, j, k) and parity s = +1 when (i, j, k) is a
// cyclic permutation of (x, y, z), -1 otherwise, expanding the product gives
//   R(i,k) = s sin b,
//   R(j,k) = -s sin a cos b,  R(k,k) = cos a cos b,
//   R(i,j) = -s cos b sin c,  R(i,i) = cos b cos c,
// so b = asin(s R(i,k)), a = atan2(-s R(j,k), R(k,k)), c = atan2(-s R(i,j), R(i,i)).
// When cos b vanishes, R = Ri(a) Rj(b) with c = 0 and a = atan2(s R(k,j), R(j,j)).
Eigen::Vector3d euler_from_quaternion(EulerOrder order, const Eigen::Quaterniond& q) {
  const Eigen::Matrix3d r = q.normalized().toRotationMatrix();
  const auto [i, j, k] = euler_axes(order);
  const double s = ((j - i + 3) % 3 == 1) ? 1.0 : -1.0;
  // b from atan2 with cos b = sqrt(R(i,i)^2 + R(i,j)^2): accurate where asin alone is not.
  const double cos_b = std::hypot(r(i, i), r(i, j));
  const double b = std::atan2(s * r(i, k), cos_b);
  if (cos_b < 1e-12) {
    return {std::atan2(s * r(k, j), r(j, j)), b, 0.0};
  }
  return {std::atan2(-s * r(j, k), r(k, k)), b, std::atan2(-s * r(i, j), r(i, i))};
}

}  // namespace odyssey
