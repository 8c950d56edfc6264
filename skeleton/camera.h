// Pinhole cameras in the toolkit's world (Z up, metres), with OpenCV axes and conventions, as the
// trajectory files and renderers expect them:
//
// - Camera axes: x right, y down, z forward (the viewing direction).
// - Extrinsics: the world->camera rigid transform, x_cam = R x_world + t, as a 4x4 [R t; 0 1].
//   The camera centre is c = -R^T t.
// - Intrinsics: K = [fx 0 cx; 0 fy cy; 0 0 1] in pixels. A camera point x_cam projects to
//     (u, v) = (fx x/z + cx, fy y/z + cy),
//   pixel (i, j) covering [i, i+1) x [j, j+1), so the image is [0, width) x [0, height) and its
//   centre is (width/2, height/2). A point is valid when z > 0 and (u, v) lies in the image.
// - From a horizontal field of view h (degrees, square pixels, centred principal point):
//     fx = fy = (width / 2) / tan(h / 2),  cx = width / 2,  cy = height / 2.
//
// A CameraPath is one camera per frame of a clip (the same fps), whatever moves it: a static
// camera, an orbit, a camera riding on a head (scene_layouts/camera_rigs.h).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace odyssey {

struct PinholeIntrinsics {
  double fx = 1, fy = 1, cx = 0, cy = 0;
  int width = 1, height = 1;

  Eigen::Matrix3d matrix() const;
  double horizontal_fov_deg() const;  // 2 atan(width / (2 fx))
};

// Throws std::invalid_argument when width or height < 1 or hfov_deg is not in (0, 180).
PinholeIntrinsics intrinsics_from_hfov(int width, int height, double hfov_deg);

// The range every camera source is held to, whatever its file says: a field of view of
// kMinFovDeg to kMaxFovDeg along each axis, that is fx in [w / (2 tan(kMaxFovDeg / 2)),
// w / (2 tan(kMinFovDeg / 2))] (0.0087 w to 5730 w) and fy likewise with h, and the principal
// point within one image size of the image, cx in [-w, 2w] and cy in [-h, 2h]. Values outside are
// a unit mistake or a damaged file, not a lens. Returns what is out of range ("" when nothing),
// for intrinsics in pixels of a w x h image or, with w = h = 1, normalised by the image size.
inline constexpr double kMinFovDeg = 0.01, kMaxFovDeg = 179;
std::string intrinsics_problem(double fx, double fy, double cx, double cy, double width, double height);

struct CameraPose {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  // R: world -> camera axes
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();   // t

  Eigen::Vector3d centre() const { return -(rotation.transpose() * translation); }
  Eigen::Vector3d forward() const { return rotation.row(2).transpose(); }  // camera +z in the world
  Eigen::Vector3d down() const { return rotation.row(1).transpose(); }     // camera +y in the world
  Eigen::Vector3d right() const { return rotation.row(0).transpose(); }    // camera +x in the world
  Eigen::Matrix4d extrinsics() const;                                      // [R t; 0 1]
  Eigen::Vector3d to_camera(const Eigen::Vector3d& world) const { return rotation * world + translation; }

  // A camera at `centre` whose z axis points along `forward` and whose image up (-y) is as close
  // to `up` as the forward direction allows:
  //   z = f / |f|,  x = normalise(z x up),  y = z x x
  // (y is then minus the part of up orthogonal to z, normalised: it points down in the image).
  // Throws std::invalid_argument when forward is zero or parallel to up (within 1e-9 rad).
  static CameraPose from_forward_up(const Eigen::Vector3d& centre, const Eigen::Vector3d& forward,
                                    const Eigen::Vector3d& up = Eigen::Vector3d::UnitZ());
  // Looking from `centre` at `target`, image up towards `up`. Same errors (centre == target).
  static CameraPose look_at(const Eigen::Vector3d& centre, const Eigen::Vector3d& target,
                            const Eigen::Vector3d& up = Eigen::Vector3d::UnitZ());
};

struct PixelProjection {
  double u = 0, v = 0;  // pixels
  double depth = 0;     // camera z, metres
  bool valid = false;   // depth > 0 and (u, v) inside [0, width) x [0, height)
};

// Projects a world point. A point at or behind the camera plane (depth <= 0) is invalid and its
// pixel is meaningless (u = v = 0 there, so files never hold inf or NaN).
PixelProjection project(const CameraPose& pose, const PinholeIntrinsics& intrinsics, const Eigen::Vector3d& world);

struct CameraPath {
  std::string kind;  // "static", "orbit", "ego-head": what produced it, for files and reports
  double fps = 30;
  std::vector<CameraPose> poses;               // one per frame
  std::vector<PinholeIntrinsics> intrinsics;   // one per frame (the dataset stores them per frame)

  int frame_count() const { return static_cast<int>(poses.size()); }
  // Throws std::invalid_argument naming the frame when the two lists differ in length, a pose has
  // a non-finite value or a rotation that is not orthonormal with determinant +1 (within 1e-6), or
  // intrinsics are not positive and finite or out of intrinsics_problem's range; and when fps is
  // not positive.
  void validate() const;
};

}  // namespace odyssey
