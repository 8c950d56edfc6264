// Skeleton construction, forward kinematics (the model, its validation, joint subsets, joints
// whose rotation is held in world, both rotation forms, derivatives on Ceres jets) against
// hand-computed chains and finite differences, and clip resampling.
#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <string>

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

// Every invalid tree is refused with a message that says what is wrong.
TEST(KinematicModelTest, RejectsInvalidTrees) {
  const auto message = [](auto&& build) {
    try {
      build();
    } catch (const std::invalid_argument& error) {
      return std::string(error.what());
    }
    return std::string("accepted");
  };
  const std::vector<RigidTransform<double>> three(3);
  EXPECT_NE(message([&] { KinematicModel({-1, 0, 1}, std::vector<RigidTransform<double>>(2)); }).find("3 parents but 2 rest"),
            std::string::npos);
  EXPECT_NE(message([&] { KinematicModel({-1, 0, 1}, three, {0, 1}); }).find("3 parents but 2 joints in the order"), std::string::npos);
  EXPECT_NE(message([&] { KinematicModel({-1, 0, 1}, three, {}, {0, 1}); }).find("3 parents but 2 rotation_in_world"),
            std::string::npos);
  EXPECT_NE(message([&] { KinematicModel({-1, 0, 3}, three); }).find("parent 3, out of range"), std::string::npos);
  EXPECT_NE(message([&] { KinematicModel({-1, 2, 0}, three); }).find("before its parent"), std::string::npos);
  EXPECT_NE(message([&] { KinematicModel({-1, 0, 0}, three, {0, 1, 1}); }).find("twice"), std::string::npos);
  EXPECT_NE(message([&] { KinematicModel({-1, 0, 0}, three, {0, 1, 5}); }).find("out of range"), std::string::npos);
  // A joint may hang from a later one when the order places the later one first.
  EXPECT_EQ(message([&] { KinematicModel({-1, 2, 0}, three, {0, 2, 1}); }), "accepted");

  const KinematicModel model({-1, 0, 1}, three);
  KinematicData<double> short_data(KinematicModel({-1, 0}, {}));
  EXPECT_NE(message([&] { forward_kinematics(model, short_data); }).find("data for 2 joints, model of 3"), std::string::npos);
}

// A joint whose rotation is held in world rides on its parent's position only: turning the
// parent moves it but does not turn it.
TEST(ForwardKinematicsTest, RotationInWorldFollowsOnlyTheParentsPosition) {
  // root -> shin (1 m along x) -> foot (0.5 m along x in the shin's frame, its rotation in world).
  const KinematicModel model({-1, 0, 1}, {}, {}, {0, 0, 1});
  KinematicData<double> data(model);
  data.local[1].translation = Vector3d(1, 0, 0);
  data.local[1].rotation = about_z(std::numbers::pi / 2).toRotationMatrix();
  data.local[2].translation = Vector3d(0.5, 0, 0);
  data.local[2].rotation = about_x(0.3).toRotationMatrix();
  forward_kinematics(model, data);
  // The shin turned 90 deg about z: the foot sits 0.5 m along +y from (1,0,0), and keeps its own
  // rotation about x.
  EXPECT_LT((data.world[2].translation - Vector3d(1, 0.5, 0)).norm(), 1e-15);
  EXPECT_LT((data.world[2].rotation - about_x(0.3).toRotationMatrix()).norm(), 1e-15);
}

// Forward kinematics over a subset recomputes the listed joints only, from parents either listed
// before them or left in the data.
TEST(ForwardKinematicsTest, SubsetReadsUnlistedParentsFromTheData) {
  const Skeleton skeleton = arm();
  const KinematicModel& model = skeleton.kinematics();
  KinematicData<double> data(model);
  forward_kinematics(model, data);
  const std::vector<RigidTransform<double>> rest = data.world;
  data.local[0].rotation = about_z(std::numbers::pi / 2).toRotationMatrix();
  data.local[2].rotation = about_x(1.0).toRotationMatrix();
  const std::vector<int> wrist{2};
  forward_kinematics(model, data, wrist);
  EXPECT_EQ(data.world[0].translation, rest[0].translation);  // not listed: untouched
  EXPECT_EQ(data.world[1].translation, rest[1].translation);
  EXPECT_LT((data.world[2].translation - Vector3d(2.5, 0, 0)).norm(), 1e-15);  // from the elbow as it was
  const std::vector<int> all{0, 1, 2};
  forward_kinematics(model, data, all);
  EXPECT_LT((data.world[2].translation - Vector3d(1, 1.5, 0)).norm(), 1e-15);
}

// A random tree (parents anywhere, placed through `order`, some rotations held in world), posed
// at random.
struct RandomTree {
  KinematicModel model;
  std::vector<QuaternionTransform<double>> local;
};

