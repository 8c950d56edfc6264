// Retargeting, quality `fast`: SMPL-X sequences as clips (against the body model), the height
// scale, rest alignment of a T-pose source onto an A-pose target, the shared CMU clips onto the
// shared characters and the Mixamo test rig, the IK-style RobotExpressive, spine chains of
// unequal length both ways, bad input, and the report.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <set>
#include <string>
#include <vector>

#include "mocap_io/bvh.h"
#include "mocap_io/gltf_character.h"
#include "retarget/reference_rig.h"
#include "retarget/refine.h"
#include "retarget/retarget.h"
#include "skeleton/body_clip.h"
#include "synthetic/synthetic_body.h"
#include "synthetic/synthetic_walk.h"

namespace odyssey::retarget {
namespace {

using Eigen::Quaterniond;
using Eigen::Vector3d;

const std::string kAssets = std::string(ODYSSEY_SHARED_DIR) + "/assets";

double angle_between(const Quaterniond& a, const Quaterniond& b) { return a.angularDistance(b); }

std::vector<Vector3d> world_positions(const Clip& clip, int frame) {
  std::vector<RigidTransform<double>> world(clip.joint_count());
  clip.world_pose(frame, world);
  std::vector<Vector3d> positions;
  for (const auto& joint : world) positions.push_back(joint.translation);
  return positions;
}

// Every joint swings about its own fixed axis, 0.35 rad at 0.9 Hz with its own phase (the root
// 0.15 rad), while the root walks 1.1 m/s along -Y and sways; frames replace the rest rotations,
// so each is rest * swing.
Clip procedural_motion(const Skeleton& skeleton, int frames, double fps) {
  Clip clip;
  clip.skeleton = skeleton;
  clip.fps = fps;
  clip.translated_joints = {0};
  for (int f = 0; f < frames; ++f) {
    const double t = f / fps;
    for (int j = 0; j < skeleton.joint_count(); ++j) {
      const Vector3d axis = Vector3d(std::sin(1.3 * j + 0.4), std::cos(0.7 * j), 0.5 + 0.3 * std::sin(j)).normalized();
      const double amplitude = j == 0 ? 0.15 : 0.35;
      const double angle = amplitude * std::sin(2 * std::numbers::pi * 0.9 * t + 0.8 * j);
      clip.rotations.push_back(skeleton.rest_rotations()[j] * Quaterniond(Eigen::AngleAxisd(angle, axis)));
    }
    clip.translations.push_back(skeleton.rest_offsets()[0] + Vector3d(0.03 * std::sin(2 * std::numbers::pi * 0.9 * t), -1.1 * t,
                                                                      0.02 * std::sin(2 * std::numbers::pi * 1.8 * t)));
  }
  return clip;
}

// A copy of a skeleton with identity rest rotations and some joints removed: their children
// hang from the removed joint's parent at the same world positions.
Skeleton without(const Skeleton& full, const std::set<std::string>& removed) {
  const std::vector<RigidTransform<double>> rest = full.rest_world();
  std::vector<std::string> names;
  std::vector<int> parents;
  std::vector<Vector3d> offsets;
  std::vector<int> new_index(full.joint_count(), -1);
  for (int j = 0; j < full.joint_count(); ++j) {
    if (removed.count(full.name(j))) continue;
    int parent = full.parent(j);
    while (parent >= 0 && new_index[parent] < 0) parent = full.parent(parent);
    new_index[j] = static_cast<int>(names.size());
    names.push_back(full.name(j));
    parents.push_back(parent < 0 ? -1 : new_index[parent]);
    offsets.push_back(parent < 0 ? rest[j].translation : Vector3d(rest[j].translation - rest[parent].translation));
  }
  return Skeleton(names, parents, offsets);
}

Skeleton scaled(const Skeleton& skeleton, double factor) {
  std::vector<Vector3d> offsets = skeleton.rest_offsets();
  for (Vector3d& offset : offsets) offset *= factor;
  return Skeleton(skeleton.names(), skeleton.parents(), offsets, skeleton.rest_rotations());
}

BoneMap canonical_names_map(const Skeleton& skeleton) {
  io::BoneMapFile file;
  for (const std::string& name : skeleton.names()) file.entries.push_back({name, {name}});
  return bone_map_from_file(skeleton, file, "canonical names");
}

// `spine_degrees` bounds the spine limb and the torso line (metrics.h) where a rig's spine is
// split in proportions far from the performer's (transfer.h: the spine's bend).
void expect_limbs_under(const RetargetMetrics& metrics, double degrees, const std::string& label, double spine_degrees = 0) {
  if (spine_degrees == 0) spine_degrees = degrees;
  EXPECT_LT(metrics.bone_direction.mean_deg, degrees) << label;
  EXPECT_GT(metrics.bone_direction.samples, 0) << label;
  for (const auto& limb : metrics.limbs) {
    EXPECT_LT(limb.error.mean_deg, limb.name == "spine" ? spine_degrees : degrees) << label << ": " << limb.name;
  }
  EXPECT_LT(metrics.torso.mean_deg, spine_degrees) << label;
}

TEST(BodyClipTest, WorldJointsEqualTheBodyModel) {
  const SyntheticBody body = make_synthetic_body(3);
  BodySequence sequence = synthetic_walk(40, 30, BodyModelKind::SMPLX, 5);
  sequence.betas = {0.8, -1.2, 0.5, 0.3, -0.7};
  const Clip clip = clip_from_body_sequence(body.model, sequence);
  EXPECT_EQ(clip.skeleton.names(), body.model.joint_names);
  ASSERT_EQ(clip.frame_count(), 40);
  BodyModelEvaluator evaluator(body.model);
  evaluator.set_shape(sequence.betas);
  std::vector<double> joints(3 * 55);
  double worst = 0;
  for (int f = 0; f < 40; ++f) {
    std::vector<double> pose(sequence.poses.row(f).data(), sequence.poses.row(f).data() + sequence.poses.cols());
    evaluator.evaluate(pose, sequence.translations.row(f).transpose(), joints, std::span<double>());
    const std::vector<Vector3d> positions = world_positions(clip, f);
    for (int j = 0; j < 55; ++j) worst = std::max(worst, (positions[j] - Vector3d(joints[3 * j], joints[3 * j + 1], joints[3 * j + 2])).norm());
  }
  EXPECT_LT(worst, 1e-9);
  // The rest pose stands upright in the Z-up world: head above pelvis above ankles.
  const std::vector<RigidTransform<double>> rest = clip.skeleton.rest_world();
  EXPECT_GT(rest[15].translation.z() - rest[0].translation.z(), 0.4);
  EXPECT_GT(rest[0].translation.z() - rest[7].translation.z(), 0.7);
}

TEST(BodyClipTest, RejectsAMismatchedKindAndNamesABadFrame) {
  const SyntheticBody body = make_synthetic_body(3);
  BodySequence sequence = synthetic_walk(10, 30, BodyModelKind::SMPLH, 1);
  EXPECT_THROW(clip_from_body_sequence(body.model, sequence), std::invalid_argument);
  sequence = synthetic_walk(10, 30, BodyModelKind::SMPLX, 1);
  sequence.poses(6, 40) = std::numeric_limits<double>::quiet_NaN();
  try {
    clip_from_body_sequence(body.model, sequence);
    FAIL();
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("frame 6"), std::string::npos) << error.what();
  }
}

// Source and target with the same build, the source 0.6 times the size: s = 1 / 0.6 exactly
// (the paired joints span 1.63 m on the target, eyes at 1.66 m to balls of the feet at 0.03 m).
TEST(RetargetTest, ScaleIsTheRigHeightRatio) {
  const Skeleton source_skeleton = scaled(reference_humanoid(ReferenceNames::smplx, 0), 0.6);
  const Clip source = procedural_motion(source_skeleton, 2, 30);
  const Character target = mixamo_reference_character(45);
  const RetargetRig rig = build_retarget_rig(source, detect_bone_map(source_skeleton), target.skeleton, detect_bone_map(target.skeleton));
  EXPECT_NEAR(rig.target_height, 1.63, 1e-9);
  EXPECT_NEAR(rig.source_height, 0.6 * 1.63, 1e-7);
  EXPECT_NEAR(rig.scale, 1 / 0.6, 1e-6);
  EXPECT_NEAR(rig.scale * rig.source_height, rig.target_height, 1e-12);
}

TEST(RetargetTest, TPoseSourceOntoAPoseTarget) {
  const Skeleton source_skeleton = reference_humanoid(ReferenceNames::smplx, 0);
  const Clip source = procedural_motion(source_skeleton, 90, 30);
  const Character target = mixamo_reference_character(45);
  const BoneMap source_map = detect_bone_map(source_skeleton), target_map = detect_bone_map(target.skeleton);
  const RetargetResult result = retarget_fast(source, source_map, target, target_map);
  const RetargetRig& rig = result.rig;
  EXPECT_LT(rig.alignment.max_residual_deg, 0.01);
  expect_limbs_under(result.report.result_metrics, 2.0, "T-pose onto A-pose");
  EXPECT_LT(result.report.result_metrics.bone_direction.max_deg, 1e-6);  // chain bones are exact
  // Same build on both sides; what is left is the regulariser's pull on the aligned pelvis and
  // chest, of order lambda^2 times their turn.
  EXPECT_LT(result.report.result_metrics.branch_direction.max_deg, 1e-4);

  // The aligned rest pose transfers to the target's rest pose, every joint, up to the alignment
  // residual (the swing onto the source bone takes it out again: under 0.01 degree, 1.7e-4 rad).
  Clip aligned;
  aligned.skeleton = source_skeleton;
  aligned.fps = 30;
  aligned.rotations = rig.source_aligned_local;
  aligned.translated_joints = {0};
  aligned.translations = {source_skeleton.rest_offsets()[0]};
  const Feet feet = source_feet(source, source_map);
  FootContacts none;
  none.planted = {std::vector<std::uint8_t>(1, 0), std::vector<std::uint8_t>(1, 0)};
  const TransferResult at_rest = FastTransfer(rig, result.target_feet).run(aligned, feet, none);
  for (int j = 0; j < target.skeleton.joint_count(); ++j) {
    EXPECT_LT(angle_between(at_rest.clip.rotation(0, j), target.skeleton.rest_rotations()[j]), 1.7e-4) << target.skeleton.name(j);
  }

  // The source's own T-pose lifts the target's arms to horizontal.
  Clip t_pose = aligned;
  t_pose.rotations = source_skeleton.rest_rotations();
  const std::vector<Vector3d> posed = world_positions(FastTransfer(rig, result.target_feet).run(t_pose, feet, none).clip, 0);
  for (const char* side : {"Left", "Right"}) {
    const Vector3d upper_arm = posed[target.skeleton.find(std::string("mixamorig:") + side + "ForeArm")] -
                               posed[target.skeleton.find(std::string("mixamorig:") + side + "Arm")];
    EXPECT_NEAR(upper_arm.normalized().z(), 0.0, 1e-6) << side;
  }

  // Quaternion signs are continuous along the clip.
  const Clip& clip = result.transfer.clip;
  for (int f = 1; f < clip.frame_count(); ++f) {
    for (int j = 0; j < clip.joint_count(); ++j) ASSERT_GE(clip.rotation(f, j).dot(clip.rotation(f - 1, j)), 0.0);
  }
}

struct SharedCase {
  std::string clip;
  std::string character;  // a file in shared/assets/characters, or "mixamo" for the test rig
  SourceRest rest;
};

class SharedAssetsTest : public testing::TestWithParam<SharedCase> {};

TEST_P(SharedAssetsTest, LimbsFollowTheSourceAndFeetKeepTheFloor) {
  const SharedCase& c = GetParam();
  const Clip source = io::load_bvh(kAssets + "/mocap/" + c.clip, {io::kCmuMetresPerUnit});
  const Character target = c.character == "mixamo" ? mixamo_reference_character(45) : io::load_character(kAssets + "/characters/" + c.character);
  RetargetOptions options;
  options.source_rest = c.rest;
  const RetargetResult result = retarget_fast(source, humanoid_bone_map(source.skeleton, c.clip), target,
                                              humanoid_bone_map(target.skeleton, c.character), options, c.clip);
  const std::string label = c.clip + " onto " + c.character + " from " + source_rest_name(c.rest);
  EXPECT_LT(result.rig.alignment.max_residual_deg, 0.05) << label;
  expect_limbs_under(result.report.result_metrics, 2.0, label);
  // The torso as a whole (spine1 -> neck) follows the performer's within 2 degrees on average
  // though the rigs split the spine in other proportions (transfer.h, the spine's bend), and the
  // chain keeps the performer's bend between its first and last segment exactly.
  EXPECT_LT(result.report.result_metrics.torso.mean_deg, 2.0) << label;
  EXPECT_GT(result.report.result_metrics.spine_bend.samples, 0) << label;
  EXPECT_LT(result.report.result_metrics.spine_bend.max_deg, 1e-4) << label;
  // During the source's contacts the feet stay on the floor: mean depth plus mean height under
  // 1 cm at the performer's size (the metrics are in the target's size, s times larger; measured
  // 0.41-0.64). RobotExpressive's thighs are two thirds of the scaled performer's and its shins
  // as long, so with every leg bone along the source's, its two planted feet stand up to 10 cm
  // apart in height in the jump's asymmetric crouch (4.3 cm at the performer's size): no height
  // of the body puts both on the floor, and it read 2.1 cm until the pelvis rolled to level them
  // (transfer.h); now 0.64.
  const RetargetMetrics& metrics = result.report.result_metrics;
  EXPECT_LT((metrics.penetration_cm + metrics.floating_cm) / result.rig.scale, 1.0) << label;
  EXPECT_GT(result.contacts.planted_count(), source.frame_count() / 2) << label;
}

std::vector<SharedCase> shared_cases() {
  std::vector<SharedCase> cases;
  for (const char* clip : {"cmu_walk_cgspeed.bvh", "cmu_jump_cgspeed.bvh"}) {
    for (const char* character : {"RiggedFigure.glb", "CesiumMan.glb", "RobotExpressive.glb", "mixamo"}) {
      for (SourceRest rest : {SourceRest::rest, SourceRest::first_frame}) cases.push_back({clip, character, rest});
    }
  }
  return cases;
}

INSTANTIATE_TEST_SUITE_P(CmuClips, SharedAssetsTest, testing::ValuesIn(shared_cases()), [](const auto& info) {
  std::string name = info.param.clip.substr(4, 4) + "_" + info.param.character + "_" + source_rest_name(info.param.rest);
  for (char& ch : name) {
    if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
  }
  return name;
});

// RobotExpressive's feet hang from the root bone. The transfer puts each at the end of its shin,
// as if it hung there, so fast's shins, as drawn from knee to foot joint, follow the source
// exactly (they were 8-10 degrees off when the feet were put where the scaled performer's ankles
// are). Each foot is one joint at the heel of a long block: its toe comes from the mesh (the front
// of the sole, 0.84 m ahead of the joint and on the floor at rest), and the foot is pitched so the
// toe stands above the heel as the performer's ball of the foot stands above the ankle (or higher,
// where the floor bound of transfer.h holds it no lower than the performer's foot), so it
// neither dips into the floor at toe-off nor drags along it (with the performer's pitch copied,
// the toe stood up to 0.5 m off where the ball puts it). Planting the feet is balanced's job.
TEST(RetargetTest, RobotExpressiveShinsFollowTheSourceAndBalancedPlantsTheFeet) {
  const Clip source = io::load_bvh(kAssets + "/mocap/cmu_walk_cgspeed.bvh", {io::kCmuMetresPerUnit});
  const Character robot = io::load_character(kAssets + "/characters/RobotExpressive.glb");
  const BoneMap robot_map = humanoid_bone_map(robot.skeleton, "robot");
  RetargetResult result = retarget_fast(source, humanoid_bone_map(source.skeleton, "walk"), robot, robot_map);
  const Skeleton& skeleton = robot.skeleton;
  for (const char* foot : {"Foot.L", "Foot.R"}) {
    const int joint = skeleton.find(foot);
    const auto& translated = result.transfer.clip.translated_joints;
    EXPECT_NE(std::find(translated.begin(), translated.end(), joint), translated.end()) << foot;
  }
  const std::vector<RigidTransform<double>> rest = skeleton.rest_world();
  for (int side = 0; side < 2; ++side) {
    const Foot& foot = result.target_feet[side];
    ASSERT_TRUE(foot.has_toe);
    EXPECT_NEAR(foot.toe_ground_height, 0.0, 1e-3);
    EXPECT_NEAR(foot.ground_heights[0], 0.045, 1e-3);
    const Vector3d ahead = rest[foot.joints[0]].rotation * foot.toe;
    EXPECT_NEAR(-ahead.y(), 0.836, 0.01);  // the robot faces -y
    EXPECT_NEAR(ahead.x(), 0.0, 0.05);
  }
  struct Contact {
    double mean = 0, worst = 0, worst_pitch_error = 0;
    int raised_frames = 0;  // where the floor bound raised the toe above the rule's
    double worst_raised_toe = 0;
  };
  // Over the source's planted frames: the lowest foot point's distance from the floor; and over
  // every frame, how far the toe's height above the heel is from the pitch rule's.
  const auto measure = [&](const Clip& clip) {
    Contact contact;
    int samples = 0;
    std::vector<RigidTransform<double>> source_world(source.joint_count());
    std::vector<RigidTransform<double>> world(skeleton.joint_count());
    std::vector<Vector3d> positions(skeleton.joint_count());
    for (int f = 0; f < clip.frame_count(); ++f) {
      clip.world_pose(f, world);
      source.world_pose(f, source_world);
      for (int j = 0; j < skeleton.joint_count(); ++j) positions[j] = world[j].translation;
      for (int side = 0; side < 2; ++side) {
        const Foot& foot = result.target_feet[side];
        const Foot& source_foot = result.source_feet[side];
        const auto clearance_of = [&](int k) {
          return (result.source_feet.levelling * source_world[source_foot.joints[k]].translation).z() - source_foot.ground_heights[k];
        };
        const double toe_above_heel = foot.point(1, positions, world[foot.joints[0]].rotation).z() - positions[foot.joints[0]].z();
        const double wanted = foot.toe_ground_height - foot.ground_heights[0] + result.rig.scale * (clearance_of(1) - clearance_of(0));
        if (toe_above_heel - wanted > 1e-9) {
          // Raised by the floor bound: the toe as high as the performer's lowest foot joint (scaled).
          const double toe = foot.point(1, positions, world[foot.joints[0]].rotation).z() - foot.toe_ground_height;
          const double lowest = result.rig.scale * std::min(clearance_of(0), clearance_of(1));
          contact.raised_frames += 1;
          contact.worst_raised_toe = std::max(contact.worst_raised_toe, std::abs(toe - lowest));
        } else {
          contact.worst_pitch_error = std::max(contact.worst_pitch_error, std::abs(toe_above_heel - wanted));
        }
        const int knee = robot_map.joints[side == 0 ? canonical::left_knee : canonical::right_knee];
        const int ankle = robot_map.joints[side == 0 ? canonical::left_ankle : canonical::right_ankle];
        EXPECT_GT(positions[knee].z(), positions[ankle].z() + 0.3) << "frame " << f;  // the shin is 0.9 long
        if (result.contacts.planted[side][f]) {
          const double clearance = foot_clearance(foot, positions, world[foot.joints[0]].rotation);
          contact.worst = std::max(contact.worst, std::abs(clearance));
          contact.mean += std::abs(clearance);
          ++samples;
        }
      }
    }
    contact.mean /= samples;
    return contact;
  };

  const Contact fast = measure(result.transfer.clip);
  const RetargetMetrics fast_metrics = result.report.result_metrics;
  std::printf("floor bound: %d foot-frames raised, toe at most %.2f cm off the bound there\n", fast.raised_frames, 100 * fast.worst_raised_toe);
  EXPECT_LT(fast.worst_pitch_error, 1e-9);
  // Within 2 cm on the robot (0.9 cm at the performer's size): the bound's floor is the first
  // pass's, and the floor offset is fitted again once the feet are pitched.
  EXPECT_LT(fast.worst_raised_toe, 0.02);
  // Every bone exact, the shins from knee to foot joint included, but the spine chain's, which
  // the transfer turns as one to share the performer's bend (transfer.h): those are as far off
  // as the torso line spine1 -> neck, half the lean exact segments would leave.
  for (const auto& bone : fast_metrics.bones) {
    const bool spine = bone.name == "spine1->spine3" || bone.name == "spine3->neck";
    if (spine) {
      EXPECT_NEAR(bone.error.mean_deg, fast_metrics.torso.mean_deg, 0.05) << bone.name;
    } else {
      EXPECT_LT(bone.error.max_deg, 1e-6) << bone.name;
    }
  }
  // Pitched from the floor, the feet stand as flat in contact as the performer's (2.3 against 7.1
  // degrees: the toe, 2.9 times as far ahead as the scaled ball, turns less for the same rise).
  EXPECT_LT(fast_metrics.foot_tilt_deg, result.report.source_metrics.foot_tilt_deg);

  refine(result, source, default_refine_options(Quality::balanced));
  const Contact balanced = measure(result.transfer.clip);
  const RetargetMetrics& metrics = result.report.result_metrics;
  // The robot is 2.3 times the performer's size: 1 cm on it is 0.4 cm on the performer.
  std::printf("planted feet off the floor: fast mean %.2f cm, worst %.2f cm; balanced mean %.2f cm, worst %.2f cm\n",
              100 * fast.mean, 100 * fast.worst, 100 * balanced.mean, 100 * balanced.worst);
  std::printf("balanced: penetration %.2f cm, floating %.2f cm (source %.2f), skate %.3f (source %.3f), legs %.2f deg\n",
              metrics.penetration_cm, metrics.floating_cm, result.report.source_metrics.floating_cm, metrics.foot_skate_ratio,
              result.report.source_metrics.foot_skate_ratio, metrics.bone_direction.mean_deg);
  EXPECT_LT(balanced.mean, 0.5 * fast.mean);
  EXPECT_LT(metrics.penetration_cm, fast_metrics.penetration_cm);
  EXPECT_LT(metrics.floating_cm, fast_metrics.floating_cm);
  EXPECT_LT(metrics.floating_cm, 1.1 * result.report.source_metrics.floating_cm);
}

// The KayKit mannequin's legs are short for its feet: 37 cm of leg above a sole reaching 27 cm
// ahead of the ankle. At the CMU walk's toe-offs its leg lifts the heel 2.7 cm where the scaled
// performer's rises 10, so the pitch rule alone (the toe as far below the heel as the performer's
// ball is below theirs) put the toe 4.5 cm into the floor, and balanced rolled the pelvis 4-5
// degrees to lift it. The floor bound (transfer.h) keeps the toe no lower than the performer's
// lowest foot joint instead (it went 3.4 cm below the floor without it).
TEST(RetargetTest, AShortLegLiftsTheHeelLessAndTheToeStaysOnTheFloor) {
  const Clip source = io::load_bvh(kAssets + "/mocap/cmu_walk_cgspeed.bvh", {io::kCmuMetresPerUnit});
  const Character mannequin = io::load_character(kAssets + "/characters/kaykit_mannequin/manny_med_mod.gltf");
  RetargetResult result = retarget_fast(source, humanoid_bone_map(source.skeleton, "walk"), mannequin,
                                        humanoid_bone_map(mannequin.skeleton, "kaykit"));
  const Clip& clip = result.transfer.clip;
  std::vector<RigidTransform<double>> world(clip.joint_count()), source_world(source.joint_count());
  std::vector<Vector3d> positions(clip.joint_count()), source_positions(source.joint_count());
  double deepest = 0;  // how far the toe goes below the performer's lowest foot joint, scaled
  for (int f = 0; f < clip.frame_count(); ++f) {
    clip.world_pose(f, world);
    source.world_pose(f, source_world);
    for (int j = 0; j < clip.joint_count(); ++j) positions[j] = world[j].translation;
    for (int j = 0; j < source.joint_count(); ++j) source_positions[j] = result.source_feet.levelling * source_world[j].translation;
    for (int side = 0; side < 2; ++side) {
      const Foot& foot = result.target_feet[side];
      ASSERT_TRUE(foot.has_toe);
      const double toe = foot.point(foot.point_count() - 1, positions, world[foot.joints[0]].rotation).z() - foot.toe_ground_height;
      deepest = std::max(deepest, result.rig.scale * foot_clearance(result.source_feet[side], source_positions) - toe);
    }
  }
  std::printf("deepest toe %.2f cm below the performer's lowest foot joint\n", 100 * deepest);
  EXPECT_LT(deepest, 0.01);

  const RetargetMetrics fast = result.report.result_metrics;
  refine(result, source, default_refine_options(Quality::balanced));
  const RetargetMetrics& balanced = result.report.result_metrics;
  std::printf("hip line fast %.2f, balanced %.2f deg; jitter fast %.2f, balanced %.2f, source %.2f m/s^2\n", fast.hip_line.mean_deg,
              balanced.hip_line.mean_deg, fast.jitter, balanced.jitter, result.report.source_metrics.jitter);
  EXPECT_LT(balanced.hip_line.mean_deg, fast.hip_line.mean_deg + 0.5);
  EXPECT_LT(balanced.jitter, 1.2 * fast.jitter);
}

// Three source spine bones (spine1 -> spine2 -> spine3 -> neck) onto one target torso bone
// (Torso -> Neck, the arms hanging from the torso joint), and one source spine bone onto
// Mixamo's three.
TEST(RetargetTest, SpineChainsOfUnequalLength) {
  const Skeleton full = reference_humanoid(ReferenceNames::smplx, 0);
  {
    const Skeleton torso_rig = without(full, {"spine2", "spine3"});
    Character target;
    target.skeleton = torso_rig;
    const Clip source = procedural_motion(full, 60, 30);
    const RetargetResult result = retarget_fast(source, canonical_names_map(full), target, canonical_names_map(torso_rig));
    const RetargetMetrics& metrics = result.report.result_metrics;
    EXPECT_LT(metrics.bone_direction.max_deg, 1e-6);
    // The torso joint's children (neck, clavicles) hang two source bones higher: the fitted
    // rotation follows them to within a couple of degrees.
    EXPECT_LT(metrics.branch_direction.mean_deg, 2.0);
    EXPECT_EQ(result.report.source_only, (std::vector<std::string>{"spine2", "spine3"}));
  }
  {
    const Skeleton short_spine = without(full, {"spine1", "spine2"});
    const Clip source = procedural_motion(short_spine, 60, 30);
    const Character target = mixamo_reference_character(45);
    const RetargetResult result = retarget_fast(source, canonical_names_map(short_spine), target, detect_bone_map(target.skeleton));
    const RetargetMetrics& metrics = result.report.result_metrics;
    EXPECT_LT(metrics.bone_direction.max_deg, 1e-6);
    EXPECT_LT(metrics.branch_direction.max_deg, 1e-4);  // the source torso is rigid with its pelvis
    // The target's unpaired Spine and Spine1 keep their rest rotation in every frame.
    for (const char* name : {"mixamorig:Spine", "mixamorig:Spine1"}) {
      const int joint = target.skeleton.find(name);
      for (int f = 0; f < result.transfer.clip.frame_count(); ++f) {
        ASSERT_LT(angle_between(result.transfer.clip.rotation(f, joint), target.skeleton.rest_rotations()[joint]), 1e-9) << name;
      }
    }
    EXPECT_EQ(result.report.target_only, (std::vector<std::string>{"spine1", "spine2"}));
  }
}

TEST(RetargetTest, SmplxSequenceDrivesCharacters) {
  const SyntheticBody body = make_synthetic_body(1);
  const Clip source = clip_from_body_sequence(body.model, synthetic_walk(90, 30, BodyModelKind::SMPLX, 2));
  const BoneMap source_map = humanoid_bone_map(source.skeleton, "walk");
  EXPECT_EQ(source_map.origin, "preset smplx");
  for (const std::string file : {"RobotExpressive.glb", "RiggedFigure.glb"}) {
    const Character target = io::load_character(kAssets + "/characters/" + file);
    const RetargetResult result = retarget_fast(source, source_map, target, humanoid_bone_map(target.skeleton, file));
    // RiggedFigure's chest sits 80% of the way up from spine1 to the neck, the SMPL-X body's far
    // lower, so under this walk's bend exact segments would leave its torso line about 5 degrees
    // off; the spine's turn splits that between the line and its segments (2.6 each).
    expect_limbs_under(result.report.result_metrics, 2.0, file, 3.0);
    EXPECT_GT(result.contacts.planted_count(), 60) << file;
  }
  const Character mixamo = mixamo_reference_character(45);
  const RetargetResult result = retarget_fast(source, source_map, mixamo, detect_bone_map(mixamo.skeleton));
  expect_limbs_under(result.report.result_metrics, 2.0, "mixamo");
  // SMPL-X fingers drive Mixamo's: every finger bone is a chain bone here.
  int finger_bones = 0;
  for (const auto& bone : result.report.result_metrics.bones) finger_bones += bone.name.find("index") != std::string::npos;
  EXPECT_EQ(finger_bones, 4);  // index1->index2, index2->index3, both hands
}

TEST(RetargetTest, NaNInOneSourceFrameNamesTheFrame) {
  const Skeleton skeleton = reference_humanoid(ReferenceNames::smplx, 0);
  Clip source = procedural_motion(skeleton, 20, 30);
  source.rotations[std::size_t(13) * skeleton.joint_count() + 18].x() = std::numeric_limits<double>::quiet_NaN();
  const Character target = mixamo_reference_character(45);
  try {
    retarget_fast(source, detect_bone_map(skeleton), target, detect_bone_map(target.skeleton), {}, "clip.bvh");
    FAIL();
  } catch (const std::invalid_argument& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("clip.bvh"), std::string::npos) << message;
    EXPECT_NE(message.find("frame 13"), std::string::npos) << message;
    EXPECT_NE(message.find("left_elbow"), std::string::npos) << message;
  }
}

