// Pinhole cameras: intrinsics from a field of view, projection against hand-computed numbers, the
// image border and points behind the camera, camera axes from a viewing direction (OpenCV: x right,
// y down, z forward), extrinsics and centre, and CameraPath::validate.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "skeleton/camera.h"

namespace odyssey {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

PinholeIntrinsics intrinsics(double fx, double fy, double cx, double cy, int width, int height) {
  PinholeIntrinsics k;
  k.fx = fx;
  k.fy = fy;
  k.cx = cx;
  k.cy = cy;
  k.width = width;
  k.height = height;
  return k;
}

TEST(CameraTest, IntrinsicsFromHorizontalFov) {
  // fx = (960 / 2) / tan(80 deg / 2) = 480 / 0.8390996... = 572.0417...
  const PinholeIntrinsics k = intrinsics_from_hfov(960, 540, 80);
  EXPECT_NEAR(k.fx, 572.0417244452209, 1e-9);
  EXPECT_EQ(k.fy, k.fx);  // square pixels
  EXPECT_EQ(k.cx, 480);
  EXPECT_EQ(k.cy, 270);
  EXPECT_EQ(k.width, 960);
  EXPECT_EQ(k.height, 540);
  EXPECT_NEAR(k.horizontal_fov_deg(), 80, 1e-12);
  // 90 deg: tan 45 = 1, so fx is half the width.
  EXPECT_NEAR(intrinsics_from_hfov(640, 480, 90).fx, 320, 1e-12);

  const Matrix3d m = k.matrix();
  Matrix3d expected;
  expected << k.fx, 0, 480, 0, k.fx, 270, 0, 0, 1;
  EXPECT_EQ(m, expected);

  EXPECT_THROW(intrinsics_from_hfov(960, 540, 0), std::invalid_argument);
  EXPECT_THROW(intrinsics_from_hfov(960, 540, -10), std::invalid_argument);
  EXPECT_THROW(intrinsics_from_hfov(960, 540, 180), std::invalid_argument);
  EXPECT_THROW(intrinsics_from_hfov(960, 540, std::numeric_limits<double>::quiet_NaN()), std::invalid_argument);
  EXPECT_THROW(intrinsics_from_hfov(0, 540, 60), std::invalid_argument);
  EXPECT_THROW(intrinsics_from_hfov(960, 0, 60), std::invalid_argument);
}

TEST(CameraTest, ProjectsLikeTheHandComputedPinhole) {
  // Identity pose: camera axes are the world axes. (0.2, -0.1, 2) with fx 500, fy 400,
  // c (320, 240): u = 500 * 0.2 / 2 + 320 = 370, v = 400 * -0.1 / 2 + 240 = 220.
  const PinholeIntrinsics k = intrinsics(500, 400, 320, 240, 640, 480);
  const PixelProjection a = project(CameraPose{}, k, Vector3d(0.2, -0.1, 2));
  EXPECT_NEAR(a.u, 370, 1e-12);
  EXPECT_NEAR(a.v, 220, 1e-12);
  EXPECT_EQ(a.depth, 2);
  EXPECT_TRUE(a.valid);

  // A camera at (0, -4, 1) looking along +y (up +z): camera x = world x, y = -world z, z = world y.
  // The point (1, 0, 2) is (1, 4, 1) from the centre, so x_cam = (1, -1, 4); at 90 deg over 960 px
  // fx = fy = 480, c = (480, 270): u = 480 / 4 + 480 = 600, v = -480 / 4 + 270 = 150.
  const CameraPose along_y = CameraPose::look_at(Vector3d(0, -4, 1), Vector3d(0, 0, 1));
  const PixelProjection b = project(along_y, intrinsics_from_hfov(960, 540, 90), Vector3d(1, 0, 2));
  EXPECT_NEAR(b.u, 600, 1e-9);
  EXPECT_NEAR(b.v, 150, 1e-9);
  EXPECT_NEAR(b.depth, 4, 1e-12);
  EXPECT_TRUE(b.valid);

  // A camera at (-2, 0, 1) looking along +x: right = forward x up = x x z = -y, down =
  // forward x right = x x (-y) = -z; so x_cam = -world y, y_cam = -world z, z_cam = world x.
  // The point (3, 0.5, 1.5) is (5, 0.5, 0.5) from the centre: x_cam = (-0.5, -0.5, 5); with
  // f = 1000, c = (320, 240): u = 1000 * -0.1 + 320 = 220, v = 1000 * -0.1 + 240 = 140.
  const CameraPose along_x = CameraPose::from_forward_up(Vector3d(-2, 0, 1), Vector3d(3, 0, 0));
  const PixelProjection c = project(along_x, intrinsics(1000, 1000, 320, 240, 640, 480), Vector3d(3, 0.5, 1.5));
  EXPECT_NEAR(c.u, 220, 1e-9);
  EXPECT_NEAR(c.v, 140, 1e-9);
  EXPECT_NEAR(c.depth, 5, 1e-12);
  EXPECT_TRUE(c.valid);
}

TEST(CameraTest, ValidOnlyInsideTheImageAndInFront) {
  // fx = fy = 512 with c = (320, 240): x = +-0.625 and y = +-0.46875 at depth 1 land exactly on
  // u = 0 / 640 and v = 0 / 480 (all exact in binary). The image is [0, 640) x [0, 480).
  const PinholeIntrinsics k = intrinsics(512, 512, 320, 240, 640, 480);
  const CameraPose pose;
  const auto at = [&](double x, double y, double z) { return project(pose, k, Vector3d(x, y, z)); };

  const PixelProjection left_edge = at(-0.625, 0, 1);
  EXPECT_EQ(left_edge.u, 0);
  EXPECT_TRUE(left_edge.valid);
  const PixelProjection right_edge = at(0.625, 0, 1);
  EXPECT_EQ(right_edge.u, 640);
  EXPECT_FALSE(right_edge.valid);
  EXPECT_TRUE(at(0.625 - 1e-6, 0, 1).valid);  // u = 639.9995
  EXPECT_FALSE(at(-0.625 - 1e-6, 0, 1).valid);

  const PixelProjection top_edge = at(0, -0.46875, 1);
  EXPECT_EQ(top_edge.v, 0);
  EXPECT_TRUE(top_edge.valid);
  const PixelProjection bottom_edge = at(0, 0.46875, 1);
  EXPECT_EQ(bottom_edge.v, 480);
  EXPECT_FALSE(bottom_edge.valid);
  EXPECT_TRUE(at(0, 0.46875 - 1e-6, 1).valid);
  EXPECT_TRUE(at(-0.625, -0.46875, 1).valid);  // the corner pixel (0, 0)

  // Behind the camera the point would land mid-image by the formula (x/z = 0.1), but it is invalid,
  // with the pixel zeroed and the depth kept.
  const PixelProjection behind = at(-0.1, -0.1, -1);
  EXPECT_FALSE(behind.valid);
  EXPECT_EQ(behind.u, 0);
  EXPECT_EQ(behind.v, 0);
  EXPECT_EQ(behind.depth, -1);
  const PixelProjection on_plane = at(0.1, 0.1, 0);
  EXPECT_FALSE(on_plane.valid);
  EXPECT_TRUE(std::isfinite(on_plane.u) && std::isfinite(on_plane.v));
}

TEST(CameraTest, FromForwardUpAxes) {
  // Looking along +y with up +z: x = y x z = +x (right), y = z_cam x x_cam = y x x = -z (down).
  const CameraPose a = CameraPose::from_forward_up(Vector3d(1, 2, 3), Vector3d(0, 5, 0), Vector3d::UnitZ());
  EXPECT_LT((a.right() - Vector3d(1, 0, 0)).norm(), 1e-15);
  EXPECT_LT((a.down() - Vector3d(0, 0, -1)).norm(), 1e-15);
  EXPECT_LT((a.forward() - Vector3d(0, 1, 0)).norm(), 1e-15);

  // Looking along -x: right = (-x) x z = +y.
  const CameraPose b = CameraPose::from_forward_up(Vector3d::Zero(), Vector3d(-1, 0, 0));
  EXPECT_LT((b.right() - Vector3d(0, 1, 0)).norm(), 1e-15);
  EXPECT_LT((b.down() - Vector3d(0, 0, -1)).norm(), 1e-15);

  // Forward (1, 0, 1), tilted 45 deg up, with a non-unit up (0, 0, 2): down is minus the part of
  // up orthogonal to z_cam, normalised: up - (up . z) z = (0,0,1) - (1/2)(1,0,1) = (-1/2, 0, 1/2),
  // so down = (1, 0, -1) / sqrt 2; right = z x up / |.| = (0, -1, 0).
  const CameraPose c = CameraPose::from_forward_up(Vector3d::Zero(), Vector3d(1, 0, 1), Vector3d(0, 0, 2));
  const double h = std::sqrt(0.5);
  EXPECT_LT((c.forward() - Vector3d(h, 0, h)).norm(), 1e-15);
  EXPECT_LT((c.down() - Vector3d(h, 0, -h)).norm(), 1e-15);
  EXPECT_LT((c.right() - Vector3d(0, -1, 0)).norm(), 1e-15);
  EXPECT_NEAR(c.rotation.determinant(), 1, 1e-15);
  EXPECT_TRUE((c.rotation * c.rotation.transpose()).isIdentity(1e-15));

  EXPECT_THROW(CameraPose::from_forward_up(Vector3d::Zero(), Vector3d::Zero()), std::invalid_argument);
  EXPECT_THROW(CameraPose::from_forward_up(Vector3d::Zero(), Vector3d(0, 0, 3)), std::invalid_argument);
  EXPECT_THROW(CameraPose::from_forward_up(Vector3d::Zero(), Vector3d(0, 0, -1)), std::invalid_argument);
  EXPECT_THROW(CameraPose::from_forward_up(Vector3d::Zero(), Vector3d(1e-12, 0, 1)), std::invalid_argument);
  // 1e-6 rad off the vertical is a legitimate (if steep) view.
  EXPECT_NO_THROW(CameraPose::from_forward_up(Vector3d::Zero(), Vector3d(1e-6, 0, 1)));
  EXPECT_THROW(CameraPose::look_at(Vector3d(1, 2, 3), Vector3d(1, 2, 3)), std::invalid_argument);
}

TEST(CameraTest, LookAtPutsTheTargetAtTheImageCentre) {
  const PinholeIntrinsics k = intrinsics_from_hfov(960, 540, 60);
  const Vector3d centre(2.5, -3, 1.8), target(-0.4, 0.7, 0.9);
  const CameraPose pose = CameraPose::look_at(centre, target);
  const PixelProjection p = project(pose, k, target);
  EXPECT_NEAR(p.u, 480, 1e-9);
  EXPECT_NEAR(p.v, 270, 1e-9);
  EXPECT_NEAR(p.depth, (target - centre).norm(), 1e-12);
  EXPECT_TRUE(p.valid);
  // Image up is world up: a point above the target is higher in the image (smaller v), and the
  // camera has no roll (its x axis is horizontal).
  EXPECT_LT(project(pose, k, target + Vector3d(0, 0, 0.3)).v, 270 - 10);
  EXPECT_NEAR(pose.right().z(), 0, 1e-15);
}

TEST(CameraTest, ExtrinsicsAndCentreRoundTrip) {
  const Vector3d centre(0.3, -2.2, 1.4);
  const CameraPose pose = CameraPose::look_at(centre, Vector3d(1, 1, 0.5));
  EXPECT_LT((pose.centre() - centre).norm(), 1e-14);
  EXPECT_LT(pose.to_camera(centre).norm(), 1e-14);

  const Eigen::Matrix4d e = pose.extrinsics();
  EXPECT_EQ((e.topLeftCorner<3, 3>()), pose.rotation);
  EXPECT_EQ((e.topRightCorner<3, 1>()), pose.translation);
  EXPECT_EQ(e.row(3), Eigen::RowVector4d(0, 0, 0, 1));
  const Vector3d world(-1, 4, 2);
  EXPECT_LT(((e * world.homogeneous()).head<3>() - pose.to_camera(world)).norm(), 1e-14);
  // Inverting the extrinsics gives the camera-to-world transform, whose translation is the centre.
  EXPECT_LT((e.inverse().topRightCorner<3, 1>() - centre).norm(), 1e-12);
}

TEST(CameraTest, ValidateRejectsBadPaths) {
  CameraPath path;
  path.kind = "static";
  for (int f = 0; f < 3; ++f) {
    path.poses.push_back(CameraPose::look_at(Vector3d(0, -4, 1.5), Vector3d(0, 0, 1)));
    path.intrinsics.push_back(intrinsics_from_hfov(960, 540, 60));
  }
  EXPECT_NO_THROW(path.validate());
  EXPECT_EQ(path.frame_count(), 3);

  const auto rejects = [](const CameraPath& bad, const std::string& phrase) {
    try {
      bad.validate();
      ADD_FAILURE() << "accepted a path that should fail with '" << phrase << "'";
    } catch (const std::invalid_argument& error) {
      EXPECT_NE(std::string(error.what()).find(phrase), std::string::npos) << error.what();
    }
  };
  {
    CameraPath bad = path;
    bad.intrinsics.pop_back();
    rejects(bad, "3 poses but 2 intrinsics");
  }
  {
    CameraPath bad = path;
    bad.poses[2].translation.x() = std::numeric_limits<double>::infinity();
    rejects(bad, "frame 2");
  }
  {
    CameraPath bad = path;
    bad.poses[1].rotation *= 1.01;  // not orthonormal
    rejects(bad, "frame 1");
  }
  {
    CameraPath bad = path;
    bad.poses[1].rotation.row(0) *= -1;  // orthonormal but a reflection, det -1
    rejects(bad, "frame 1");
  }
  {
    CameraPath bad = path;
    bad.intrinsics[0].fx = 0;
    rejects(bad, "frame 0");
  }
  {
    CameraPath bad = path;
    bad.intrinsics[2].cy = std::numeric_limits<double>::quiet_NaN();
    rejects(bad, "frame 2");
  }
  {
    CameraPath bad = path;
    bad.fps = 0;
    rejects(bad, "fps");
  }
  // A rotation off by 1e-9 (float noise from a file) is still a rotation.
  CameraPath noisy = path;
  noisy.poses[0].rotation(0, 1) += 1e-9;
  EXPECT_NO_THROW(noisy.validate());
}

}  // namespace
}  // namespace odyssey
