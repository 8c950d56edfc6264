#include "skeleton/camera.h"

#include <Eigen/Geometry>  // cross(); camera.h has only Eigen/Core, which declares it without a definition
#include <Eigen/LU>        // determinant(), likewise
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>
#include <tuple>

namespace odyssey {

Eigen::Matrix3d PinholeIntrinsics::matrix() const {
  Eigen::Matrix3d k;
  k << fx, 0, cx, 0, fy, cy, 0, 0, 1;
  return k;
}

double PinholeIntrinsics::horizontal_fov_deg() const {
  return 2 * std::atan(width / (2 * fx)) * 180 / std::numbers::pi;
}

std::string intrinsics_problem(double fx, double fy, double cx, double cy, double width, double height) {
  const auto fov = [](double focal, double size) { return 2 * std::atan(size / (2 * focal)) * 180 / std::numbers::pi; };
  const auto number = [](double value) {
    char text[32];
    std::snprintf(text, sizeof text, "%.6g", value);
    return std::string(text);
  };
  for (const auto& [name, focal, size] : {std::tuple{"fx", fx, width}, std::tuple{"fy", fy, height}}) {
    if (!(focal > 0) || !std::isfinite(focal)) return std::string(name) + " = " + number(focal) + " is not a positive number";
    const double degrees = fov(focal, size);
    if (!(degrees >= kMinFovDeg && degrees <= kMaxFovDeg)) {
      return std::string(name) + " = " + number(focal) + " gives a field of view of " + number(degrees) + " degrees, outside " +
             number(kMinFovDeg) + " to " + number(kMaxFovDeg);
    }
  }
  for (const auto& [name, centre, size] : {std::tuple{"cx", cx, width}, std::tuple{"cy", cy, height}}) {
    if (!(centre >= -size && centre <= 2 * size)) {
      return std::string(name) + " = " + number(centre) + " lies more than one image size (" + number(size) +
             ") outside the image";
    }
  }
  return "";
}

PinholeIntrinsics intrinsics_from_hfov(int width, int height, double hfov_deg) {
  if (width < 1 || height < 1) {
    throw std::invalid_argument("image size must be at least 1x1 pixels, got " + std::to_string(width) + "x" +
                                std::to_string(height));
  }
  if (!(hfov_deg > 0 && hfov_deg < 180)) {
    throw std::invalid_argument("horizontal field of view must be between 0 and 180 degrees (exclusive), got " +
                                std::to_string(hfov_deg));
  }
  PinholeIntrinsics k;
  k.width = width;
  k.height = height;
  k.fx = k.fy = (width / 2.0) / std::tan(hfov_deg * std::numbers::pi / 360);
  k.cx = width / 2.0;
  k.cy = height / 2.0;
  return k;
}

Eigen::Matrix4d CameraPose::extrinsics() const {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = rotation;
  m.topRightCorner<3, 1>() = translation;
  return m;
}

CameraPose CameraPose::from_forward_up(const Eigen::Vector3d& centre, const Eigen::Vector3d& forward,
                                       const Eigen::Vector3d& up) {
  const double forward_norm = forward.norm();
  if (!(forward_norm > 0) || !std::isfinite(forward_norm)) {
    throw std::invalid_argument("camera viewing direction is zero or not finite");
  }
  const Eigen::Vector3d z = forward / forward_norm;
  const Eigen::Vector3d side = z.cross(up);
  // |z x u| = |u| sin(angle): parallel within 1e-9 rad is degenerate.
  if (!(side.norm() > 1e-9 * up.norm())) {
    throw std::invalid_argument("camera viewing direction is parallel to its up direction");
  }
  const Eigen::Vector3d x = side.normalized();
  const Eigen::Vector3d y = z.cross(x);
  CameraPose pose;
  pose.rotation.row(0) = x.transpose();
  pose.rotation.row(1) = y.transpose();
  pose.rotation.row(2) = z.transpose();
  pose.translation = -(pose.rotation * centre);
  return pose;
}

CameraPose CameraPose::look_at(const Eigen::Vector3d& centre, const Eigen::Vector3d& target, const Eigen::Vector3d& up) {
  if ((target - centre).norm() == 0) throw std::invalid_argument("camera looks at its own centre");
  return from_forward_up(centre, target - centre, up);
}

PixelProjection project(const CameraPose& pose, const PinholeIntrinsics& k, const Eigen::Vector3d& world) {
  const Eigen::Vector3d p = pose.to_camera(world);
  PixelProjection out;
  out.depth = p.z();
  if (!(p.z() > 0)) return out;
  out.u = k.fx * p.x() / p.z() + k.cx;
  out.v = k.fy * p.y() / p.z() + k.cy;
  out.valid = out.u >= 0 && out.u < k.width && out.v >= 0 && out.v < k.height;
  return out;
}

void CameraPath::validate() const {
  if (!(fps > 0) || !std::isfinite(fps)) throw std::invalid_argument("camera path fps must be positive");
  if (poses.size() != intrinsics.size()) {
    throw std::invalid_argument("camera path has " + std::to_string(poses.size()) + " poses but " +
                                std::to_string(intrinsics.size()) + " intrinsics");
  }
  for (std::size_t f = 0; f < poses.size(); ++f) {
    const CameraPose& pose = poses[f];
    const std::string at = "camera path frame " + std::to_string(f) + ": ";
    if (!pose.rotation.allFinite() || !pose.translation.allFinite()) throw std::invalid_argument(at + "non-finite pose");
    if (!(pose.rotation * pose.rotation.transpose()).isIdentity(1e-6) || std::abs(pose.rotation.determinant() - 1) > 1e-6) {
      throw std::invalid_argument(at + "rotation is not a proper rotation");
    }
    const PinholeIntrinsics& k = intrinsics[f];
    if (!(k.fx > 0 && k.fy > 0) || !std::isfinite(k.fx) || !std::isfinite(k.fy) || !std::isfinite(k.cx) ||
        !std::isfinite(k.cy) || k.width < 1 || k.height < 1) {
      throw std::invalid_argument(at + "intrinsics must be positive and finite");
    }
    if (const std::string problem = intrinsics_problem(k.fx, k.fy, k.cx, k.cy, k.width, k.height); !problem.empty()) {
      throw std::invalid_argument(at + "intrinsics: " + problem);
    }
  }
}

}  // namespace odyssey
