// Camera rigs: a static camera, an orbit (radius, height, angle, direction), a camera riding on a
// head checked on every frame against the head's motion written out by hand, the head frame from
// the rest pose, the Gaussian smoothing (straight lines kept, a 10 Hz wobble reduced by the
// filter's gain, sigma 0 untouched), bad options, and the ego camera on real characters.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "mocap_io/gltf_character.h"
#include "retarget/bone_map.h"
#include "retarget/canonical.h"
#include "scene_layouts/camera_rigs.h"

namespace odyssey::scene {
namespace {

using Eigen::Quaterniond;
using Eigen::Vector3d;
constexpr double kPi = std::numbers::pi;

Quaterniond about(double angle, const Vector3d& axis) { return Quaterniond(Eigen::AngleAxisd(angle, axis.normalized())); }
Quaterniond rz(double angle) { return about(angle, Vector3d::UnitZ()); }
Quaterniond rx(double angle) { return about(angle, Vector3d::UnitX()); }

void expect_invalid(const std::function<void()>& call, const std::string& option) {
  try {
    call();
    ADD_FAILURE() << "no error for bad " << option;
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find(option), std::string::npos) << error.what();
  }
}

// A small rig facing +y (its left on -x): pelvis at (0, 0, 1), hips 0.1 m to each side and 5 cm
// down, a spine 0.3 m up, and the head 0.25 m above the spine and 2 cm forward. The head's rest
// rotation is arbitrary (as in glTF rigs, whose bone axes point anywhere), so its local axes are
// not the world's; every other rest rotation is the identity.
const Quaterniond kHeadRest = about(0.7, Vector3d(1, 2, 3));
constexpr int kPelvis = 0, kLeftHip = 1, kRightHip = 2, kSpine = 3, kHead = 4;

Skeleton small_rig() {
  return Skeleton({"pelvis", "left_hip", "right_hip", "spine", "head"}, {-1, kPelvis, kPelvis, kPelvis, kSpine},
                  {Vector3d(0, 0, 1), Vector3d(-0.1, 0, -0.05), Vector3d(0.1, 0, -0.05), Vector3d(0, 0, 0.3),
                   Vector3d(0, 0.02, 0.25)},
                  {Quaterniond::Identity(), Quaterniond::Identity(), Quaterniond::Identity(), Quaterniond::Identity(),
                   kHeadRest});
}

// Per frame: the pelvis at `translation(t)` turned by `pelvis(t)`, and the head's local rotation
// `head(t) * kHeadRest`: head(t) acts in the spine's axes, which are the pelvis's. So the head's
// world rotation is pelvis(t) head(t) kHeadRest, it sits at translation(t) + pelvis(t) (0, 0.02,
// 0.55), and since kHeadRest maps the head-local forward to +y and up to +z, it looks along
// pelvis(t) head(t) y with up pelvis(t) head(t) z.
struct Motion {
  std::function<Vector3d(double)> translation;
  std::function<Quaterniond(double)> pelvis;
  std::function<Quaterniond(double)> head;
};

Clip clip_of(const Motion& motion, int frames, double fps) {
  Clip clip;
  clip.skeleton = small_rig();
  clip.fps = fps;
  clip.translated_joints = {kPelvis};
  for (int f = 0; f < frames; ++f) {
    const double t = f / fps;
    clip.rotations.insert(clip.rotations.end(), {motion.pelvis(t), Quaterniond::Identity(), Quaterniond::Identity(),
                                                 Quaterniond::Identity(), motion.head(t) * kHeadRest});
    clip.translations.push_back(motion.translation(t));
  }
  return clip;
}

Vector3d head_position(const Motion& motion, double t) { return motion.translation(t) + motion.pelvis(t) * Vector3d(0, 0.02, 0.55); }
Quaterniond head_turn(const Motion& motion, double t) { return motion.pelvis(t) * motion.head(t); }

const PinholeIntrinsics kIntrinsics = intrinsics_from_hfov(960, 540, 90);

TEST(CameraRigsTest, StaticCameraIsConstantAndLooksAtTheTarget) {
  StaticCameraOptions options;
  options.centre = Vector3d(1, -3, 1.6);
  options.target = Vector3d(-0.5, 0.5, 0.9);
  const CameraPath path = static_camera_path(12, 24, kIntrinsics, options);
  path.validate();
  EXPECT_EQ(path.kind, "static");
  EXPECT_EQ(path.fps, 24);
  ASSERT_EQ(path.frame_count(), 12);
  ASSERT_EQ(path.intrinsics.size(), 12u);
  for (int f = 0; f < 12; ++f) {
    EXPECT_EQ(path.poses[f].rotation, path.poses[0].rotation);
    EXPECT_EQ(path.poses[f].translation, path.poses[0].translation);
    EXPECT_EQ(path.intrinsics[f].fx, kIntrinsics.fx);
  }
  EXPECT_LT((path.poses[0].centre() - options.centre).norm(), 1e-12);
  const PixelProjection p = project(path.poses[0], kIntrinsics, options.target);
  EXPECT_NEAR(p.u, 480, 1e-9);
  EXPECT_NEAR(p.v, 270, 1e-9);
  EXPECT_NEAR(path.poses[0].right().z(), 0, 1e-15);  // image up towards +z: no roll
  EXPECT_GT(-path.poses[0].down().z(), 0.9);
}

TEST(CameraRigsTest, OrbitCirclesTheTarget) {
  OrbitCameraOptions options;
  options.target = Vector3d(1, 2, 1);
  options.radius = 3;
  options.height = 1.7;
  options.period_s = 8;
  const int frames = 61;  // 2 s at 30 fps: a quarter turn
  const CameraPath path = orbit_camera_path(frames, 30, kIntrinsics, options);
  path.validate();
  EXPECT_EQ(path.kind, "orbit");
  ASSERT_EQ(path.frame_count(), frames);
  for (int f = 0; f < frames; ++f) {
    const Vector3d c = path.poses[f].centre();
    EXPECT_NEAR(c.z(), 1.7, 1e-12) << f;
    EXPECT_NEAR((c - options.target).head<2>().norm(), 3, 1e-12) << f;
    const PixelProjection p = project(path.poses[f], kIntrinsics, options.target);
    EXPECT_NEAR(p.u, 480, 1e-9) << f;
    EXPECT_NEAR(p.v, 270, 1e-9) << f;
    // a(t) = -90 deg + 360 deg t / 8 s at t = f / 30.
    const double angle = -kPi / 2 + 2 * kPi * (f / 30.0) / 8;
    EXPECT_NEAR(c.x(), 1 + 3 * std::cos(angle), 1e-12) << f;
    EXPECT_NEAR(c.y(), 2 + 3 * std::sin(angle), 1e-12) << f;
  }
  // Start at -90 deg: on the -y side, looking along +y (and down a little at the target).
  EXPECT_LT((path.poses[0].centre() - Vector3d(1, -1, 1.7)).norm(), 1e-12);
  EXPECT_LT((path.poses[0].right() - Vector3d(1, 0, 0)).norm(), 1e-12);
  // A quarter period later the angle is 0: on the +x side.
  EXPECT_LT((path.poses[60].centre() - Vector3d(4, 2, 1.7)).norm(), 1e-12);
  // Counter-clockwise seen from above: (c0 - target) x (c1 - target) points up.
  const Vector3d r0 = path.poses[0].centre() - options.target, r1 = path.poses[1].centre() - options.target;
  EXPECT_GT(r0.cross(r1).z(), 0);

  options.period_s = -8;
  const CameraPath clockwise = orbit_camera_path(frames, 30, kIntrinsics, options);
  EXPECT_LT((clockwise.poses[60].centre() - Vector3d(-2, 2, 1.7)).norm(), 1e-12);  // angle -180 deg
  const Vector3d s0 = clockwise.poses[0].centre() - options.target, s1 = clockwise.poses[1].centre() - options.target;
  EXPECT_LT(s0.cross(s1).z(), 0);
}

TEST(CameraRigsTest, HeadFrameFromRest) {
  // Facing +y: forward_rest = (left - right) x z = (-0.2, 0, 0) x z = +y (normalised).
  const HeadFrame frame = head_frame_from_rest(small_rig(), kHead, kLeftHip, kRightHip);
  EXPECT_LT((kHeadRest * frame.forward_local - Vector3d(0, 1, 0)).norm(), 1e-15);
  EXPECT_LT((kHeadRest * frame.up_local - Vector3d(0, 0, 1)).norm(), 1e-15);
  // The head-local axes are not the world's (kHeadRest is a real rotation).
  EXPECT_GT((frame.forward_local - Vector3d(0, 1, 0)).norm(), 0.1);

  // Facing -x: the character's right is forward x up = (-x) x z = +y, so the right hip is on +y.
  // The pelvis carries a 90 deg rest turn about z that the hips and head inherit, so their offsets
  // are the world offsets written in the turned pelvis axes (turn^-1 applied).
  const Quaterniond turn = rz(kPi / 2);
  const Quaterniond head_rest = about(-1.1, Vector3d(0.3, -1, 0.2));
  const Skeleton facing_minus_x(
      {"pelvis", "left_hip", "right_hip", "head"}, {-1, 0, 0, 0},
      {Vector3d(2, 1, 0.9), turn.inverse() * Vector3d(0, -0.12, -0.04), turn.inverse() * Vector3d(0, 0.12, -0.04),
       turn.inverse() * Vector3d(0, 0, 0.6)},
      {turn, Quaterniond::Identity(), Quaterniond::Identity(), head_rest});
  const std::vector<RigidTransform<double>> rest = facing_minus_x.rest_world();
  ASSERT_LT((rest[2].translation - Vector3d(2, 1.12, 0.86)).norm(), 1e-15);  // right hip on +y
  const HeadFrame minus_x = head_frame_from_rest(facing_minus_x, 3, 1, 2);
  // The head's rest world rotation is turn * head_rest.
  EXPECT_LT(((turn * head_rest) * minus_x.forward_local - Vector3d(-1, 0, 0)).norm(), 1e-15);
  EXPECT_LT(((turn * head_rest) * minus_x.up_local - Vector3d(0, 0, 1)).norm(), 1e-15);

  expect_invalid([] { head_frame_from_rest(small_rig(), 5, kLeftHip, kRightHip); }, "head joint 5");
  expect_invalid([] { head_frame_from_rest(small_rig(), kHead, -1, kRightHip); }, "left_hip joint -1");
  expect_invalid([] { head_frame_from_rest(small_rig(), kHead, kLeftHip, 7); }, "right_hip joint 7");
  expect_invalid([] { head_frame_from_rest(small_rig(), kHead, kLeftHip, kLeftHip); }, "coincide");
  // One hip straight above the other: no horizontal axis, no forward.
  const Skeleton stacked({"pelvis", "a", "b"}, {-1, 0, 0}, {Vector3d(0, 0, 1), Vector3d(0, 0, 0.1), Vector3d(0, 0, -0.1)});
  expect_invalid([&] { head_frame_from_rest(stacked, 0, 1, 2); }, "along z");
}

TEST(CameraRigsTest, EgoHeadFollowsTheHeadOnEveryFrame) {
  // The pelvis walks and sways its heading; the head turns (yaw up to 0.8 rad) and nods (pitch up
  // to 0.4 rad) on top.
  const Motion motion{
      [](double t) { return Vector3d(0.2 * t, 0.5 * t, 1 + 0.01 * std::sin(3 * t)); },
      [](double t) { return rz(0.3 * std::sin(2 * t)); },
      [](double t) { return rz(0.8 * std::sin(1.5 * t)) * rx(0.4 * std::sin(2.5 * t + 0.5)); },
  };
  const int frames = 90;
  const Clip clip = clip_of(motion, frames, 30);
  EgoHeadOptions options;
  options.forward_offset = 0.12;
  options.up_offset = 0.07;
  const HeadFrame frame = head_frame_from_rest(clip.skeleton, kHead, kLeftHip, kRightHip);
  const CameraPath path = ego_head_camera_path(TimedClip(clip), kHead, frame, kIntrinsics, options);
  path.validate();
  EXPECT_EQ(path.kind, "ego-head");
  EXPECT_EQ(path.fps, 30);
  ASSERT_EQ(path.frame_count(), frames);
  ASSERT_EQ(path.intrinsics.size(), std::size_t(frames));
  double largest_turn = 0;
  for (int f = 0; f < frames; ++f) {
    const double t = f / 30.0;
    const Quaterniond turn = head_turn(motion, t);
    // centre = p + R (forward_offset f_h + up_offset u_h), with R f_h = turn y and R u_h = turn z.
    const Vector3d centre = head_position(motion, t) + turn * Vector3d(0, 0.12, 0.07);
    const Vector3d forward = turn * Vector3d::UnitY();
    const CameraPose& pose = path.poses[f];
    EXPECT_LT((pose.centre() - centre).norm(), 1e-9) << f;
    EXPECT_LT((pose.forward() - forward).norm(), 1e-9) << f;
    // forward and the head's up are orthogonal, so image down is exactly minus the head's up.
    EXPECT_LT((pose.down() + turn * Vector3d::UnitZ()).norm(), 1e-9) << f;
    largest_turn = std::max(largest_turn, std::acos(std::min(1.0, forward.y())));
  }
  EXPECT_GT(largest_turn, 0.7);  // the camera really turned with the head

  // The bone-map overload finds the same joints and gives the same path.
  retarget::BoneMap map;
  map.joints[retarget::canonical::head] = kHead;
  map.joints[retarget::canonical::left_hip] = kLeftHip;
  map.joints[retarget::canonical::right_hip] = kRightHip;
  const CameraPath mapped = ego_head_camera_path(TimedClip(clip), map, kIntrinsics, options);
  ASSERT_EQ(mapped.frame_count(), frames);
  for (int f = 0; f < frames; ++f) {
    EXPECT_EQ(mapped.poses[f].rotation, path.poses[f].rotation) << f;
    EXPECT_EQ(mapped.poses[f].translation, path.poses[f].translation) << f;
  }
}

// The interior frames: at least 3 sigma from either end.
bool interior(int f, int frames, double sigma_frames) { return f >= 3 * sigma_frames && frames - 1 - f >= 3 * sigma_frames; }

TEST(CameraRigsTest, SmoothingKeepsStraightMotion) {
  // The pelvis moves in a straight line at constant velocity and the head turns about z at a
  // constant 0.9 rad/s (tilted down by a fixed 0.2 rad); with no eye offsets the camera centre is
  // the head joint, which moves in a straight line, and its orientation turns at a constant rate
  // about a fixed axis: both pass through a symmetric window unchanged.
  const Motion motion{
      [](double t) { return Vector3d(0.3 * t, 1.0 * t, 1 - 0.1 * t); },
      [](double) { return rz(0.4); },
      [](double t) { return rz(0.9 * t) * rx(-0.2); },
  };
  const int frames = 91;
  const Clip clip = clip_of(motion, frames, 30);
  const HeadFrame frame = head_frame_from_rest(clip.skeleton, kHead, kLeftHip, kRightHip);
  EgoHeadOptions options;
  options.forward_offset = 0;
  options.up_offset = 0;
  const CameraPath raw = ego_head_camera_path(TimedClip(clip), kHead, frame, kIntrinsics, options);
  options.smoothing_sigma_s = 0.05;  // 1.5 frames
  const CameraPath smooth = ego_head_camera_path(TimedClip(clip), kHead, frame, kIntrinsics, options);
  smooth.validate();
  int checked = 0;
  for (int f = 0; f < frames; ++f) {
    if (!interior(f, frames, 1.5)) continue;
    ++checked;
    EXPECT_LT((smooth.poses[f].centre() - raw.poses[f].centre()).norm(), 1e-9) << f;
    EXPECT_LT((smooth.poses[f].rotation - raw.poses[f].rotation).norm(), 1e-9) << f;
  }
  EXPECT_EQ(checked, frames - 10);  // frames 5..85
  // At the very first frame the window is cut to frames 0..4, all ahead along the line: the
  // smoothing is really on (a bias of about 5 cm at 1.05 m/s).
  EXPECT_GT((smooth.poses[0].centre() - raw.poses[0].centre()).norm(), 0.01);
}

TEST(CameraRigsTest, SmoothingReducesA10HzWobbleByTheGaussianGain) {
  // At 120 fps the pelvis walks along +y and wobbles sideways, 1 cm at 10 Hz, and the head shakes
  // 0.05 rad at 10 Hz about z. With no eye offsets the camera's x is the pelvis's x, and its yaw
  // (the heading of its forward axis) is pi/2 + the shake.
  const double fps = 120, hz = 10, omega = 2 * kPi * hz;
  const Motion motion{
      [omega](double t) { return Vector3d(0.01 * std::sin(omega * t), 0.5 * t, 1); },
      [](double) { return Quaterniond::Identity(); },
      [omega](double t) { return rz(0.05 * std::sin(omega * t + 0.3)); },
  };
  const int frames = 241;
  const Clip clip = clip_of(motion, frames, fps);
  const HeadFrame frame = head_frame_from_rest(clip.skeleton, kHead, kLeftHip, kRightHip);
  EgoHeadOptions options;
  options.forward_offset = 0;
  options.up_offset = 0;
  const CameraPath raw = ego_head_camera_path(TimedClip(clip), kHead, frame, kIntrinsics, options);
  const double sigma = 0.02;  // 2.4 frames
  options.smoothing_sigma_s = sigma;
  const CameraPath smooth = ego_head_camera_path(TimedClip(clip), kHead, frame, kIntrinsics, options);

  const auto sideways = [](const CameraPose& pose) { return pose.centre().x(); };
  const auto yaw = [](const CameraPose& pose) { return std::atan2(pose.forward().y(), pose.forward().x()) - kPi / 2; };
  // sigma 0 is the unsmoothed path: the hand-written wobble, undamped.
  for (int f = 0; f < frames; ++f) {
    const double t = f / fps;
    ASSERT_NEAR(sideways(raw.poses[f]), 0.01 * std::sin(omega * t), 1e-12) << f;
    ASSERT_NEAR(yaw(raw.poses[f]), 0.05 * std::sin(omega * t + 0.3), 1e-12) << f;
  }

  // Least-squares gain of the smoothed signal against the raw one over the interior, and the
  // largest deviation from that scaled copy (zero phase: none beyond rounding and, for the
  // quaternion mean, terms of order amplitude^3).
  const auto gain = [&](const std::function<double(const CameraPose&)>& signal, double* worst) {
    double num = 0, den = 0;
    for (int f = 0; f < frames; ++f) {
      if (!interior(f, frames, sigma * fps)) continue;
      num += signal(smooth.poses[f]) * signal(raw.poses[f]);
      den += signal(raw.poses[f]) * signal(raw.poses[f]);
    }
    const double g = num / den;
    *worst = 0;
    for (int f = 0; f < frames; ++f) {
      if (interior(f, frames, sigma * fps)) *worst = std::max(*worst, std::abs(signal(smooth.poses[f]) - g * signal(raw.poses[f])));
    }
    return g;
  };
  // exp(-(2 pi 10 Hz 0.02 s)^2 / 2) = 0.4540; the filter sampled at 120 fps and cut at 3 sigma
  // has 0.4554 at 10 Hz, and a 10% error in sigma would move it by 0.07.
  const double expected = std::exp(-std::pow(omega * sigma, 2) / 2);
  double worst = 0;
  EXPECT_NEAR(gain(sideways, &worst), expected, 0.005);
  EXPECT_LT(worst, 1e-12);
  EXPECT_NEAR(gain(yaw, &worst), expected, 0.005);
  EXPECT_LT(worst, 1e-4 * 0.05);
  // The walk along +y is a straight line: unchanged in the interior.
  for (int f = 0; f < frames; ++f) {
    if (interior(f, frames, sigma * fps)) {
      EXPECT_NEAR(smooth.poses[f].centre().y(), 0.5 * f / fps + 0.02, 1e-12) << f;
    }
  }
}

TEST(CameraRigsTest, RejectsBadOptions) {
  StaticCameraOptions still;
  expect_invalid([&] { static_camera_path(0, 30, kIntrinsics, still); }, "frames");
  expect_invalid([&] { static_camera_path(10, 0, kIntrinsics, still); }, "fps");
  expect_invalid([&] { static_camera_path(10, -30, kIntrinsics, still); }, "fps");
  PinholeIntrinsics no_focal = kIntrinsics;
  no_focal.fx = 0;
  expect_invalid([&] { static_camera_path(10, 30, no_focal, still); }, "intrinsics");
  expect_invalid([] { intrinsics_from_hfov(960, 540, 0); }, "field of view");
  expect_invalid([] { intrinsics_from_hfov(960, 540, -45); }, "field of view");
  still.target = still.centre;
  expect_invalid([&] { static_camera_path(10, 30, kIntrinsics, still); }, "centre and target");
  still.centre = Vector3d(0, 0, 5);
  still.target = Vector3d(0, 0, 1);  // straight down the up axis
  expect_invalid([&] { static_camera_path(10, 30, kIntrinsics, still); }, "centre and target");
  still.target = Vector3d(0, std::numeric_limits<double>::quiet_NaN(), 1);
  expect_invalid([&] { static_camera_path(10, 30, kIntrinsics, still); }, "target");

  OrbitCameraOptions orbit;
  orbit.radius = 0;
  expect_invalid([&] { orbit_camera_path(10, 30, kIntrinsics, orbit); }, "radius");
  orbit.radius = -2;
  expect_invalid([&] { orbit_camera_path(10, 30, kIntrinsics, orbit); }, "radius");
  orbit.radius = 4;
  orbit.period_s = 0;
  expect_invalid([&] { orbit_camera_path(10, 30, kIntrinsics, orbit); }, "period_s");
  orbit.period_s = std::numeric_limits<double>::infinity();
  expect_invalid([&] { orbit_camera_path(10, 30, kIntrinsics, orbit); }, "period_s");
  orbit.period_s = 10;
  orbit.height = std::numeric_limits<double>::quiet_NaN();
  expect_invalid([&] { orbit_camera_path(10, 30, kIntrinsics, orbit); }, "height");

  const Motion still_motion{[](double) { return Vector3d(0, 0, 1); }, [](double) { return Quaterniond::Identity(); },
                            [](double) { return Quaterniond::Identity(); }};
  const Clip clip = clip_of(still_motion, 5, 30);
  const HeadFrame frame = head_frame_from_rest(clip.skeleton, kHead, kLeftHip, kRightHip);
  EgoHeadOptions ego;
  ego.smoothing_sigma_s = -0.01;
  expect_invalid([&] { ego_head_camera_path(TimedClip(clip), kHead, frame, kIntrinsics, ego); }, "smoothing_sigma_s");
  ego.smoothing_sigma_s = 0;
  ego.forward_offset = std::numeric_limits<double>::infinity();
  expect_invalid([&] { ego_head_camera_path(TimedClip(clip), kHead, frame, kIntrinsics, ego); }, "forward_offset");
  ego.forward_offset = 0.1;
  expect_invalid([&] { ego_head_camera_path(TimedClip(clip), 9, frame, kIntrinsics, ego); }, "head joint 9");
  HeadFrame looking_up;
  looking_up.forward_local = Vector3d(0, 0, 2);
  expect_invalid([&] { ego_head_camera_path(TimedClip(clip), kHead, looking_up, kIntrinsics, ego); }, "head_frame");
  Clip empty = clip;
  empty.rotations.clear();
  empty.translations.clear();
  expect_invalid([&] { ego_head_camera_path(TimedClip(empty), kHead, frame, kIntrinsics, ego); }, "frames");

  retarget::BoneMap map;
  map.joints[retarget::canonical::left_hip] = kLeftHip;
  map.joints[retarget::canonical::right_hip] = kRightHip;
  expect_invalid([&] { ego_head_camera_path(TimedClip(clip), map, kIntrinsics, ego); }, "no head");
  map.joints[retarget::canonical::head] = kHead;
  map.joints[retarget::canonical::right_hip] = -1;
  expect_invalid([&] { ego_head_camera_path(TimedClip(clip), map, kIntrinsics, ego); }, "right_hip");
  map.joints[retarget::canonical::right_hip] = kRightHip;
  EXPECT_EQ(ego_head_camera_path(TimedClip(clip), map, kIntrinsics, ego).frame_count(), 5);
}

// The ego camera on a real character in its rest pose: it sits in front of and above the head
// joint and looks level, the way the hips say the character faces; the toes (ankle to ball of the
// foot, where mapped) agree on which way that is.
void check_rest_pose_ego_camera(const std::string& path) {
  SCOPED_TRACE(path);
  const Character character = io::load_character(path);
  const retarget::BoneMap map = retarget::humanoid_bone_map(character.skeleton, path, "");
  const Skeleton& rig = character.skeleton;
  Clip clip;
  clip.skeleton = rig;
  clip.fps = 30;
  for (int f = 0; f < 4; ++f) clip.rotations.insert(clip.rotations.end(), rig.rest_rotations().begin(), rig.rest_rotations().end());
  const EgoHeadOptions options;
  const CameraPath camera = ego_head_camera_path(TimedClip(clip), map, kIntrinsics, options);
  camera.validate();
  ASSERT_EQ(camera.frame_count(), 4);

  namespace canonical = retarget::canonical;
  const std::vector<RigidTransform<double>> rest = rig.rest_world();
  const Vector3d hips = rest[map.joints[canonical::left_hip]].translation - rest[map.joints[canonical::right_hip]].translation;
  const Vector3d facing = hips.cross(Vector3d::UnitZ()).normalized();
  const Vector3d head = rest[map.joints[canonical::head]].translation;
  for (const CameraPose& pose : camera.poses) {
    EXPECT_NEAR(pose.forward().z(), 0, 1e-9);  // level
    EXPECT_GT(pose.forward().dot(facing), 1 - 1e-9);
    // centre = head + 0.1 facing + 0.08 z at rest.
    EXPECT_LT((pose.centre() - (head + 0.1 * facing + 0.08 * Vector3d::UnitZ())).norm(), 1e-9);
  }
  for (const auto& [ankle, ball] : {std::pair{canonical::left_ankle, canonical::left_foot},
                                    std::pair{canonical::right_ankle, canonical::right_foot}}) {
    if (!map.mapped(ankle) || !map.mapped(ball)) continue;
    Vector3d toes = rest[map.joints[ball]].translation - rest[map.joints[ankle]].translation;
    toes.z() = 0;
    EXPECT_GT(camera.poses[0].forward().dot(toes.normalized()), std::cos(30 * kPi / 180));
  }
}

TEST(CameraRigsTest, EgoCameraOnRealCharacters) {
  check_rest_pose_ego_camera(std::string(ODYSSEY_DATA_DIR) + "/characters/RiggedFigure.glb");
  check_rest_pose_ego_camera(std::string(ODYSSEY_SHARED_DIR) + "/assets/characters/RobotExpressive.glb");
}

}  // namespace
}  // namespace odyssey::scene
