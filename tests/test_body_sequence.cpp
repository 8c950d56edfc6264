// BodySequence: validation, resampling (exact copies on source frames, slerp midpoints checked by
// hand) and the procedural walk (deterministic, finite, moving the documented way, feet planted).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include "skeleton/body_sequence.h"
#include "skeleton/rotation.h"
#include "synthetic/synthetic_walk.h"

namespace odyssey {
namespace {

// A sequence whose values are a simple function of frame and column, so copies can be checked.
BodySequence ramp(int frames, double fps, BodyModelKind kind) {
  BodySequence sequence;
  sequence.kind = kind;
  sequence.fps = fps;
  sequence.betas = {0.5, -0.25};
  const int width = 3 * body_model_joint_count(kind);
  sequence.poses.resize(frames, width);
  sequence.translations.resize(frames, 3);
  for (int f = 0; f < frames; ++f) {
    for (int c = 0; c < width; ++c) sequence.poses(f, c) = 0.3 * std::sin(0.05 * f + 0.7 * c);
    sequence.translations.row(f) << 0.01 * f, -0.02 * f, 0.9;
  }
  return sequence;
}

TEST(BodySequenceTest, ValidateNamesTheFirstBadFrame) {
  BodySequence sequence = ramp(10, 30, BodyModelKind::SMPLX);
  EXPECT_NO_THROW(sequence.validate());
  sequence.poses(7, 40) = std::numeric_limits<double>::quiet_NaN();
  try {
    sequence.validate();
    ADD_FAILURE() << "no error";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("frame 7, joint 13"), std::string::npos) << error.what();
  }
  sequence = ramp(10, 30, BodyModelKind::SMPLX);
  sequence.translations(3, 2) = std::numeric_limits<double>::infinity();
  EXPECT_THROW(sequence.validate(), std::invalid_argument);
  sequence = ramp(10, 30, BodyModelKind::SMPLX);
  sequence.kind = BodyModelKind::SMPLH;  // 165 columns do not fit SMPL-H's 156
  EXPECT_THROW(sequence.validate(), std::invalid_argument);
  sequence = ramp(10, 0, BodyModelKind::SMPLX);
  EXPECT_THROW(sequence.validate(), std::invalid_argument);
}

TEST(BodySequenceTest, ResamplingTo30FpsKeepsEveryFourthFrameExactly) {
  const BodySequence source = ramp(121, 120, BodyModelKind::SMPLX);  // exactly one second
  const BodySequence target = source.resampled(30);
  ASSERT_EQ(target.frame_count(), 31);
  EXPECT_EQ(target.fps, 30);
  EXPECT_EQ(target.betas, source.betas);
  for (int f = 0; f < target.frame_count(); ++f) {
    EXPECT_EQ(target.poses.row(f), source.poses.row(4 * f)) << "frame " << f;
    EXPECT_EQ(target.translations.row(f), source.translations.row(4 * f)) << "frame " << f;
  }
}

TEST(BodySequenceTest, ResamplingTo60FpsSlerpsMidwayRotations) {
  BodySequence source;
  source.kind = BodyModelKind::SMPLH;
  source.fps = 30;
  source.poses = RowMatrixXd::Zero(2, 156);
  source.translations.resize(2, 3);
  source.translations << 0, 0, 0.9, 0.04, -0.02, 0.94;
  const double half_pi = std::numbers::pi / 2;
  // Joint 1: 90 degrees about x, then 90 degrees about y.
  source.poses.row(0).segment<3>(3) << half_pi, 0, 0;
  source.poses.row(1).segment<3>(3) << 0, half_pi, 0;
  // Joint 2: from rest to 90 degrees about z.
  source.poses.row(1).segment<3>(6) << 0, 0, half_pi;
  // Joint 3: 3 rad about z, then -3 rad about z: the short way passes through pi, not 0.
  source.poses.row(0).segment<3>(9) << 0, 0, 3.0;
  source.poses.row(1).segment<3>(9) << 0, 0, -3.0;

  const BodySequence target = source.resampled(60);
  ASSERT_EQ(target.frame_count(), 3);  // t = 0, 1/60, 2/60
  EXPECT_EQ(target.poses.row(0), source.poses.row(0));
  EXPECT_EQ(target.poses.row(2), source.poses.row(1));

  // q0 = (cos 45, sin 45, 0, 0), q1 = (cos 45, 0, sin 45, 0). Their slerp midpoint is
  // (q0 + q1) / |q0 + q1| = (sqrt2, sqrt2/2, sqrt2/2, 0) / sqrt3: the angle is 2 acos(sqrt(2/3))
  // about (1, 1, 0) / sqrt2.
  const double angle = 2 * std::acos(std::sqrt(2.0 / 3.0));
  const Eigen::Vector3d expected = angle * Eigen::Vector3d(1, 1, 0) / std::sqrt(2.0);
  EXPECT_LT((target.poses.row(1).segment<3>(3).transpose() - expected).norm(), 1e-12);
  // Rest to 90 degrees about z: 45 degrees about z.
  EXPECT_LT((target.poses.row(1).segment<3>(6).transpose() - Eigen::Vector3d(0, 0, std::numbers::pi / 4)).norm(),
            1e-12);
  // 3 rad and -3 rad about z are 2 pi - 6 apart through pi: the midpoint is pi about z.
  EXPECT_NEAR(target.poses.row(1).segment<3>(9).norm(), std::numbers::pi, 1e-9);
  EXPECT_NEAR(std::abs(target.poses(1, 11)), std::numbers::pi, 1e-9);
  // Translation: linear.
  EXPECT_LT((target.translations.row(1) - Eigen::RowVector3d(0.02, -0.01, 0.92)).norm(), 1e-15);
  // Untouched joints stay exactly at rest.
  EXPECT_EQ(target.poses.row(1).segment<3>(30), Eigen::RowVector3d::Zero());
}

TEST(BodySequenceTest, ResamplingKeepsTheClipFrameCountRule) {
  // 100 frames at 120 fps last 0.825 s: 30 fps gives frames at 0 .. 24/30 = 0.8 s, 25 frames.
  EXPECT_EQ(ramp(100, 120, BodyModelKind::SMPL).resampled(30).frame_count(), 25);
  EXPECT_EQ(ramp(1, 120, BodyModelKind::SMPL).resampled(30).frame_count(), 1);
  EXPECT_THROW(ramp(10, 120, BodyModelKind::SMPL).resampled(0), std::invalid_argument);
}

TEST(SyntheticWalkTest, IsDeterministicForASeedAndVariesAcrossSeeds) {
  const BodySequence a = synthetic_walk(90, 30, BodyModelKind::SMPLX, 7);
  const BodySequence b = synthetic_walk(90, 30, BodyModelKind::SMPLX, 7);
  const BodySequence c = synthetic_walk(90, 30, BodyModelKind::SMPLX, 8);
  EXPECT_EQ(a.poses, b.poses);
  EXPECT_EQ(a.translations, b.translations);
  double largest_difference = 0;
  for (Eigen::Index i = 0; i < a.poses.size(); ++i) {
    largest_difference = std::max(largest_difference, std::abs(a.poses.data()[i] - c.poses.data()[i]));
  }
  EXPECT_GT(largest_difference, 1e-3);
}

TEST(SyntheticWalkTest, EveryKindValidatesAndHasTheRightShape) {
  for (BodyModelKind kind : {BodyModelKind::SMPL, BodyModelKind::SMPLH, BodyModelKind::SMPLX}) {
    const BodySequence walk = synthetic_walk(300, 60, kind, 3);
    EXPECT_NO_THROW(walk.validate());
    EXPECT_EQ(walk.frame_count(), 300);
    EXPECT_EQ(walk.poses.cols(), 3 * body_model_joint_count(kind));
    EXPECT_EQ(walk.fps, 60);
    EXPECT_EQ(walk.betas.size(), 10u);
    EXPECT_EQ(walk.gender, "neutral");
  }
  EXPECT_THROW(synthetic_walk(0, 30, BodyModelKind::SMPLX, 1), std::invalid_argument);
  EXPECT_THROW(synthetic_walk(10, -30, BodyModelKind::SMPLX, 1), std::invalid_argument);
}

TEST(SyntheticWalkTest, WalksUprightAlongMinusYAtAboutWalkingSpeed) {
  const BodySequence walk = synthetic_walk(301, 30, BodyModelKind::SMPLX, 11);  // 10 s
  const Eigen::RowVector3d travel = walk.translations.row(300) - walk.translations.row(0);
  EXPECT_NEAR(-travel.y() / 10.0, 1.2, 0.1);  // m/s along -Y
  EXPECT_LT(std::abs(travel.x()), 0.05);
  EXPECT_LT(std::abs(travel.z()), 0.05);
  const Eigen::Quaterniond upright(y_up_to_z_up());
  for (int f = 0; f < walk.frame_count(); ++f) {
    EXPECT_GT(walk.translations(f, 2), 0.8);
    EXPECT_LT(walk.translations(f, 2), 1.0);
    // The root stays within about 10 degrees of the upright, -Y facing orientation.
    const Eigen::Quaterniond root = quaternion_from_axis_angle<double>(walk.poses.row(f).segment<3>(0).transpose());
    EXPECT_LT(root.angularDistance(upright), 0.18) << "frame " << f;
  }
}

// Forward kinematics of the legs with the SMPL-X template's rest joints (the same numbers the
// walk is planned for): the stance foot must stay put. Pelvis, hips, knees, ankles, feet.
TEST(SyntheticWalkTest, StanceFeetStayPlanted) {
  const int parents[12] = {-1, 0, 0, -1, 1, 2, -1, 4, 5, -1, 7, 8};
  Eigen::Vector3d rest[12];
  rest[0] = {0, -0.357, 0.007};
  rest[1] = {0.065, -0.44, 0};
  rest[2] = {-0.065, -0.44, 0};
  rest[4] = {0.1, -0.82, 0.005};
  rest[5] = {-0.1, -0.82, 0.005};
  rest[7] = {0.091, -1.215, -0.037};
  rest[8] = {-0.091, -1.215, -0.037};
  rest[10] = {0.115, -1.262, 0.085};  // the ball of the foot, 0.122 ahead of the ankle
  rest[11] = {-0.115, -1.262, 0.085};
  const double fps = 60;
  const BodySequence walk = synthetic_walk(240, fps, BodyModelKind::SMPLX, 5);
  std::vector<Eigen::Vector3d> feet[2];
  for (int f = 0; f < walk.frame_count(); ++f) {
    Eigen::Matrix3d rotation[12];
    Eigen::Vector3d position[12];
    for (int j : {0, 1, 2, 4, 5, 7, 8, 10, 11}) {
      const Eigen::Matrix3d local = rodrigues<double>(walk.poses.row(f).segment<3>(3 * j).transpose());
      if (parents[j] < 0) {
        rotation[j] = local;
        position[j] = rest[0] + walk.translations.row(f).transpose();
      } else {
        rotation[j] = rotation[parents[j]] * local;
        position[j] = position[parents[j]] + rotation[parents[j]] * (rest[j] - rest[parents[j]]);
      }
    }
    feet[0].push_back(position[10]);
    feet[1].push_back(position[11]);
  }
  for (const auto& foot : feet) {
    double lowest = 1e9;
    for (const auto& p : foot) lowest = std::min(lowest, p.z());
    EXPECT_NEAR(lowest, 0.035, 0.01);  // the ball joint sits 3.5 cm above the sole
    // While the ball of the foot is on the ground (within 1 mm of its lowest, from the frame
    // before to the frame after: the frames where it lands and lifts off are not contact), it
    // does not slide: under 2 cm/s horizontally.
    int planted = 0;
    for (std::size_t f = 1; f + 1 < foot.size(); ++f) {
      if (foot[f - 1].z() < lowest + 0.001 && foot[f].z() < lowest + 0.001 && foot[f + 1].z() < lowest + 0.001) {
        ++planted;
        EXPECT_LT((foot[f] - foot[f - 1]).head<2>().norm() * fps, 0.02) << "frame " << f;
      }
    }
    // Stance is 60% of the cycle; the ball is down from foot-flat (8%) to toe-off.
    EXPECT_GT(planted, 0.45 * foot.size());
  }
}

}  // namespace
}  // namespace odyssey
