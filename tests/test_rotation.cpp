// Rotation conversions against slow references computed independently of the library.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "skeleton/rotation.h"

namespace odyssey {
namespace {

using Matrix3l = Eigen::Matrix<long double, 3, 3>;

// exp([r]x) by scaling and squaring of the power series in long double: a route to the rotation
// matrix that shares nothing with Rodrigues' closed form.
Eigen::Matrix3d slow_exact_rotation(const Eigen::Vector3d& r) {
  Matrix3l k;
  k << 0, -r.z(), r.y(), r.z(), 0, -r.x(), -r.y(), r.x(), 0;
  int squarings = 0;
  long double norm = r.cast<long double>().norm();
  while (norm > 0.25L) {
    norm /= 2;
    ++squarings;
  }
  k /= std::ldexp(1.0L, squarings);
  Matrix3l sum = Matrix3l::Identity(), term = Matrix3l::Identity();
  for (int n = 1; n < 30; ++n) {
    term = term * k / static_cast<long double>(n);
    sum += term;
  }
  for (int s = 0; s < squarings; ++s) sum = sum * sum;
  return sum.cast<double>();
}

void expect_rotation_near(const Eigen::Matrix3d& actual, const Eigen::Matrix3d& expected, double tolerance) {
  EXPECT_LT((actual - expected).cwiseAbs().maxCoeff(), tolerance) << "actual\n" << actual << "\nexpected\n" << expected;
}

TEST(RodriguesTest, MatchesSlowExactReferenceAcrossAngles) {
  const Eigen::Vector3d axis = Eigen::Vector3d(0.3, -0.5, 0.81).normalized();
  for (double angle : {0.0, 1e-9, 1e-6, 0.5, std::numbers::pi - 1e-6, std::numbers::pi, 2 * std::numbers::pi, 10.0}) {
    SCOPED_TRACE(angle);
    const Eigen::Vector3d r = angle * axis;
    expect_rotation_near(rodrigues<double>(r), slow_exact_rotation(r), 1e-14);
  }
}

TEST(RodriguesTest, IsExactlyIdentityAtZero) {
  EXPECT_EQ(rodrigues<double>(Eigen::Vector3d::Zero()), Eigen::Matrix3d::Identity());
}

TEST(RodriguesTest, TinyAngleKeepsFirstOrderTerm) {
  // At 1e-9 rad the off-diagonal entries are +-1e-9 * axis; a formula that rounds to the
  // identity (e.g. 1 - cos computed directly) would lose them.
  const Eigen::Vector3d r(0, 0, 1e-9);
  const Eigen::Matrix3d m = rodrigues<double>(r);
  EXPECT_NEAR(m(1, 0), 1e-9, 1e-24);
  EXPECT_NEAR(m(0, 1), -1e-9, 1e-24);
}

TEST(RodriguesTest, BeyondTwoPiWrapsAround) {
  const Eigen::Vector3d axis = Eigen::Vector3d(1, 2, 3).normalized();
  expect_rotation_near(rodrigues<double>((0.7 + 4 * std::numbers::pi) * axis), rodrigues<double>(0.7 * axis), 1e-13);
}

TEST(RodriguesTest, QuaternionRouteAgrees) {
  const Eigen::Vector3d axis = Eigen::Vector3d(-0.2, 0.9, 0.4).normalized();
  for (double angle : {0.0, 1e-9, 1.0, std::numbers::pi - 1e-6, std::numbers::pi, 10.0}) {
    SCOPED_TRACE(angle);
    const Eigen::Vector3d r = angle * axis;
    expect_rotation_near(quaternion_from_axis_angle<double>(r).toRotationMatrix(), slow_exact_rotation(r), 1e-14);
  }
}

TEST(AxisAngleTest, RoundTripsNearPiAndZero) {
  const Eigen::Vector3d axis = Eigen::Vector3d(0.6, -0.64, 0.48).normalized();
  for (double angle : {1e-12, 1e-9, 0.3, std::numbers::pi - 1e-6, std::numbers::pi - 1e-9}) {
    SCOPED_TRACE(angle);
    const Eigen::Vector3d r = angle * axis;
    EXPECT_LT((axis_angle_from_matrix(rodrigues<double>(r)) - r).norm(), 1e-12 + 1e-9 * angle);
  }
  // Exactly pi: the axis is determined up to sign, and both signs are the same rotation.
  const Eigen::Vector3d r = std::numbers::pi * axis;
  const Eigen::Vector3d back = axis_angle_from_matrix(rodrigues<double>(r));
  EXPECT_NEAR(back.norm(), std::numbers::pi, 1e-12);
  EXPECT_NEAR(std::abs(back.normalized().dot(axis)), 1.0, 1e-12);
}

Eigen::Matrix3d axis_rotation(int axis, double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  Eigen::Matrix3d m;
  switch (axis) {
    case 0: m << 1, 0, 0, 0, c, -s, 0, s, c; break;
    case 1: m << c, 0, s, 0, 1, 0, -s, 0, c; break;
    default: m << c, -s, 0, s, c, 0, 0, 0, 1; break;
  }
  return m;
}

class EulerOrderTest : public ::testing::TestWithParam<const char*> {};

TEST_P(EulerOrderTest, ComposesInListedOrderAndRoundTrips) {
  const std::string name = GetParam();
  const EulerOrder order = *parse_euler_order(name);
  const int axes[3] = {name[0] - 'X', name[1] - 'X', name[2] - 'X'};
  for (const Eigen::Vector3d& angles : {Eigen::Vector3d(0.3, -0.7, 1.9), Eigen::Vector3d(-2.5, 1.2, -0.4),
                                       Eigen::Vector3d(0.2, std::numbers::pi / 2, 0.0),
                                       Eigen::Vector3d(-1.0, -std::numbers::pi / 2, 0.0)}) {
    SCOPED_TRACE(angles.transpose());
    const Eigen::Matrix3d expected =
        axis_rotation(axes[0], angles[0]) * axis_rotation(axes[1], angles[1]) * axis_rotation(axes[2], angles[2]);
    const Eigen::Quaterniond q = quaternion_from_euler<double>(order, angles);
    expect_rotation_near(q.toRotationMatrix(), expected, 1e-14);
    const Eigen::Vector3d back = euler_from_quaternion(order, q);
    EXPECT_LE(std::abs(back[1]), std::numbers::pi / 2 + 1e-12);
    expect_rotation_near(quaternion_from_euler<double>(order, back).toRotationMatrix(), expected, 1e-9);
  }
}

INSTANTIATE_TEST_SUITE_P(AllOrders, EulerOrderTest, ::testing::Values("XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"));

TEST(EulerOrderParseTest, RejectsRepeatedAxesAndJunk) {
  EXPECT_TRUE(parse_euler_order("zxy").has_value());
  EXPECT_FALSE(parse_euler_order("XXY").has_value());
  EXPECT_FALSE(parse_euler_order("XY").has_value());
  EXPECT_FALSE(parse_euler_order("ABC").has_value());
}

TEST(YUpToZUpTest, MapsUpToUpAndForwardToMinusY) {
  const Eigen::Matrix3d c = y_up_to_z_up();
  EXPECT_TRUE((c * Eigen::Vector3d::UnitY()).isApprox(Eigen::Vector3d::UnitZ()));
  EXPECT_TRUE((c * Eigen::Vector3d::UnitZ()).isApprox(-Eigen::Vector3d::UnitY()));
  EXPECT_NEAR(c.determinant(), 1.0, 1e-15);
}

}  // namespace
}  // namespace odyssey
