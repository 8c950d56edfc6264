// Keyframe tracks (skeleton/keyframes.h) against hand-computed values for each of glTF's samplers,
// and the loop timing of a character's own animation (skeleton/node_animation.h).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <stdexcept>

#include "skeleton/keyframes.h"
#include "skeleton/node_animation.h"

namespace odyssey {
namespace {

std::array<double, 4> sample(const KeyframeTrack& track, double t) {
  std::array<double, 4> out{};
  track.sample(t, std::span(out.data(), track.components));
  return out;
}

TEST(KeyframesTest, StepHoldsEachKeyUntilTheNext) {
  KeyframeTrack track{Interpolation::step, 3, false, {0, 1, 2}, {1, 1, 1, 2, 2, 2, 3, 3, 3}};
  track.validate("step");
  EXPECT_EQ(sample(track, -5)[0], 1);    // before the first key: the first value
  EXPECT_EQ(sample(track, 0.999)[0], 1);
  EXPECT_EQ(sample(track, 1.0)[1], 2);   // a key's own time: its value
  EXPECT_EQ(sample(track, 1.7)[2], 2);
  EXPECT_EQ(sample(track, 9)[0], 3);     // after the last key: the last value
}

TEST(KeyframesTest, LinearInterpolatesTranslations) {
  KeyframeTrack track{Interpolation::linear, 3, false, {2, 6}, {0, 0, 0, 4, 8, -4}};
  track.validate("linear");
  const auto p = sample(track, 3);  // s = 1/4
  EXPECT_DOUBLE_EQ(p[0], 1);
  EXPECT_DOUBLE_EQ(p[1], 2);
  EXPECT_DOUBLE_EQ(p[2], -1);
}

TEST(KeyframesTest, LinearRotationsSlerpTheShorterWay) {
  // From the identity to 90 degrees about z; a third of the way is 30 degrees: (0, 0, sin 15, cos 15).
  const double h = std::sqrt(0.5);
  KeyframeTrack track{Interpolation::linear, 4, true, {0, 3}, {0, 0, 0, 1, 0, 0, h, h}};
  track.validate("rotation");
  auto q = sample(track, 1);
  const double half = 15 * std::numbers::pi / 180;
  EXPECT_NEAR(q[2], std::sin(half), 1e-12);
  EXPECT_NEAR(q[3], std::cos(half), 1e-12);
  EXPECT_NEAR(q[0], 0, 1e-12);
  // The same end key stored with the other sign: still 30 degrees, not 150 the long way round.
  track.values = {0, 0, 0, 1, 0, 0, -h, -h};
  q = sample(track, 1);
  EXPECT_NEAR(std::abs(q[3]), std::cos(half), 1e-12);
  EXPECT_NEAR(std::abs(q[2]), std::sin(half), 1e-12);
  // Not normalised in the file: keys are normalised first.
  track.values = {0, 0, 0, 2, 0, 0, 3 * h, 3 * h};
  q = sample(track, 1);
  EXPECT_NEAR(q[2], std::sin(half), 1e-12);
}

TEST(KeyframesTest, CubicSplineIsHermiteWithTangentsScaledByTheKeyInterval) {
  // Keys at 1 and 3 (d = 2); key 0: value 0, out-tangent (1, 0, 0); key 1: in-tangent (0, 2, 0),
  // value (1, 1, 1). At t = 2, s = 1/2: h00 = 1/2, h10 = d (1/8 - 1/2 + 1/2) = 1/4, h01 = 1/2,
  // h11 = d (1/8 - 1/4) = -1/4, so p = 1/4 (1, 0, 0) + 1/2 (1, 1, 1) - 1/4 (0, 2, 0) = (3/4, 0, 1/2).
  KeyframeTrack track{Interpolation::cubic_spline, 3, false, {1, 3},
                      {9, 9, 9, 0, 0, 0, 1, 0, 0,     // key 0: in-tangent (unused), value, out-tangent
                       0, 2, 0, 1, 1, 1, 7, 7, 7}};   // key 1: in-tangent, value, out-tangent (unused)
  track.validate("cubic");
  const auto p = sample(track, 2);
  EXPECT_DOUBLE_EQ(p[0], 0.75);
  EXPECT_DOUBLE_EQ(p[1], 0.0);
  EXPECT_DOUBLE_EQ(p[2], 0.5);
  // At s = 1/4: h00 = 27/32, h10 = 2 (1/64 - 1/8 + 1/4) = 9/32, h01 = 5/32, h11 = 2 (1/64 - 1/16) = -3/32.
  const auto q = sample(track, 1.5);
  EXPECT_NEAR(q[0], 9.0 / 32 + 5.0 / 32, 1e-15);
  EXPECT_NEAR(q[1], 5.0 / 32 - 2 * 3.0 / 32, 1e-15);
  EXPECT_NEAR(q[2], 5.0 / 32, 1e-15);
  // Keys exactly: their values, whatever the tangents.
  EXPECT_DOUBLE_EQ(sample(track, 1)[0], 0.0);
  EXPECT_DOUBLE_EQ(sample(track, 3)[2], 1.0);
}

TEST(KeyframesTest, CubicSplineRotationsAreNormalisedAfterwards) {
  // Zero tangents, identity to 90 degrees about z, halfway: (0, 0, h/2, 1/2 + h/2) normalised is
  // the 45-degree rotation (0, 0, sin 22.5, cos 22.5).
  const double h = std::sqrt(0.5);
  KeyframeTrack track{Interpolation::cubic_spline, 4, true, {0, 1},
                      {0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0,
                       0, 0, 0, 0, 0, 0, h, h, 0, 0, 0, 0}};
  track.validate("cubic rotation");
  const auto q = sample(track, 0.5);
  EXPECT_NEAR(q[2], std::sin(std::numbers::pi / 8), 1e-12);
  EXPECT_NEAR(q[3], std::cos(std::numbers::pi / 8), 1e-12);
}

TEST(KeyframesTest, EqualTimesMakeAJump) {
  KeyframeTrack track{Interpolation::linear, 3, false, {0, 1, 1, 2}, {0, 0, 0, 1, 1, 1, 5, 5, 5, 6, 6, 6}};
  track.validate("jump");
  EXPECT_DOUBLE_EQ(sample(track, 0.5)[0], 0.5);
  EXPECT_DOUBLE_EQ(sample(track, 1.0)[0], 5.0);  // the later key wins at its time
  EXPECT_DOUBLE_EQ(sample(track, 1.5)[0], 5.5);
}

TEST(KeyframesTest, ValidateNamesTheBadKey) {
  const auto message = [](const KeyframeTrack& track) {
    try {
      track.validate("track");
    } catch (const std::invalid_argument& error) {
      return std::string(error.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(message({Interpolation::linear, 3, false, {0, 2, 1}, std::vector<double>(9, 0)}).find("key 2"), std::string::npos);
  EXPECT_NE(message({Interpolation::linear, 3, false, {0, 1}, std::vector<double>(5, 0)}).find("5 numbers for 2 keys"),
            std::string::npos);
  EXPECT_NE(message({Interpolation::cubic_spline, 3, false, {0, 1}, std::vector<double>(6, 0)}).find("keys of 9"),
            std::string::npos);
  EXPECT_NE(message({Interpolation::step, 3, false, {0, NAN}, std::vector<double>(6, 0)}).find("non-finite time"),
            std::string::npos);
  EXPECT_NE(message({Interpolation::step, 3, false, {0, 1}, {0, 0, 0, 0, INFINITY, 0}}).find("key 1 holds a non-finite"),
            std::string::npos);
  EXPECT_NE(message({Interpolation::linear, 4, true, {0}, {0, 0, 0, 0}}).find("zero length"), std::string::npos);
  EXPECT_NE(message({Interpolation::linear, 3, false, {}, {}}).find("no keys"), std::string::npos);
}

TEST(NodeAnimationTimingTest, OneLoopOfFloatKeyTimesEndsOnTheLastKey) {
  // The Fox's Walk: 17 key intervals at 24 fps, its last key stored as the float 0.70833331.
  const double end = static_cast<float>(17.0 / 24.0);
  EXPECT_DOUBLE_EQ(played_seconds("walk: ", end, 24, std::nullopt, std::nullopt), end);
  EXPECT_DOUBLE_EQ(loop_time(5 / 24.0, end, 24), 5.0 / 24);
  // Frame 17 at 24 fps, a little past the float end, is the end: the last pose, not the first.
  EXPECT_DOUBLE_EQ(loop_time(17 / 24.0, end, 24), end);
  EXPECT_NEAR(loop_time(18 / 24.0, end, 24), 1.0 / 24, 1e-6);  // then it starts over
  EXPECT_DOUBLE_EQ(loop_time(34 / 24.0, end, 24), end);       // the end of loop 2
  EXPECT_DOUBLE_EQ(loop_time(0, end, 24), 0);
}

TEST(NodeAnimationTimingTest, SecondsLoopAsOftenAsNeeded) {
  // One second of animation played for 2.55 s at 10 fps.
  EXPECT_DOUBLE_EQ(played_seconds("cycle: ", 1, 10, std::nullopt, 2.55), 2.55);
  EXPECT_DOUBLE_EQ(played_seconds("cycle: ", 1, 10, 3, std::nullopt), 3);
  EXPECT_NEAR(loop_time(0.3, 1, 10), 0.3, 1e-12);
  EXPECT_DOUBLE_EQ(loop_time(1.0, 1, 10), 1.0);
  EXPECT_NEAR(loop_time(1.3, 1, 10), 0.3, 1e-12);
  EXPECT_NEAR(loop_time(2.5, 1, 10), 0.5, 1e-12);
  // An animation of one instant: its pose at every time.
  EXPECT_EQ(loop_time(0.7, 0, 30), 0);
  const auto message = [](auto call) {
    try {
      call();
    } catch (const std::invalid_argument& error) {
      return std::string(error.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message([] { played_seconds("cycle: ", 1, 30, 0, std::nullopt); }), "cycle: loops must be 1 or more");
  EXPECT_EQ(message([] { played_seconds("cycle: ", 1, 30, 1, 1.0); }), "cycle: give loops or seconds, not both");
  EXPECT_EQ(message([] { played_seconds("cycle: ", 1, 30, std::nullopt, -1.0); }), "cycle: seconds must be 0 or more");
  EXPECT_TRUE(message([] { played_seconds("cycle: ", 1, 30, std::nullopt, 1e9); }).find("more than 10000000 frames") != std::string::npos);
}

}  // namespace
}  // namespace odyssey