RandomTree random_tree(int joints, unsigned seed) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<double> uniform(-1, 1);
  std::vector<int> order(joints);
  for (int k = 0; k < joints; ++k) order[k] = k;
  std::shuffle(order.begin(), order.end(), random);
  std::vector<int> parents(joints, -1);
  std::vector<std::uint8_t> in_world(joints, 0);
  for (int k = 1; k < joints; ++k) {
    parents[order[k]] = order[std::uniform_int_distribution<int>(0, k - 1)(random)];
    in_world[order[k]] = k % 4 == 3;
  }
  RandomTree tree{KinematicModel(parents, {}, order, in_world), {}};
  for (int j = 0; j < joints; ++j) {
    const Quaterniond q = Quaterniond(uniform(random), uniform(random), uniform(random), uniform(random)).normalized();
    tree.local.push_back({q, Vector3d(uniform(random), uniform(random), uniform(random))});
  }
  return tree;
}

// The quaternion and the matrix forms are two routes to the same poses.
TEST(ForwardKinematicsTest, QuaternionAndMatrixFormsAgree) {
  for (unsigned seed = 0; seed < 10; ++seed) {
    const RandomTree tree = random_tree(25, seed);
    KinematicData<double> matrices(tree.model);
    QuaternionKinematicData<double> quaternions(tree.model);
    quaternions.base = {about_x(0.4), Vector3d(0.1, -2, 3)};
    matrices.base = {quaternions.base.rotation.toRotationMatrix(), quaternions.base.translation};
    for (std::size_t j = 0; j < tree.local.size(); ++j) {
      quaternions.local[j] = tree.local[j];
      matrices.local[j] = {tree.local[j].rotation.toRotationMatrix(), tree.local[j].translation};
    }
    forward_kinematics(tree.model, matrices);
    forward_kinematics(tree.model, quaternions);
    for (std::size_t j = 0; j < tree.local.size(); ++j) {
      EXPECT_LT((matrices.world[j].translation - quaternions.world[j].translation).norm(), 1e-13) << seed << " " << j;
      EXPECT_LT((matrices.world[j].rotation - quaternions.world[j].rotation.toRotationMatrix()).norm(), 1e-13) << seed << " " << j;
    }
  }
}

// On jets, the derivatives of every joint's world position with respect to one joint's local
// rotation (a rotation vector applied after it) and the base's translation match central finite
// differences.
TEST(ForwardKinematicsTest, JetDerivativesMatchFiniteDifferences) {
  using Jet = ceres::Jet<double, 6>;
  const RandomTree tree = random_tree(12, 7);
  const int joints = static_cast<int>(tree.local.size());
  const int turned = tree.model.order[2];
  // Positions with joint `turned` turned by the rotation vector x[0..2] and the base moved by x[3..5].
  const auto positions = [&](const auto* x) {
    using T = std::remove_cv_t<std::remove_pointer_t<decltype(x)>>;
    using std::cos;
    using std::sin;
    using std::sqrt;
    QuaternionKinematicData<T> data(tree.model);
    for (int j = 0; j < joints; ++j) data.local[j] = tree.local[j].template cast<T>();
    const T angle = sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
    const T k = sin(angle / 2.0) / angle;
    data.local[turned].rotation = data.local[turned].rotation * Eigen::Quaternion<T>(cos(angle / 2.0), k * x[0], k * x[1], k * x[2]);
    data.base.translation = Eigen::Matrix<T, 3, 1>(x[3], x[4], x[5]);
    forward_kinematics(tree.model, data);
    std::vector<Eigen::Matrix<T, 3, 1>> out;
    for (const auto& joint : data.world) out.push_back(joint.translation);
    return out;
  };
  const double at[6] = {0.3, -0.2, 0.1, 0.5, 0.0, -0.5};
  Jet x[6];
  for (int k = 0; k < 6; ++k) x[k] = Jet(at[k], k);
  const auto jets = positions(static_cast<const Jet*>(x));
  constexpr double h = 1e-6;
  for (int k = 0; k < 6; ++k) {
    double plus[6], minus[6];
    std::copy(at, at + 6, plus);
    std::copy(at, at + 6, minus);
    plus[k] += h;
    minus[k] -= h;
    const auto above = positions(static_cast<const double*>(plus)), below = positions(static_cast<const double*>(minus));
    for (int j = 0; j < joints; ++j) {
      for (int i = 0; i < 3; ++i) EXPECT_NEAR(jets[j][i].v[k], (above[j][i] - below[j][i]) / (2 * h), 1e-8) << j << " " << i << " " << k;
    }
  }
}

// The skeleton's model is its rest pose: rest_world and a clip's frame at rest agree with it.
TEST(ForwardKinematicsTest, SkeletonModelIsItsRestPose) {
  const Skeleton skeleton = arm();
  QuaternionKinematicData<double> data(skeleton.kinematics());
  forward_kinematics(skeleton.kinematics(), data);
  const std::vector<RigidTransform<double>> rest = skeleton.rest_world();
  for (int j = 0; j < skeleton.joint_count(); ++j) EXPECT_LT((data.world[j].translation - rest[j].translation).norm(), 1e-15);
  EXPECT_LT((rest[2].translation - Vector3d(2.5, 0, 0)).norm(), 1e-15);
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