TEST(RetargetTest, RejectsUnpairedPelvisAndForeignClips) {
  const Skeleton skeleton = reference_humanoid(ReferenceNames::smplx, 0);
  const Clip source = procedural_motion(skeleton, 5, 30);
  const Character target = mixamo_reference_character(45);
  BoneMap no_pelvis = detect_bone_map(target.skeleton);
  no_pelvis.joints[canonical::pelvis] = -1;
  EXPECT_THROW(build_retarget_rig(source, detect_bone_map(skeleton), target.skeleton, no_pelvis), std::invalid_argument);
  const RetargetRig rig = build_retarget_rig(source, detect_bone_map(skeleton), target.skeleton, detect_bone_map(target.skeleton));
  const Clip other = procedural_motion(without(skeleton, {"jaw"}), 5, 30);
  const Feet feet = target_feet(target, detect_bone_map(target.skeleton));
  FootContacts contacts;
  contacts.planted = {std::vector<std::uint8_t>(5, 0), std::vector<std::uint8_t>(5, 0)};
  EXPECT_THROW(FastTransfer(rig, feet).run(other, feet, contacts), std::invalid_argument);
}

TEST(RetargetTest, ReportHoldsTheMapUnmappedJointsAndMetrics) {
  const Clip source = io::load_bvh(kAssets + "/mocap/cmu_walk_cgspeed.bvh", {io::kCmuMetresPerUnit});
  const Character figure = io::load_character(kAssets + "/characters/RiggedFigure.glb");
  const RetargetResult result = retarget_fast(source, humanoid_bone_map(source.skeleton, "walk"), figure,
                                              humanoid_bone_map(figure.skeleton, "figure"), {}, "cmu_walk_cgspeed.bvh");
  const nlohmann::json report = nlohmann::json::parse(report_json(result.report).dump());
  EXPECT_EQ(report["quality"], "fast");
  EXPECT_EQ(report["source"]["name"], "cmu_walk_cgspeed.bvh");
  EXPECT_EQ(report["source"]["frames"], 344);
  EXPECT_EQ(report["target"]["map"], "preset rigged_figure");
  EXPECT_DOUBLE_EQ(report["scale"].get<double>(), result.rig.scale);
  EXPECT_EQ(report["map"].size(), 19u);
  EXPECT_EQ(report["map"][0]["canonical"], "pelvis");
  EXPECT_EQ(report["map"][0]["source"], "Hips");
  EXPECT_EQ(report["map"][0]["target"], "torso_joint_1");
  EXPECT_EQ(report["unmapped_joints"]["source"].size(), 6u);  // LHipJoint, RHipJoint, LowerBack, Neck, finger bases
  EXPECT_TRUE(report["unmapped_joints"]["target"].empty());
  EXPECT_EQ(report["mapped_on_one_side_only"]["source"].size(), 6u);  // collars, index1 and thumb1 on each side
  EXPECT_EQ(report["settings"]["source_rest"], "rest");
  EXPECT_LT(report["metrics"]["result"]["bone_direction_deg"]["mean"].get<double>(), 2.0);
  EXPECT_TRUE(report["metrics"]["result"]["limb_direction_deg"].contains("left_leg"));
  EXPECT_TRUE(report["metrics"]["source"].contains("foot_skate_ratio"));
  EXPECT_FALSE(report["metrics"]["source"].contains("bone_direction_deg"));
  EXPECT_GT(report["timings_s"]["transfer"].get<double>(), 0.0);
}

}  // namespace
}  // namespace odyssey::retarget
