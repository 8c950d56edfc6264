// Cinematic camera rigs (scene_layouts/camera_rigs.h): the swoop's heights, radius and sweep; the
// dolly-zoom's subject image size held constant; the zoom's focal endpoints and geometric middle;
// the handheld shake's amplitude bounds, band-limited spectrum and seeding; bad options.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <complex>
#include <functional>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "scene_layouts/camera_rigs.h"

namespace odyssey::scene {
namespace {

using Eigen::Vector3d;
constexpr double kPi = std::numbers::pi;

const PinholeIntrinsics kIntrinsics = intrinsics_from_hfov(960, 540, 60);

void expect_invalid(const std::function<void()>& call, const std::string& part) {
  try {
    call();
    ADD_FAILURE() << "no error naming " << part;
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find(part), std::string::npos) << error.what();
  }
}

// The camera looks at `target`: its forward axis is the unit direction to it.
void expect_looks_at(const CameraPose& pose, const Vector3d& target, double tolerance) {
  EXPECT_LT((pose.forward() - (target - pose.centre()).normalized()).norm(), tolerance);
}

TEST(SwoopCameraTest, RisesBetweenItsHeightsAtAFixedRadiusWhileTurningItsSweep) {
  SwoopCameraOptions options;
  options.target = Vector3d(1, -2, 0.9);
  options.radius = 5;
  options.start_height = 0.4;
  options.end_height = 4.2;
  options.start_angle_deg = 30;
  options.sweep_deg = -120;
  const int frames = 61;
  const CameraPath path = swoop_camera_path(frames, 30, kIntrinsics, options);
  ASSERT_EQ(path.frame_count(), frames);
  path.validate();
  EXPECT_EQ(path.kind, "swoop");
  for (int f = 0; f < frames; ++f) {
    const Vector3d c = path.poses[f].centre();
    EXPECT_NEAR((c - options.target).head<2>().norm(), 5, 1e-12) << "frame " << f;
    expect_looks_at(path.poses[f], options.target, 1e-12);
    EXPECT_NEAR(path.intrinsics[f].fx, kIntrinsics.fx, 0);
  }
  // Endpoints exact; the middle frame halfway in height and angle (the ease has s(1/2) = 1/2).
  const auto angle_of = [&](int f) {
    const Vector3d d = path.poses[f].centre() - options.target;
    return std::atan2(d.y(), d.x()) * 180 / kPi;
  };
  EXPECT_NEAR(path.poses.front().centre().z(), 0.4, 1e-12);
  EXPECT_NEAR(path.poses.back().centre().z(), 4.2, 1e-12);
  EXPECT_NEAR(path.poses[30].centre().z(), 2.3, 1e-12);
  EXPECT_NEAR(angle_of(0), 30, 1e-9);
  EXPECT_NEAR(angle_of(30), -30, 1e-9);
  EXPECT_NEAR(angle_of(60), -90, 1e-9);
  // Eased: the first step is far shorter than the middle one (zero speed at the ends). In the
  // ease, s(1/60) = (1 - cos(pi/60))/2 = 6.85e-4 against s(31/60) - s(1/2) = sin(pi/120)/2 = 0.0262;
  // the height's share differs a little, so allow 5% where 2.6% is expected (a linear ramp gives 100%).
  const double first_step = (path.poses[1].centre() - path.poses[0].centre()).norm();
  const double middle_step = (path.poses[31].centre() - path.poses[30].centre()).norm();
  EXPECT_LT(first_step, 0.05 * middle_step);
}

// A subject of half-width L in the plane through the target across the view axis: its image is
// 2 f L / d wide. The rig keeps f / d fixed, so the width holds to rounding.
TEST(DollyZoomCameraTest, SubjectKeepsItsImageSizeWhileTheCameraMovesAlongItsViewAxis) {
  DollyZoomOptions options;
  options.start_centre = Vector3d(3, -6, 1.7);
  options.target = Vector3d(0.5, 0.5, 1.1);
  options.end_distance = 1.5;
  const int frames = 90;
  const CameraPath path = dolly_zoom_camera_path(frames, 30, kIntrinsics, options);
  path.validate();
  const double d0 = (options.target - options.start_centre).norm();
  const Vector3d axis = (options.target - options.start_centre) / d0;
  double first_width = 0;
  for (int f = 0; f < frames; ++f) {
    const CameraPose& pose = path.poses[f];
    const PinholeIntrinsics& k = path.intrinsics[f];
    // On the view axis, looking along it, never turning.
    EXPECT_LT((pose.forward() - axis).norm(), 1e-12);
    EXPECT_LT((pose.rotation - path.poses[0].rotation).norm(), 1e-15);
    const double d = (options.target - pose.centre()).norm();
    EXPECT_LT(((options.target - pose.centre()) - d * axis).norm(), 1e-12);
    EXPECT_NEAR(k.fx / d, kIntrinsics.fx / d0, 1e-12 * kIntrinsics.fx / d0);
    // Horizontal and vertical extents of the subject in pixels.
    const double l = 0.3;
    const PixelProjection left = project(pose, k, options.target - l * pose.right());
    const PixelProjection right = project(pose, k, options.target + l * pose.right());
    const PixelProjection top = project(pose, k, options.target - l * pose.down());
    const PixelProjection bottom = project(pose, k, options.target + l * pose.down());
    const double width = right.u - left.u, height = bottom.v - top.v;
    if (f == 0) first_width = width;
    EXPECT_NEAR(width, first_width, 1e-9 * first_width) << "frame " << f;
    EXPECT_NEAR(height, first_width * k.fy / k.fx, 1e-9 * first_width) << "frame " << f;
  }
  EXPECT_NEAR(first_width, 2 * kIntrinsics.fx * 0.3 / d0, 1e-9);
  EXPECT_NEAR((options.target - path.poses.back().centre()).norm(), 1.5, 1e-12);
  // The background widens: the field of view at the end is wider than at the start.
  EXPECT_GT(path.intrinsics.back().horizontal_fov_deg(), 60 + 1);
}

TEST(ZoomCameraTest, FocalLengthRunsGeometricallyBetweenTheTwoFieldsOfViewFromAFixedCentre) {
  ZoomCameraOptions options;
  options.centre = Vector3d(-2, -5, 1.5);
  options.target = Vector3d(0, 0, 1);
  options.end_hfov_deg = 20;
  const int frames = 41;
  const CameraPath path = zoom_camera_path(frames, 24, kIntrinsics, options);
  path.validate();
  const double f0 = 480 / std::tan(30 * kPi / 180), f1 = 480 / std::tan(10 * kPi / 180);
  EXPECT_NEAR(path.intrinsics.front().fx, f0, 1e-9);
  EXPECT_NEAR(path.intrinsics.back().fx, f1, 1e-9);
  EXPECT_NEAR(path.intrinsics.back().horizontal_fov_deg(), 20, 1e-9);
  EXPECT_NEAR(path.intrinsics[20].fx, std::sqrt(f0 * f1), 1e-9);
  for (int f = 0; f < frames; ++f) {
    EXPECT_LT((path.poses[f].centre() - options.centre).norm(), 1e-12);
    expect_looks_at(path.poses[f], options.target, 1e-12);
    EXPECT_NEAR(path.intrinsics[f].fy / path.intrinsics[f].fx, kIntrinsics.fy / kIntrinsics.fx, 1e-12);
    EXPECT_EQ(path.intrinsics[f].cx, kIntrinsics.cx);
    if (f > 0) {
      EXPECT_GT(path.intrinsics[f].fx, path.intrinsics[f - 1].fx);
    }
  }
}

CameraPath still_camera(int frames, double fps) {
  StaticCameraOptions options;
  options.centre = Vector3d(1, -4, 1.6);
  options.target = Vector3d(0, 0, 1);
  return static_camera_path(frames, fps, kIntrinsics, options);
}

struct Shake {
  std::vector<Vector3d> offsets, turns;  // per frame, in the original camera's axes
};

// The shake of `shaken` relative to `base`: e = R (c' - c) and the X-Y-Z angles of D = R' R^T.
Shake shake_of(const CameraPath& base, const CameraPath& shaken) {
  Shake shake;
  for (int f = 0; f < base.frame_count(); ++f) {
    const CameraPose& a = base.poses[f];
    const CameraPose& b = shaken.poses[f];
    shake.offsets.push_back(a.rotation * (b.centre() - a.centre()));
    // D = Rx(x) Ry(y) Rz(z) has third column (sin y, -sin x cos y, cos x cos y) and first row
    // (cos y cos z, -cos y sin z, sin y): small angles read back without branch ambiguity.
    const Eigen::Matrix3d d = b.rotation * a.rotation.transpose();
    shake.turns.emplace_back(std::atan2(-d(1, 2), d(2, 2)), std::asin(d(0, 2)), std::atan2(-d(0, 1), d(0, 0)));
  }
  return shake;
}

TEST(HandheldShakeTest, OffsetsAndTurnsStayWithinTheirAmplitudesAndReachThem) {
  const CameraPath base = still_camera(900, 30);
  CameraPath shaken = base;
  HandheldOptions options;
  options.amplitude_m = 0.03;
  options.rotation_deg = 0.8;
  options.low_hz = 0.5;
  options.high_hz = 2;
  apply_handheld(shaken, options, 42, 7);
  shaken.validate();
  EXPECT_EQ(shaken.kind, "static+handheld");
  const Shake shake = shake_of(base, shaken);
  const double turn_bound = 0.8 * kPi / 180;
  Eigen::Vector3d largest_offset = Vector3d::Zero(), largest_turn = Vector3d::Zero();
  for (int f = 0; f < base.frame_count(); ++f) {
    largest_offset = largest_offset.cwiseMax(shake.offsets[f].cwiseAbs());
    largest_turn = largest_turn.cwiseMax(shake.turns[f].cwiseAbs());
  }
  for (int k = 0; k < 3; ++k) {
    EXPECT_LE(largest_offset[k], 0.03 + 1e-12);
    EXPECT_LE(largest_turn[k], turn_bound + 1e-12);
    // A sum of 8 sines of random phases over 30 s comes well past a third of its bound.
    EXPECT_GT(largest_offset[k], 0.03 / 3);
    EXPECT_GT(largest_turn[k], turn_bound / 3);
  }
}

// Hann-windowed DFT of each offset signal over 60 s: the energy outside the band (widened by the
// window's main lobe, 2 bins each side, plus a bin of margin) is a tiny share of the total.
TEST(HandheldShakeTest, SpectrumLiesInsideTheBand) {
  const double fps = 30;
  const int frames = 1800;
  const CameraPath base = still_camera(frames, fps);
  CameraPath shaken = base;
  HandheldOptions options;
  options.amplitude_m = 0.02;
  options.low_hz = 1;
  options.high_hz = 2.5;
  apply_handheld(shaken, options, 5, 0);
  const Shake shake = shake_of(base, shaken);
  const double bin_hz = fps / frames;
  for (int axis = 0; axis < 3; ++axis) {
    double inside = 0, outside = 0;
    for (int bin = 0; bin <= frames / 2; ++bin) {
      std::complex<double> sum = 0;
      for (int f = 0; f < frames; ++f) {
        const double window = 0.5 - 0.5 * std::cos(2 * kPi * f / frames);
        sum += window * shake.offsets[f][axis] * std::polar(1.0, -2 * kPi * bin * f / frames);
      }
      const double frequency = bin * bin_hz, energy = std::norm(sum);
      (frequency >= 1 - 3 * bin_hz && frequency <= 2.5 + 3 * bin_hz ? inside : outside) += energy;
    }
    EXPECT_LT(outside / (inside + outside), 1e-4) << "axis " << axis;
  }
}

TEST(HandheldShakeTest, SameSeedSamePathAndAnotherSeedOrStreamAnotherPath) {
  const CameraPath base = still_camera(300, 30);
  HandheldOptions options;
  options.amplitude_m = 0.02;
  CameraPath a = base, b = base, c = base, d = base;
  apply_handheld(a, options, 11, 3);
  apply_handheld(b, options, 11, 3);
  apply_handheld(c, options, 12, 3);
  apply_handheld(d, options, 11, 4);
  double same = 0, other_seed = 0, other_stream = 0;
  for (int f = 0; f < base.frame_count(); ++f) {
    same = std::max(same, (a.poses[f].extrinsics() - b.poses[f].extrinsics()).cwiseAbs().maxCoeff());
    other_seed = std::max(other_seed, (a.poses[f].centre() - c.poses[f].centre()).norm());
    other_stream = std::max(other_stream, (a.poses[f].centre() - d.poses[f].centre()).norm());
  }
  EXPECT_EQ(same, 0);
  EXPECT_GT(other_seed, 0.1 * 0.02);
  EXPECT_GT(other_stream, 0.1 * 0.02);
}

TEST(HandheldShakeTest, RidesOnAMovingRigWithoutChangingItsIntrinsics) {
  const CameraPath base = zoom_camera_path(120, 30, kIntrinsics, ZoomCameraOptions{});
  CameraPath shaken = base;
  apply_handheld(shaken, HandheldOptions{}, 1, 0);
  const Shake shake = shake_of(base, shaken);
  for (int f = 0; f < base.frame_count(); ++f) {
    EXPECT_EQ(shaken.intrinsics[f].fx, base.intrinsics[f].fx);
    EXPECT_LE(shake.offsets[f].cwiseAbs().maxCoeff(), HandheldOptions{}.amplitude_m + 1e-12);
  }
}

TEST(CinematicRigsTest, BadOptionsAreRejectedNamingTheOption) {
  SwoopCameraOptions swoop;
  swoop.radius = 0;
  expect_invalid([&] { swoop_camera_path(10, 30, kIntrinsics, swoop); }, "swoop camera: radius");
  swoop = {};
  swoop.end_height = NAN;
  expect_invalid([&] { swoop_camera_path(10, 30, kIntrinsics, swoop); }, "end_height");
  DollyZoomOptions dolly;
  dolly.end_distance = 0;
  expect_invalid([&] { dolly_zoom_camera_path(10, 30, kIntrinsics, dolly); }, "end_distance");
  dolly = {};
  dolly.start_centre = dolly.target;
  expect_invalid([&] { dolly_zoom_camera_path(10, 30, kIntrinsics, dolly); }, "start_centre is on the target");
  ZoomCameraOptions zoom;
  zoom.end_hfov_deg = 180;
  expect_invalid([&] { zoom_camera_path(10, 30, kIntrinsics, zoom); }, "end_hfov_deg");
  CameraPath path = still_camera(10, 30);
  HandheldOptions shake;
  shake.high_hz = 15;  // the Nyquist rate at 30 fps
  expect_invalid([&] { apply_handheld(path, shake, 0, 0); }, "fps / 2");
  shake = {};
  shake.amplitude_m = -1;
  expect_invalid([&] { apply_handheld(path, shake, 0, 0); }, "amplitude");
  shake = {};
  shake.low_hz = 3;
  shake.high_hz = 1;
  expect_invalid([&] { apply_handheld(path, shake, 0, 0); }, "band");
}

}  // namespace
}  // namespace odyssey::scene
