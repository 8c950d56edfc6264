// The metrics on tiny hand-made clips whose numbers are worked out by hand in the comments, and
// contact detection and floor fitting on clips with known feet.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "retarget/contacts.h"
#include "retarget/metrics.h"
#include "retarget/rig.h"

namespace odyssey::retarget {
namespace {

using Eigen::Vector3d;

// pelvis (0, 0, 1); knees (+-0.1, 0, 0.5); ankles (+-0.1, 0, 0.1): every joint a canonical one.
Skeleton legs() {
  return Skeleton({"pelvis", "left_knee", "left_ankle", "right_knee", "right_ankle"}, {-1, 0, 1, 0, 3},
                  {Vector3d(0, 0, 1), Vector3d(0.1, 0, -0.5), Vector3d(0, 0, -0.4), Vector3d(-0.1, 0, -0.5), Vector3d(0, 0, -0.4)});
}

BoneMap identity_map(const Skeleton& skeleton) {
  BoneMap map;
  for (int j = 0; j < skeleton.joint_count(); ++j) map.joints[canonical_index(skeleton.name(j))] = j;
  return map;
}

// pelvis (0, 0, 1); hips (+-0.1, 0, 0.95); knees (+-0.1, 0, 0.5).
Skeleton hips() {
  return Skeleton({"pelvis", "left_hip", "left_knee", "right_hip", "right_knee"}, {-1, 0, 1, 0, 3},
                  {Vector3d(0, 0, 1), Vector3d(0.1, 0, -0.05), Vector3d(0, 0, -0.45), Vector3d(-0.1, 0, -0.05), Vector3d(0, 0, -0.45)});
}

// A clip on a five-joint skeleton (legs() unless given) whose every joint is placed by
// translation: `positions[f][j]` is joint j's world position in frame f (rotations identity, so
// local translation = world difference).
Clip placed(const std::vector<std::vector<Vector3d>>& positions, double fps, const Skeleton& skeleton = legs()) {
  Clip clip;
  clip.skeleton = skeleton;
  clip.fps = fps;
  clip.translated_joints = {0, 1, 2, 3, 4};
  for (const auto& frame : positions) {
    for (int j = 0; j < 5; ++j) {
      clip.rotations.push_back(Eigen::Quaterniond::Identity());
      const int parent = clip.skeleton.parent(j);
      clip.translations.push_back(parent < 0 ? frame[j] : Vector3d(frame[j] - frame[parent]));
    }
  }
  return clip;
}

// Feet with the floor at z = 0 and the ankle sitting on it.
Feet ankles_on_floor() {
  Feet feet;
  feet.sides[0] = {{2}, {0.0}};
  feet.sides[1] = {{4}, {0.0}};
  return feet;
}

struct Fixture {
  Skeleton skeleton = legs();
  BoneMap map = identity_map(skeleton);
  Clip rest_clip = placed({{Vector3d(0, 0, 1), Vector3d(0.1, 0, 0.5), Vector3d(0.1, 0, 0.1), Vector3d(-0.1, 0, 0.5), Vector3d(-0.1, 0, 0.1)}}, 10);
  RetargetRig rig = build_retarget_rig(rest_clip, map, skeleton, map);
};

TEST(MetricsTest, IdenticalRigsHaveUnitScale) {
  const Fixture fixture;
  EXPECT_NEAR(fixture.rig.scale, 1.0, 1e-12);  // both span z 0.1 .. 1.0
  ASSERT_EQ(fixture.rig.segments.size(), 4u);
  EXPECT_TRUE(fixture.rig.segments[0].branch);  // pelvis -> left_knee (the pelvis starts two)
  EXPECT_FALSE(fixture.rig.segments[2].branch);  // left_knee -> left_ankle
}

// Left ankle over five frames at 10 fps, (x, z): (0, 0), (0.01, 0.02), (0.07, 0.04), (0.08, 0.08),
// (0.08, 0.02); the right ankle stays at z = -0.01; pelvis and knees still.
//
// Skate: frame pairs (t, t+1) per foot, 8 in all. Left: (0,1) heights 0, 0.02 (contact), speed
// 0.01 * 10 = 0.1 m/s: no; (1,2) 0.02, 0.04 (contact), speed 0.06 * 10 = 0.6 m/s > 0.5: skating;
// (2,3) 0.08 is not contact; (3,4) neither. Right: still. Ratio 1/8.
// Penetration and floating over the source's planted (foot, frame): left planted in 0, 1, 4
// (clearances 0, 0.02, 0.02), right in all five (-0.01 each): 8 samples; depth 5 * 0.01 / 8 =
// 0.625 cm, height (0.02 + 0.02) / 8 = 0.5 cm.
// Jitter over frames 1..3 and the 5 joints (15 samples): only the left ankle moves; its second
// differences p(t+1) - 2 p(t) + p(t-1) are (0.05, 0) at t = 1, (-0.05, 0.02) at t = 2 and
// (-0.01, -0.10) at t = 3, norms 0.05, sqrt(0.0029), sqrt(0.0101); times fps^2 = 100, over 15.
TEST(MetricsTest, SkatePenetrationFloatingAndJitterByHand) {
  const Fixture fixture;
  const std::vector<std::pair<double, double>> left = {{0, 0}, {0.01, 0.02}, {0.07, 0.04}, {0.08, 0.08}, {0.08, 0.02}};
  std::vector<std::vector<Vector3d>> frames;
  for (const auto& [x, z] : left) {
    frames.push_back({Vector3d(0, 0, 1), Vector3d(0.1, 0, 0.5), Vector3d(0.1 + x, 0, z), Vector3d(-0.1, 0, 0.5), Vector3d(-0.1, 0, -0.01)});
  }
  const Clip clip = placed(frames, 10);
  FootContacts contacts;
  contacts.planted[0] = {1, 1, 0, 0, 1};
  contacts.planted[1] = {1, 1, 1, 1, 1};
  const RetargetMetrics metrics = source_metrics(fixture.rig, clip, ankles_on_floor(), contacts);
  EXPECT_DOUBLE_EQ(metrics.foot_skate_ratio, 1.0 / 8.0);
  EXPECT_DOUBLE_EQ(metrics.foot_skate_ratio_gmd, 1.0 / 8.0);  // s = 1: the two figures agree
  EXPECT_NEAR(metrics.penetration_cm, 0.625, 1e-12);
  EXPECT_NEAR(metrics.floating_cm, 0.5, 1e-12);
  const double jitter = (0.05 + std::sqrt(0.0029) + std::sqrt(0.0101)) * 100.0 / 15.0;
  EXPECT_NEAR(metrics.jitter, jitter, 1e-9);
  EXPECT_EQ(metrics.bone_direction.samples, 0);  // comparative metrics are for results only
}

// Foot tilt. The left foot is one joint (the ankle, 0.1 m up when flat) with a toe 0.2 m ahead and
// 0.1 m below it, on the floor: flat, the line to the toe pitches asin(-0.1 / sqrt(0.05)) =
// -26.57 degrees. In frame 1 the ankle turns 20 degrees about the lateral axis (toe down): the line
// pitches -46.57 degrees, 20 from flat. Planted in frames 0 and 1 (tilts 0 and 20) but not in 2
// (turned 40): the mean is 10. The right foot, an ankle alone, has no front point and no tilt.
TEST(MetricsTest, FootTiltByHand) {
  const Fixture fixture;
  const std::vector<Vector3d> frame = {Vector3d(0, 0, 1), Vector3d(0.1, 0, 0.5), Vector3d(0.1, 0, 0.1), Vector3d(-0.1, 0, 0.5),
                                       Vector3d(-0.1, 0, 0.1)};
  Clip clip = placed({frame, frame, frame}, 30);
  for (int f : {1, 2}) {
    clip.rotations[5 * f + 2] = Eigen::Quaterniond(Eigen::AngleAxisd(f * 20.0 * std::numbers::pi / 180.0, Vector3d::UnitY()));
  }
  Feet feet;
  feet.sides[0] = {{2}, {0.1}};
  feet.sides[0].has_toe = true;
  feet.sides[0].toe = Vector3d(0.2, 0, -0.1);
  feet.sides[1] = {{4}, {0.1}};
  FootContacts contacts;
  contacts.planted[0] = {1, 1, 0};
  contacts.planted[1] = {1, 1, 1};
  const RetargetMetrics metrics = source_metrics(fixture.rig, clip, feet, contacts);
  EXPECT_NEAR(metrics.foot_tilt_deg, 10.0, 1e-9);
}

// The result moves the left ankle 0.1 m sideways of the source's: the left shin (knee -> ankle,
// 0.4 m long, straight down in the source) leans by atan(0.1 / 0.4) = 14.036 degrees; the right
// shin is exact. The end effectors are the two ankles: 0.1 m and 0 off, relative to the pelvis.
TEST(MetricsTest, BoneDirectionAndEndEffectorByHand) {
  const Fixture fixture;
  const std::vector<Vector3d> source_frame = {Vector3d(0, 0, 1), Vector3d(0.1, 0, 0.5), Vector3d(0.1, 0, 0.1), Vector3d(-0.1, 0, 0.5),
                                              Vector3d(-0.1, 0, 0.1)};
  std::vector<Vector3d> result_frame = source_frame;
  result_frame[2].x() += 0.1;
  const Clip source = placed({source_frame, source_frame, source_frame}, 30);
  const Clip result = placed({result_frame, result_frame, result_frame}, 30);
  FootContacts contacts;
  contacts.planted = {std::vector<std::uint8_t>(3, 0), std::vector<std::uint8_t>(3, 0)};
  const RetargetMetrics metrics = result_metrics(fixture.rig, source, ankles_on_floor(), result, ankles_on_floor(), contacts);
  const double lean = std::atan(0.25) * 180.0 / std::numbers::pi;
  EXPECT_NEAR(metrics.bone_direction.mean_deg, lean / 2, 1e-9);  // two shins, one off
  EXPECT_NEAR(metrics.bone_direction.max_deg, lean, 1e-9);
  EXPECT_EQ(metrics.bone_direction.samples, 6);
  ASSERT_EQ(metrics.limbs.size(), 2u);
  EXPECT_EQ(metrics.limbs[0].name, "left_leg");
  EXPECT_NEAR(metrics.limbs[0].error.mean_deg, lean, 1e-9);
  EXPECT_NEAR(metrics.limbs[1].error.max_deg, 0.0, 1e-9);
  ASSERT_EQ(metrics.bones.size(), 2u);
  EXPECT_EQ(metrics.bones[0].name, "left_knee->left_ankle");
  EXPECT_NEAR(metrics.branch_direction.max_deg, 0.0, 1e-9);  // pelvis -> knees untouched
  EXPECT_NEAR(metrics.end_effector_mean_m, 0.05, 1e-12);
  EXPECT_NEAR(metrics.end_effector_max_m, 0.1, 1e-12);
}

// The hip line. The result raises its left hip by 0.2 tan(10 deg) over the source's (the hips
// 0.2 m apart), so the line from the right hip to the left turns 10 degrees in one frame of two;
// the knees stay. legs() has no hips: no samples.
TEST(MetricsTest, HipLineByHand) {
  const Skeleton skeleton = hips();
  const BoneMap map = identity_map(skeleton);
  const std::vector<Vector3d> source_frame = {Vector3d(0, 0, 1), Vector3d(0.1, 0, 0.95), Vector3d(0.1, 0, 0.5),
                                              Vector3d(-0.1, 0, 0.95), Vector3d(-0.1, 0, 0.5)};
  std::vector<Vector3d> rolled = source_frame;
  const double degrees = 10;
  rolled[1].z() += 0.2 * std::tan(degrees * std::numbers::pi / 180);
  const Clip source = placed({source_frame, source_frame}, 30, skeleton);
  const Clip result = placed({source_frame, rolled}, 30, skeleton);
  const RetargetRig rig = build_retarget_rig(placed({source_frame}, 30, skeleton), map, skeleton, map);
  Feet knees;
  knees.sides[0] = {{2}, {0.5}};
  knees.sides[1] = {{4}, {0.5}};
  FootContacts contacts;
  contacts.planted = {std::vector<std::uint8_t>(2, 0), std::vector<std::uint8_t>(2, 0)};
  const RetargetMetrics metrics = result_metrics(rig, source, knees, result, knees, contacts);
  EXPECT_EQ(metrics.hip_line.samples, 2);
  EXPECT_NEAR(metrics.hip_line.max_deg, degrees, 1e-9);
  EXPECT_NEAR(metrics.hip_line.mean_deg, degrees / 2, 1e-9);

  const Fixture fixture;
  FootContacts one_frame;
  one_frame.planted = {std::vector<std::uint8_t>(1, 0), std::vector<std::uint8_t>(1, 0)};
  const RetargetMetrics no_hips =
      result_metrics(fixture.rig, fixture.rest_clip, ankles_on_floor(), fixture.rest_clip, ankles_on_floor(), one_frame);
  EXPECT_EQ(no_hips.hip_line.samples, 0);
}

// The torso, pelvis to neck and the spine's bend. A straight spine: pelvis (0, 0, 1), spine1 0.1 above it, spine3
// 0.2 above that, neck 0.2 above, head 0.1 above. In the second frame the result bends at the chest:
// spine3 -> neck (and the head with it) turns 20 degrees toward +x. Both spine segments keep
// their length 0.2, so the torso line spine1 -> neck halves the bend: 10 degrees off the source's.
// The pelvis -> neck line is (0.2 sin 20, 0, 0.3 + 0.2 cos 20) against (0, 0, 0.5).
TEST(MetricsTest, TorsoPelvisToNeckAndSpineBendByHand) {
  const Skeleton skeleton({"pelvis", "spine1", "spine3", "neck", "head"}, {-1, 0, 1, 2, 3},
                          {Vector3d(0, 0, 1), Vector3d(0, 0, 0.1), Vector3d(0, 0, 0.2), Vector3d(0, 0, 0.2), Vector3d(0, 0, 0.1)});
  const BoneMap map = identity_map(skeleton);
  const std::vector<Vector3d> straight = {Vector3d(0, 0, 1), Vector3d(0, 0, 1.1), Vector3d(0, 0, 1.3), Vector3d(0, 0, 1.5),
                                          Vector3d(0, 0, 1.6)};
  const double bend = 20 * std::numbers::pi / 180;
  const Vector3d up(std::sin(bend), 0, std::cos(bend));
  std::vector<Vector3d> bent = straight;
  bent[3] = bent[2] + 0.2 * up;
  bent[4] = bent[3] + 0.1 * up;
  const Clip source = placed({straight, straight}, 30, skeleton);
  const Clip result = placed({straight, bent}, 30, skeleton);
  const RetargetRig rig = build_retarget_rig(placed({straight}, 30, skeleton), map, skeleton, map);
  Feet heads;  // no foot: contacts are not what this test reads
  heads.sides[0] = {{4}, {1.6}};
  heads.sides[1] = {{4}, {1.6}};
  FootContacts contacts;
  contacts.planted = {std::vector<std::uint8_t>(2, 0), std::vector<std::uint8_t>(2, 0)};
  const RetargetMetrics metrics = result_metrics(rig, source, heads, result, heads, contacts);
  EXPECT_EQ(metrics.torso.samples, 2);
  EXPECT_NEAR(metrics.torso.max_deg, 10.0, 1e-9);
  EXPECT_NEAR(metrics.torso.mean_deg, 5.0, 1e-9);
  const double from_pelvis = std::atan2(0.2 * std::sin(bend), 0.3 + 0.2 * std::cos(bend)) * 180 / std::numbers::pi;
  EXPECT_NEAR(metrics.pelvis_to_neck.max_deg, from_pelvis, 1e-9);
  EXPECT_NEAR(metrics.pelvis_to_neck.mean_deg, from_pelvis / 2, 1e-9);
  EXPECT_GT(from_pelvis, 7.9);  // 7.98: the segment's 20 degrees, diluted by the 0.3 m below the chest
  // The chain spine1 -> spine3 -> neck curls by 20 degrees where the source's is straight.
  EXPECT_EQ(metrics.spine_bend.samples, 2);
  EXPECT_NEAR(metrics.spine_bend.max_deg, 20.0, 1e-9);
  EXPECT_NEAR(metrics.spine_bend.mean_deg, 10.0, 1e-9);
}

// Scale-aware skate. The target is legs() twice as large (pelvis at 2 m), so s = 2 and the
// scale-aware thresholds are 10 cm and 1 m/s; GMD's stay 5 cm and 0.5 m/s. The result's left
// ankle, at 10 fps, has heights 0.01, 0.02, 0.03, 0.07, 0.08, 0.04, 0.04 and moves along x by
// 0.07, 0.12, 0.05, 0.15, 0.05, 0.08 between frames (speeds 0.7, 1.2, 0.5, 1.5, 0.5, 0.8 m/s);
// the right ankle stays on the floor. Per frame pair (t, t+1):
//   (0,1) 0.01/0.02 at 0.7: GMD skates (contact, > 0.5); scale-aware not (< 1);
//   (1,2) 0.02/0.03 at 1.2: both;
//   (2,3) 0.03/0.07 at 0.5: GMD out of contact; scale-aware in contact but slow: neither;
//   (3,4) 0.07/0.08 at 1.5: GMD out of contact; scale-aware skates;
//   (4,5) 0.08/0.04 at 0.5: neither;
//   (5,6) 0.04/0.04 at 0.8: GMD skates; scale-aware not.
// 12 (foot, pair) samples: GMD 3/12, scale-aware 2/12. The source is the same motion at half
// the size (the performer): at its own size GMD's thresholds apply, and it skates 2/12 by both
// figures, as the scale-aware result does.
TEST(MetricsTest, SkateThresholdsScaleWithTheCharacter) {
  const Fixture fixture;
  const Skeleton big(fixture.skeleton.names(), fixture.skeleton.parents(),
                     {Vector3d(0, 0, 2), Vector3d(0.2, 0, -1), Vector3d(0, 0, -0.8), Vector3d(-0.2, 0, -1), Vector3d(0, 0, -0.8)});
  const RetargetRig rig = build_retarget_rig(fixture.rest_clip, fixture.map, big, fixture.map);
  ASSERT_NEAR(rig.scale, 2.0, 1e-12);
  const std::vector<double> heights = {0.01, 0.02, 0.03, 0.07, 0.08, 0.04, 0.04};
  const std::vector<double> steps = {0.07, 0.12, 0.05, 0.15, 0.05, 0.08};
  std::vector<std::vector<Vector3d>> result_frames, source_frames;
  double x = 0;
  for (std::size_t f = 0; f < heights.size(); ++f) {
    if (f > 0) x += steps[f - 1];
    const std::vector<Vector3d> frame = {Vector3d(x, 0, 2), Vector3d(0.2 + x, 0, 1), Vector3d(0.2 + x, 0, heights[f]),
                                         Vector3d(-0.2, 0, 1), Vector3d(-0.2, 0, 0)};
    result_frames.push_back(frame);
    std::vector<Vector3d> half;
    for (const Vector3d& p : frame) half.push_back(0.5 * p);
    source_frames.push_back(half);
  }
  const Clip result = placed(result_frames, 10);
  const Clip source = placed(source_frames, 10);
  FootContacts contacts;
  contacts.planted = {std::vector<std::uint8_t>(7, 0), std::vector<std::uint8_t>(7, 1)};
  const RetargetMetrics scaled = result_metrics(rig, source, ankles_on_floor(), result, ankles_on_floor(), contacts);
  EXPECT_DOUBLE_EQ(scaled.foot_skate_ratio, 2.0 / 12.0);
  EXPECT_DOUBLE_EQ(scaled.foot_skate_ratio_gmd, 3.0 / 12.0);
  const RetargetMetrics performer = source_metrics(rig, source, ankles_on_floor(), contacts);
  EXPECT_DOUBLE_EQ(performer.foot_skate_ratio, 2.0 / 12.0);
  EXPECT_DOUBLE_EQ(performer.foot_skate_ratio_gmd, 2.0 / 12.0);
  // At s = 1 the two figures are one (the hand-made clip above: 1/8 both).
  const RetargetMetrics same = result_metrics(fixture.rig, result, ankles_on_floor(), result, ankles_on_floor(), contacts);
  EXPECT_DOUBLE_EQ(same.foot_skate_ratio, same.foot_skate_ratio_gmd);
}

TEST(MetricsTest, RejectsClipsOfTheWrongLength) {
  const Fixture fixture;
  FootContacts contacts;
  contacts.planted = {std::vector<std::uint8_t>(3, 0), std::vector<std::uint8_t>(3, 0)};
  EXPECT_THROW(source_metrics(fixture.rig, fixture.rest_clip, ankles_on_floor(), contacts), std::invalid_argument);
}

// Contacts: planted when the clearance is under 5 cm and the foot slower than 0.5 m/s.
TEST(ContactsTest, HeightAndSpeedThresholds) {
  // Left ankle at 30 fps: heights 0, 0.01, 0.06, 0.01, 0.01 and steps in x of 0, 0.01 (0.3 m/s),
  // 0.02 (0.6 m/s), 0, then the last frame repeats the step before it (0 m/s).
  const std::vector<std::pair<double, double>> left = {{0, 0}, {0, 0.01}, {0.01, 0.06}, {0.03, 0.01}, {0.03, 0.01}};
  std::vector<std::vector<Vector3d>> frames;
  for (const auto& [x, z] : left) {
    frames.push_back({Vector3d(0, 0, 1), Vector3d(0.1, 0, 0.5), Vector3d(0.1 + x, 0, z), Vector3d(-0.1, 0, 0.5), Vector3d(-0.1, 0, 0)});
  }
  const FootContacts contacts = detect_contacts(placed(frames, 30), ankles_on_floor());
  // frame 0: h 0, speed 0 -> planted; 1: h 0.01, speed (0.01)*30 = 0.3 -> planted; 2: h 0.06 ->
  // no; 3: h 0.01, speed 0 -> planted; 4: last frame, step 3->4 is 0 -> planted.
  EXPECT_EQ(contacts.planted[0], (std::vector<std::uint8_t>{1, 1, 0, 1, 1}));
  EXPECT_EQ(contacts.planted[1], (std::vector<std::uint8_t>{1, 1, 1, 1, 1}));
  EXPECT_EQ(contacts.planted_count(), 9);
  frames[1][2].x() = 0.02;  // now 0 -> 1 moves 0.02 m in 1/30 s: 0.6 m/s
  EXPECT_EQ(detect_contacts(placed(frames, 30), ankles_on_floor()).planted[0][0], 0);
}

// A walk on a floor tilted 1 degree along y: the fit finds the tilt, the levelled ankles stand at
// their true height above it, and contacts cover the stance phases.
TEST(ContactsTest, FitsATiltedFloor) {
  const double tilt = 1.0 * std::numbers::pi / 180.0;
  const double ankle_height = 0.08;
  const double fps = 60;
  std::vector<std::vector<Vector3d>> frames;
  // Each foot alternates 0.6 s planted and 0.4 s swinging 1.2 m forward (-y), 10 cm high.
  const auto foot = [&](double t, double phase, double x) {
    const double cycle = std::fmod(t + phase, 1.0);
    const double steps = std::floor(t + phase);
    double y = -1.2 * steps, lift = 0;
    if (cycle > 0.6) {
      const double u = (cycle - 0.6) / 0.4;
      y -= 1.2 * u;
      lift = 0.10 * std::sin(std::numbers::pi * u);
    }
    const double floor = -y * std::tan(tilt);  // the floor rises toward -y
    return Vector3d(x, y, floor + ankle_height + lift);
  };
  for (int f = 0; f < 300; ++f) {
    const double t = f / fps;
    const Vector3d l = foot(t, 0.0, 0.1), r = foot(t, 0.5, -0.1);
    const Vector3d pelvis((l.x() + r.x()) / 2, (l.y() + r.y()) / 2, (l.z() + r.z()) / 2 + 0.9);
    frames.push_back({pelvis, (pelvis + l) / 2, l, (pelvis + r) / 2, r});
  }
  const Clip walk = placed(frames, fps);
  const Feet feet = source_feet(walk, identity_map(legs()));
  const Vector3d normal = feet.levelling.conjugate() * Vector3d::UnitZ();
  const Vector3d expected_normal(0, std::sin(tilt), std::cos(tilt));
  EXPECT_LT(std::acos(std::min(1.0, normal.dot(expected_normal))) * 180 / std::numbers::pi, 0.02);
  // Levelled, the floor is z = 0 at the origin, so a planted ankle stands at its height.
  EXPECT_NEAR(feet[0].ground_heights[0], ankle_height, 1e-3);
  EXPECT_NEAR(feet[1].ground_heights[0], ankle_height, 1e-3);
  const FootContacts contacts = detect_contacts(walk, feet);
  // 60% of 300 frames planted per foot; the frames where the foot lifts slowly count too.
  EXPECT_NEAR(contacts.planted_count() / 600.0, 0.6, 0.05);
}

}  // namespace
}  // namespace odyssey::retarget
