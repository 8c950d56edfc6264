// Skeleton construction, forward kinematics against hand-computed chains, and clip resampling.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "skeleton/clip.h"
#include "skeleton/fk.h"
#include "skeleton/rotation.h"
#include "skeleton/skeleton.h"

namespace odyssey {
namespace {

using Eigen::Quaterniond;
using Eigen::Vector3d;

Quaterniond about_z(double angle) { return Quaterniond(Eigen::AngleAxisd(angle, Vector3d::UnitZ())); }
Quaterniond about_x(double angle) { return Quaterniond(Eigen::AngleAxisd(angle, Vector3d::UnitX())); }

// root at (1,0,0); a 1 m bone along +x to `elbow`; a 0.5 m bone along +x to `wrist`.
Skeleton arm() {
  return Skeleton({"root", "elbow", "wrist"}, {-1, 0, 1}, {Vector3d(1, 0, 0), Vector3d(1, 0, 0), Vector3d(0.5, 0, 0)});
}

TEST(ForwardKinematicsTest, HandComputedChain) {
  const Skeleton skeleton = arm();
  std::vector<RigidTransform<double>> local(3), world(3);
  skeleton.rest_local(local);
  // Root turns 90 deg about z, elbow a further 90 deg about z, wrist 90 deg about x.
  local[0].rotation = about_z(std::numbers::pi / 2).toRotationMatrix();
  local[1].rotation = about_z(std::numbers::pi / 2).toRotationMatrix();
  local[2].rotation = about_x(std::numbers::pi / 2).toRotationMatrix();
  forward_kinematics<double>(skeleton.parents(), local, world);
  // root stays at (1,0,0); the elbow offset (1,0,0) turned 90 deg lands at (1,1,0); the wrist
  // offset (0.5,0,0) turned 180 deg lands 0.5 m along -x: (0.5,1,0).
  EXPECT_LT((world[0].translation - Vector3d(1, 0, 0)).norm(), 1e-15);
  EXPECT_LT((world[1].translation - Vector3d(1, 1, 0)).norm(), 1e-15);
  EXPECT_LT((world[2].translation - Vector3d(0.5, 1, 0)).norm(), 1e-15);
  // The wrist frame: Rz(180) Rx(90) maps local y to Rz(180) z = z, local z to Rz(180) (-y) = y.
  EXPECT_LT((world[2].rotation * Vector3d::UnitY() - Vector3d::UnitZ()).norm(), 1e-15);
  EXPECT_LT((world[2].rotation * Vector3d::UnitZ() - Vector3d::UnitY()).norm(), 1e-15);
}

TEST(ForwardKinematicsTest, BaseTransformIsAppliedToRoots) {
  const Skeleton skeleton = arm();
  std::vector<RigidTransform<double>> local(3), world(3);
  skeleton.rest_local(local);
  RigidTransform<double> base;
  base.translation = Vector3d(0, 0, 2);
  forward_kinematics<double>(skeleton.parents(), local, world, base);
  EXPECT_LT((world[2].translation - Vector3d(2.5, 0, 2)).norm(), 1e-15);
}

TEST(ForwardKinematicsTest, RunsOnAnotherScalarType) {
  // The template is what Ceres differentiates; long double stands in for a jet here.
  std::vector<RigidTransform<long double>> local(3), world(3);
  local[1].translation << 1, 0, 0;
  local[2].translation << 1, 0, 0;
  local[1].rotation = about_z(std::numbers::pi / 2).toRotationMatrix().cast<long double>();
  const std::vector<int> parents{-1, 0, 1};
  forward_kinematics<long double>(parents, local, world);
  EXPECT_NEAR(static_cast<double>(world[2].translation.y()), 1.0, 1e-15);
}

TEST(SkeletonTest, RejectsParentThatDoesNotPrecede) {
  EXPECT_THROW(Skeleton({"a", "b"}, {1, -1}, {Vector3d::Zero(), Vector3d::Zero()}), std::invalid_argument);
  EXPECT_THROW(Skeleton({"a", "b"}, {-1, 0}, {Vector3d::Zero()}), std::invalid_argument);
  EXPECT_THROW(Skeleton({"a"}, {-1}, {Vector3d(NAN, 0, 0)}), std::invalid_argument);
}

TEST(SkeletonTest, FromUnorderedSortsParentsFirst) {
  std::vector<int> new_index;
  const Skeleton skeleton = Skeleton::from_unordered({"hand", "shoulder", "root", "elbow"}, {3, 2, -1, 1},
                                                     {Vector3d(3, 0, 0), Vector3d(1, 0, 0), Vector3d(0, 0, 0), Vector3d(2, 0, 0)},
                                                     {}, &new_index);
  ASSERT_EQ(skeleton.joint_count(), 4);
  EXPECT_EQ(skeleton.names(), (std::vector<std::string>{"root", "shoulder", "elbow", "hand"}));
  EXPECT_EQ(skeleton.parents(), (std::vector<int>{-1, 0, 1, 2}));
  EXPECT_EQ(new_index, (std::vector<int>{3, 1, 0, 2}));
  EXPECT_EQ(skeleton.rest_world()[3].translation, Vector3d(6, 0, 0));
}

TEST(SkeletonTest, FromUnorderedNamesAJointOnACycle) {
  try {
    Skeleton::from_unordered({"root", "a", "b"}, {-1, 2, 1}, {Vector3d::Zero(), Vector3d::Zero(), Vector3d::Zero()}, {});
    FAIL() << "cycle accepted";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("cycle"), std::string::npos) << error.what();
  }
  EXPECT_THROW(Skeleton::from_unordered({"a"}, {5}, {Vector3d::Zero()}, {}), std::invalid_argument);
}

Clip spinning_clip(int frames, double fps) {
  Clip clip;
  clip.skeleton = arm();
  clip.fps = fps;
  clip.translated_joints = {0};
  for (int f = 0; f < frames; ++f) {
    clip.rotations.push_back(about_z(0.1 * f));
    clip.rotations.push_back(Quaterniond::Identity());
    clip.rotations.push_back(about_x(-0.05 * f));
    clip.translations.push_back(Vector3d(0.01 * f, 0, 0));
  }
  return clip;
}

TEST(ClipTest, ResampleDownKeepsEveryFourthFrameExactly) {
  const Clip clip = spinning_clip(13, 120);
  const Clip down = clip.resampled(30);
  ASSERT_EQ(down.frame_count(), 4);  // times 0, 1/30, 2/30, 3/30 = frames 0, 4, 8, 12
  for (int f = 0; f < 4; ++f) {
    EXPECT_LT(down.rotation(f, 0).angularDistance(clip.rotation(4 * f, 0)), 1e-12);
    EXPECT_LT((down.translations[f] - clip.translations[4 * f]).norm(), 1e-15);
  }
}

TEST(ClipTest, ResampleUpSlerpsMidway) {
  const Clip clip = spinning_clip(3, 30);
  const Clip up = clip.resampled(60);
  ASSERT_EQ(up.frame_count(), 5);
  // Midway between 0.1 rad and 0.2 rad about z is 0.15 rad; translation midway 0.015 m.
  EXPECT_LT(up.rotation(3, 0).angularDistance(about_z(0.15)), 1e-12);
  EXPECT_NEAR(up.translations[3].x(), 0.015, 1e-15);
}

TEST(ClipTest, ValidateNamesTheFrameWithNaN) {
  Clip clip = spinning_clip(5, 30);
  clip.rotations[3 * 3 + 2] = Quaterniond(NAN, 0, 0, 0);
  try {
    clip.validate();
    FAIL() << "NaN accepted";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("frame 3"), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("wrist"), std::string::npos) << error.what();
  }
}

TEST(ClipTest, WorldPoseChainsTranslationAndRotation) {
  const Clip clip = spinning_clip(4, 30);
  std::vector<RigidTransform<double>> world(3);
  clip.world_pose(2, world);
  // Root at (0.02,0,0) turned 0.2 rad: the elbow sits 1 m along (cos 0.2, sin 0.2, 0).
  EXPECT_LT((world[1].translation - Vector3d(0.02 + std::cos(0.2), std::sin(0.2), 0)).norm(), 1e-15);
  EXPECT_LT((world[2].translation - Vector3d(0.02 + 1.5 * std::cos(0.2), 1.5 * std::sin(0.2), 0)).norm(), 1e-15);
}

}  // namespace
}  // namespace odyssey
