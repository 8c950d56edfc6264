// Numerical stability of retargeting at the extremes (issue 3), for quality `fast` and, through
// refine(), `balanced`:
//   - characters scaled to 5 cm and to 50 m: the scale ratio is exact, limbs follow within 2
//     degrees, and `fast` gives the very rotations it gives at full size (everything but lengths
//     is scale free); performers recorded at such sizes too;
//   - rotations at and around pi (a half-turned root, bones twisted and folded by pi, a root
//     spinning through two full turns) and quaternions stored with flipped signs on every other
//     frame: the result is finite, continuous and, for the flips, identical;
//   - a 100,000-frame clip (the CMU walk tiled): a pose repeats exactly one period later, the
//     root advances by exactly the scaled tile stride, nothing drifts;
//   - zero-length bones on either rig: no NaN; such a bone has no direction and is left out of
//     alignment, the swing and the metrics (its joint still takes the source joint's turn), and a
//     rig with no height at all is rejected by name;
//   - spines and legs exactly along the up axis, with joint frames whose axis is the bone (so the
//     legs' frames are the half turn about a horizontal axis): alignment and transfer stay exact;
//   - a source off the floor: a clip lifted 1 m as a whole is a capture floor 1 m up (the floor is
//     fitted to the feet, contacts.h), so contacts and poses are those of the clip on the floor;
//     a source whose feet never rest has no contacts, and the target is placed by its feet's mean
//     clearance over every frame (transfer.h), so it does not hover;
//   - a NaN or an infinity in one frame: an error naming the clip, the frame and the joint.
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include "mocap_io/bvh.h"
#include "mocap_io/gltf_character.h"
#include "retarget/geometry.h"
#include "retarget/reference_rig.h"
#include "retarget/refine.h"
#include "retarget/retarget.h"
#include "skeleton/body_clip.h"
#include "synthetic/synthetic_body.h"
#include "synthetic/synthetic_walk.h"

namespace odyssey::retarget {
namespace {

using Eigen::AngleAxisd;
using Eigen::Quaterniond;
using Eigen::Vector3d;

const std::string kAssets = std::string(ODYSSEY_SHARED_DIR) + "/assets";
constexpr double kPi = std::numbers::pi;

Clip cmu_walk(double metres_per_unit = io::kCmuMetresPerUnit) {
  return io::load_bvh(kAssets + "/mocap/cmu_walk_cgspeed.bvh", {metres_per_unit}).resampled(30);
}

Character rigged_figure() { return io::load_character(kAssets + "/characters/RiggedFigure.glb"); }

RetargetResult retarget(const Clip& source, const Character& target, const RetargetOptions& options = {}) {
  return retarget_fast(source, humanoid_bone_map(source.skeleton, "source"), target,
                       humanoid_bone_map(target.skeleton, target.name), options);
}

void refine_balanced(RetargetResult& result, const Clip& source) {
  refine(result, source, default_refine_options(Quality::balanced));
}

BoneMap canonical_names_map(const Skeleton& skeleton) {
  io::BoneMapFile file;
  for (const std::string& name : skeleton.names()) file.entries.push_back({name, {name}});
  return bone_map_from_file(skeleton, file, "canonical names");
}

void expect_limbs_under(const RetargetMetrics& metrics, double degrees, const std::string& label) {
  EXPECT_GT(metrics.bone_direction.samples, 0) << label;
  EXPECT_LT(metrics.bone_direction.mean_deg, degrees) << label;
  for (const auto& limb : metrics.limbs) EXPECT_LT(limb.error.mean_deg, degrees) << label << ": " << limb.name;
}

void expect_finite_unit(const Clip& clip, const std::string& label) {
  for (std::size_t i = 0; i < clip.rotations.size(); ++i) {
    const Quaterniond& q = clip.rotations[i];
    ASSERT_TRUE(q.coeffs().allFinite()) << label << ": frame " << i / clip.joint_count();
    ASSERT_NEAR(q.norm(), 1.0, 1e-9) << label << ": frame " << i / clip.joint_count();
  }
  for (std::size_t i = 0; i < clip.translations.size(); ++i) {
    ASSERT_TRUE(clip.translations[i].allFinite()) << label << ": translation " << i;
  }
}

// Every local rotation keeps its sign from one frame to the next (what the GLB writer stores).
void expect_continuous_signs(const Clip& clip, const std::string& label) {
  for (int f = 1; f < clip.frame_count(); ++f) {
    for (int j = 0; j < clip.joint_count(); ++j) {
      ASSERT_GE(clip.rotation(f, j).dot(clip.rotation(f - 1, j)), 0.0) << label << ": frame " << f << " joint " << j;
    }
  }
}

std::vector<RigidTransform<double>> world_pose(const Clip& clip, int frame) {
  std::vector<RigidTransform<double>> world(clip.joint_count());
  clip.world_pose(frame, world);
  return world;
}

// Largest angle (radians) between the local rotations of two clips on one skeleton.
double largest_rotation_difference(const Clip& a, const Clip& b) {
  double largest = 0;
  for (std::size_t i = 0; i < a.rotations.size(); ++i) largest = std::max(largest, a.rotations[i].angularDistance(b.rotations[i]));
  return largest;
}

// A character k times its size: skeleton offsets and mesh positions scaled, inverse binds
// conjugated by S = diag(k, k, k, 1), since the scaled world is S W IB v = W' (S IB S^-1) (S v)
// with W' the rigid transform whose translation is scaled.
Character scaled_character(const Character& character, double k) {
  Character scaled = character;
  std::vector<Vector3d> offsets = character.skeleton.rest_offsets();
  for (Vector3d& offset : offsets) offset *= k;
  scaled.skeleton = Skeleton(character.skeleton.names(), character.skeleton.parents(), offsets, character.skeleton.rest_rotations());
  const Eigen::Matrix4d s = Eigen::Vector4d(k, k, k, 1).asDiagonal();
  const Eigen::Matrix4d s_inverse = Eigen::Vector4d(1 / k, 1 / k, 1 / k, 1).asDiagonal();
  for (CharacterMesh& mesh : scaled.meshes) {
    for (Eigen::Vector3f& position : mesh.positions) position *= static_cast<float>(k);
    for (Eigen::Matrix4d& inverse_bind : mesh.inverse_bind) inverse_bind = s * inverse_bind * s_inverse;
  }
  return scaled;
}

// A skeleton from world rest positions. `bone_axis` zero: identity rest rotations. Otherwise
// every joint's frame turns `bone_axis` onto the direction to its first child (the shortest turn;
// a leaf takes its parent's frame), as Mixamo (+Y) and Blender-style (+Z along the bone) rigs do.
Skeleton skeleton_from_positions(const std::vector<std::string>& names, const std::vector<int>& parents,
                                 const std::vector<Vector3d>& positions, const Vector3d& bone_axis) {
  const int n = static_cast<int>(names.size());
  std::vector<Quaterniond> world(n, Quaterniond::Identity());
  if (!bone_axis.isZero()) {
    for (int j = 0; j < n; ++j) {
      int child = -1;
      for (int c = j + 1; c < n && child < 0; ++c) {
        if (parents[c] == j && (positions[c] - positions[j]).norm() > 1e-9) child = c;
      }
      if (child >= 0) {
        // At a half turn (a leg bone under +Z) the turn's axis is any horizontal one; all are valid.
        world[j] = shortest_rotation(bone_axis, (positions[child] - positions[j]).normalized());
      } else if (parents[j] >= 0) {
        world[j] = world[parents[j]];
      }
    }
  }
  std::vector<Vector3d> offsets(n);
  std::vector<Quaterniond> rotations(n);
  for (int j = 0; j < n; ++j) {
    const int p = parents[j];
    offsets[j] = p < 0 ? positions[j] : Vector3d(world[p].conjugate() * (positions[j] - positions[p]));
    rotations[j] = p < 0 ? world[j] : world[p].conjugate() * world[j];
  }
  return Skeleton(names, parents, offsets, rotations);
}

// Every joint swings about its own fixed axis (0.35 rad, 0.9 Hz, its own phase; the root 0.15
// rad) on top of its rest rotation, while the root moves at `velocity`.
Clip swinging_motion(const Skeleton& skeleton, int frames, double fps, const Vector3d& velocity, double lift = 0) {
  Clip clip;
  clip.skeleton = skeleton;
  clip.fps = fps;
  clip.translated_joints = {0};
  for (int f = 0; f < frames; ++f) {
    const double t = f / fps;
    for (int j = 0; j < skeleton.joint_count(); ++j) {
      const Vector3d axis = Vector3d(std::sin(1.3 * j + 0.4), std::cos(0.7 * j), 0.5 + 0.3 * std::sin(j)).normalized();
      const double angle = (j == 0 ? 0.15 : 0.35) * std::sin(2 * kPi * 0.9 * t + 0.8 * j);
      clip.rotations.push_back(skeleton.rest_rotations()[j] * Quaterniond(AngleAxisd(angle, axis)));
    }
    clip.translations.push_back(skeleton.rest_offsets()[0] + velocity * t + Vector3d(0, 0, lift));
  }
  return clip;
}

// --- Characters at 5 cm and 50 m. ---

struct ScaledRun {
  double factor;
  Character character;
  RetargetResult result;
};

std::vector<ScaledRun> scaled_runs(const Clip& source) {
  const Character figure = rigged_figure();
  const double height = figure.rest_bounds().sizes().z();
  std::vector<ScaledRun> runs;
  for (const double size : {height, 0.05, 50.0}) {
    const double k = size / height;
    Character character = scaled_character(figure, k);
    RetargetResult result = retarget(source, character);
    runs.push_back({k, std::move(character), std::move(result)});
  }
  return runs;
}

TEST(ExtremesTest, CharactersAt5cmAnd50mFast) {
  const Clip source = cmu_walk();
  const std::vector<ScaledRun> runs = scaled_runs(source);
  const ScaledRun& full = runs[0];
  for (const ScaledRun& run : runs) {
    const std::string label = "figure scaled by " + std::to_string(run.factor);
    // Mesh positions are float32: the mesh's height scales to float rounding.
    EXPECT_NEAR(run.character.rest_bounds().sizes().z() / full.character.rest_bounds().sizes().z(), run.factor, 1e-6 * run.factor);
    EXPECT_NEAR(run.result.rig.scale / full.result.rig.scale, run.factor, 1e-12 * run.factor) << label;
    EXPECT_NEAR(run.result.rig.scale * run.result.rig.source_height, run.result.rig.target_height, 1e-12 * run.result.rig.target_height);
    expect_limbs_under(run.result.report.result_metrics, 2.0, label);
    const Clip& clip = run.result.transfer.clip;
    expect_finite_unit(clip, label);
    // Only lengths change with the size: the same rotations, translations k times as long. (The
    // feet's pitch reads the toe off the mesh, float32: 5e-8 rad apart at the two extremes.)
    EXPECT_LT(largest_rotation_difference(clip, full.result.transfer.clip), 1e-6) << label;
    // (The floor offset comes from the lowest mesh point, float32: 1e-7 m at full size.)
    for (std::size_t i = 0; i < clip.translations.size(); ++i) {
      ASSERT_LT((clip.translations[i] / run.factor - full.result.transfer.clip.translations[i]).norm(), 1e-7) << label;
    }
    EXPECT_NEAR(run.result.report.result_metrics.floating_cm / run.factor, full.result.report.result_metrics.floating_cm, 1e-6);
    EXPECT_EQ(run.result.contacts.planted, full.result.contacts.planted) << label;
  }
}

TEST(ExtremesTest, CharactersAt5cmAnd50mBalanced) {
  const Clip source = cmu_walk();
  std::vector<ScaledRun> runs = scaled_runs(source);
  for (ScaledRun& run : runs) refine_balanced(run.result, source);
  const ScaledRun& full = runs[0];
  for (const ScaledRun& run : runs) {
    const std::string label = "balanced, figure scaled by " + std::to_string(run.factor);
    EXPECT_NEAR(run.result.rig.scale / full.result.rig.scale, run.factor, 1e-12 * run.factor) << label;
    expect_limbs_under(run.result.report.result_metrics, 2.0, label);
    expect_finite_unit(run.result.transfer.clip, label);
    // A refinement whose terms are weighed in the character's own size gives the same pose at
    // every size; a degree allows for solver tolerances.
    EXPECT_LT(largest_rotation_difference(run.result.transfer.clip, full.result.transfer.clip), 1.0 * kPi / 180) << label;
    // Feet on the floor during contact, measured in the character's size.
    const RetargetMetrics& metrics = run.result.report.result_metrics;
    const RetargetMetrics& reference = full.result.report.result_metrics;
    EXPECT_NEAR((metrics.penetration_cm + metrics.floating_cm) / run.factor, reference.penetration_cm + reference.floating_cm,
                0.1 + 0.1 * (reference.penetration_cm + reference.floating_cm))
        << label;
  }
}

// A performer recorded at 5 cm or 50 m (a wrong BVH unit) still fills the character: the scale
// is exactly inverse. Contacts are found at the recorded size (5 cm, 0.5 m/s thresholds), which
// is why --bvh-units matters: the poses may differ, the limbs still follow.
TEST(ExtremesTest, PerformersAt5cmAnd50m) {
  const Character figure = rigged_figure();
  const Clip normal = cmu_walk();
  const RetargetResult reference = retarget(normal, figure);
  const double performer = reference.rig.source_height;
  for (const double size : {0.05, 50.0}) {
    const double k = size / performer;
    const Clip source = cmu_walk(io::kCmuMetresPerUnit * k);
    const RetargetResult result = retarget(source, figure);
    const std::string label = "performer " + std::to_string(size) + " m";
    EXPECT_NEAR(result.rig.scale * k, reference.rig.scale, 1e-9 * reference.rig.scale) << label;
    expect_limbs_under(result.report.result_metrics, 2.0, label);
    expect_finite_unit(result.transfer.clip, label);
  }
}

// --- Rotations at pi, signs flipped. ---

// The T-posed SMPL-X-named reference rig with joints turned by angles that step through pi in
// 1e-4 rad steps (exactly pi at frame 20): the root yawed, an upper arm twisted about itself, an
// elbow folded back, a knee turned over, a spine joint turned about an oblique axis.
Clip half_turns(const Skeleton& skeleton) {
  Clip clip;
  clip.skeleton = skeleton;
  clip.fps = 30;
  clip.translated_joints = {0};
  const auto joint = [&](const char* name) { return skeleton.find(name); };
  for (int f = 0; f <= 40; ++f) {
    const double angle = kPi + (f - 20) * 1e-4;
    std::vector<Quaterniond> frame = skeleton.rest_rotations();
    frame[0] = Quaterniond(AngleAxisd(angle, Vector3d::UnitZ()));
    frame[joint("left_shoulder")] = Quaterniond(AngleAxisd(angle, Vector3d::UnitX()));
    frame[joint("right_elbow")] = Quaterniond(AngleAxisd(angle, Vector3d::UnitZ()));
    frame[joint("left_knee")] = Quaterniond(AngleAxisd(angle, Vector3d::UnitX()));
    frame[joint("spine2")] = Quaterniond(AngleAxisd(angle, Vector3d(1, 2, 3).normalized()));
    clip.rotations.insert(clip.rotations.end(), frame.begin(), frame.end());
    clip.translations.push_back(skeleton.rest_offsets()[0]);
  }
  return clip;
}

// Source pelvis and target pelvis turn by the same angle from each frame to the next.
void expect_pelvis_steps_equal(const RetargetResult& result, const Clip& source, double tolerance, const std::string& label) {
  const int source_pelvis = result.rig.source_joint(canonical::pelvis), target_pelvis = result.rig.target_joint(canonical::pelvis);
  std::vector<RigidTransform<double>> source_before = world_pose(source, 0), target_before = world_pose(result.transfer.clip, 0);
  for (int f = 1; f < source.frame_count(); ++f) {
    const std::vector<RigidTransform<double>> source_now = world_pose(source, f), target_now = world_pose(result.transfer.clip, f);
    const double source_step = Quaterniond(source_now[source_pelvis].rotation).angularDistance(Quaterniond(source_before[source_pelvis].rotation));
    const double target_step = Quaterniond(target_now[target_pelvis].rotation).angularDistance(Quaterniond(target_before[target_pelvis].rotation));
    ASSERT_NEAR(target_step, source_step, tolerance) << label << ": frame " << f;
    source_before = source_now;
    target_before = target_now;
  }
}

TEST(ExtremesTest, RotationsAtPiStayFiniteExactAndContinuous) {
  const Skeleton skeleton = reference_humanoid(ReferenceNames::smplx, 0);
  const Clip source = half_turns(skeleton);
  const Character target = mixamo_reference_character(45);
  const RetargetResult result = retarget(source, target);
  const Clip& clip = result.transfer.clip;
  expect_finite_unit(clip, "half turns");
  expect_continuous_signs(clip, "half turns");
  // Chain bones are swung onto the source's directions exactly, a knee turned over included.
  EXPECT_LT(result.report.result_metrics.bone_direction.max_deg, 1e-6);
  expect_pelvis_steps_equal(result, source, 1e-9, "half turns");
}

TEST(ExtremesTest, RootSpinningThroughTwoFullTurns) {
  const Skeleton skeleton = reference_humanoid(ReferenceNames::smplx, 0);
  Clip source = swinging_motion(skeleton, 200, 30, Vector3d(0, -1.1, 0));
  for (int f = 0; f < source.frame_count(); ++f) {
    const Quaterniond spin(AngleAxisd(4 * kPi * f / 199.0, Vector3d::UnitZ()));
    source.rotations[std::size_t(f) * skeleton.joint_count()] = spin * source.rotation(f, 0);
  }
  const RetargetResult result = retarget(source, mixamo_reference_character(45));
  expect_finite_unit(result.transfer.clip, "spin");
  expect_continuous_signs(result.transfer.clip, "spin");
  EXPECT_LT(result.report.result_metrics.bone_direction.max_deg, 1e-6);
  expect_pelvis_steps_equal(result, source, 1e-9, "spin");
}

// q and -q are the same rotation: negating every quaternion of every other frame changes nothing.
Clip sign_flipped(Clip clip) {
  for (int f = 1; f < clip.frame_count(); f += 2) {
    for (int j = 0; j < clip.joint_count(); ++j) {
      Quaterniond& q = clip.rotations[std::size_t(f) * clip.joint_count() + j];
      q.coeffs() = -q.coeffs();
    }
  }
  return clip;
}

void expect_same_result(const RetargetResult& a, const RetargetResult& b, double tolerance, const std::string& label) {
  ASSERT_EQ(a.transfer.clip.rotations.size(), b.transfer.clip.rotations.size());
  for (std::size_t i = 0; i < a.transfer.clip.rotations.size(); ++i) {
    ASSERT_LT((a.transfer.clip.rotations[i].coeffs() - b.transfer.clip.rotations[i].coeffs()).norm(), tolerance)
        << label << ": rotation " << i;
  }
  for (std::size_t i = 0; i < a.transfer.clip.translations.size(); ++i) {
    ASSERT_LT((a.transfer.clip.translations[i] - b.transfer.clip.translations[i]).norm(), tolerance) << label << ": translation " << i;
  }
  EXPECT_EQ(a.contacts.planted, b.contacts.planted) << label;
  EXPECT_NEAR(a.report.result_metrics.bone_direction.mean_deg, b.report.result_metrics.bone_direction.mean_deg, 1e-9) << label;
  EXPECT_NEAR(a.report.result_metrics.foot_skate_ratio, b.report.result_metrics.foot_skate_ratio, 1e-12) << label;
}

struct FlipCase {
  std::string name;
  Clip source;
  Character target;
};

std::vector<FlipCase> flip_cases() {
  const SyntheticBody body = make_synthetic_body(0);
  return {{"cmu walk onto RobotExpressive", cmu_walk(), io::load_character(kAssets + "/characters/RobotExpressive.glb")},
          {"smplx walk onto mixamo", clip_from_body_sequence(body.model, synthetic_walk(60, 30, BodyModelKind::SMPLX, 5)),
           mixamo_reference_character(45)},
          {"half turns onto mixamo", half_turns(reference_humanoid(ReferenceNames::smplx, 0)), mixamo_reference_character(45)}};
}

TEST(ExtremesTest, SignFlippedQuaternionsGiveTheIdenticalResultFast) {
  for (const FlipCase& c : flip_cases()) {
    const RetargetResult plain = retarget(c.source, c.target);
    const RetargetResult flipped = retarget(sign_flipped(c.source), c.target);
    expect_same_result(plain, flipped, 1e-12, c.name);
  }
}

TEST(ExtremesTest, SignFlippedQuaternionsGiveTheIdenticalResultBalanced) {
  for (const FlipCase& c : flip_cases()) {
    const Clip flipped_source = sign_flipped(c.source);
    RetargetResult plain = retarget(c.source, c.target);
    RetargetResult flipped = retarget(flipped_source, c.target);
    refine_balanced(plain, c.source);
    refine_balanced(flipped, flipped_source);
    expect_finite_unit(flipped.transfer.clip, c.name);
    expect_continuous_signs(flipped.transfer.clip, c.name);
    expect_same_result(plain, flipped, 1e-9, "balanced " + c.name);
  }
}

// --- 100,000 frames. ---

// The CMU walk at 30 fps, frames 1-85 (frame 0 is the T-pose reference), repeated: each copy's
// root moves on by the tile's horizontal stride, so a pose repeats exactly `period` frames later,
// one stride further on.
struct TiledWalk {
  Clip clip;
  int period;
  Vector3d stride;
};

TiledWalk tiled_walk(int frames) {
  const Clip walk = cmu_walk();
  const int first = 1, period = walk.frame_count() - first;
  const int joints = walk.joint_count();
  const std::size_t k = walk.translated_joints.size();
  Vector3d stride = (walk.translations[(first + period - 1) * k] - walk.translations[first * k]) * period / (period - 1.0);
  stride.z() = 0;
  TiledWalk tiled{Clip{}, period, stride};
  Clip& clip = tiled.clip;
  clip.skeleton = walk.skeleton;
  clip.fps = walk.fps;
  clip.translated_joints = walk.translated_joints;
  clip.rotations.reserve(std::size_t(frames) * joints);
  clip.translations.reserve(std::size_t(frames) * k);
  for (int f = 0; f < frames; ++f) {
    const int tile = f / period, source_frame = first + f % period;
    clip.rotations.insert(clip.rotations.end(), walk.rotations.begin() + std::size_t(source_frame) * joints,
                          walk.rotations.begin() + std::size_t(source_frame + 1) * joints);
    for (std::size_t t = 0; t < k; ++t) {
      Vector3d translation = walk.translations[source_frame * k + t];
      if (walk.translated_joints[t] == 0) translation += tile * stride;
      clip.translations.push_back(translation);
    }
  }
  return tiled;
}

double peak_rss_mib() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss / 1024.0;  // kilobytes on Linux
}

// Frames `from_tile` against `to_tile`: the same local rotations, the same pose relative to the
// pelvis, and the pelvis `to_tile - from_tile` times `advance` further on.
void expect_repeats(const RetargetResult& result, const TiledWalk& walk, int from_tile, int to_tile, const Vector3d& advance,
                    double tolerance, const std::string& label) {
  const Clip& clip = result.transfer.clip;
  const int pelvis = result.rig.target_joint(canonical::pelvis);
  for (int f = 0; f < walk.period; ++f) {
    const int a = from_tile * walk.period + f, b = to_tile * walk.period + f;
    const std::vector<RigidTransform<double>> pose_a = world_pose(clip, a), pose_b = world_pose(clip, b);
    for (int j = 0; j < clip.joint_count(); ++j) {
      ASSERT_LT(clip.rotation(a, j).angularDistance(clip.rotation(b, j)), tolerance) << label << ": frame " << b << " joint " << j;
      const Vector3d relative_a = pose_a[j].translation - pose_a[pelvis].translation;
      const Vector3d relative_b = pose_b[j].translation - pose_b[pelvis].translation;
      ASSERT_LT((relative_a - relative_b).norm(), tolerance) << label << ": frame " << b << " joint " << j;
    }
    const Vector3d travelled = pose_b[pelvis].translation - pose_a[pelvis].translation;
    ASSERT_LT((travelled - (to_tile - from_tile) * advance).norm(), tolerance) << label << ": frame " << b;
  }
}

Vector3d pelvis_position(const RetargetResult& result, int frame) {
  return world_pose(result.transfer.clip, frame)[result.rig.target_joint(canonical::pelvis)].translation;
}

constexpr int kLongClipFrames = 100000;

TEST(ExtremesTest, HundredThousandFramesDoNotDriftFast) {
  const TiledWalk walk = tiled_walk(kLongClipFrames);
  ASSERT_EQ(walk.clip.frame_count(), kLongClipFrames);
  const auto start = std::chrono::steady_clock::now();
  const RetargetResult result = retarget(walk.clip, rigged_figure());
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("fast, %d frames: %.2f s including metrics (transfer %.3f s), peak RSS %.0f MiB\n", kLongClipFrames, seconds,
              result.report.timings.transfer, peak_rss_mib());
  expect_finite_unit(result.transfer.clip, "100k fast");
  const int last_full_tile = kLongClipFrames / walk.period - 1;
  // The root follows the planted feet (transfer.h): each tile it travels what the legs walk, the
  // scaled stride less what they would slide, the same amount every tile. The first and last
  // tiles are smoothed against the clip's ends; the second and the second last agree 3.8 km apart
  // up to the rounding of the summed steps.
  const Vector3d advance = pelvis_position(result, 2 * walk.period) - pelvis_position(result, walk.period);
  const Vector3d scaled_stride = result.rig.scale * (result.source_feet.levelling * walk.stride);
  EXPECT_GT(advance.norm(), 0.7 * scaled_stride.norm());
  EXPECT_LT(advance.norm(), 1.01 * scaled_stride.norm());
  expect_repeats(result, walk, 1, last_full_tile - 1, advance, 1e-6, "100k fast");
  expect_limbs_under(result.report.result_metrics, 2.0, "100k fast");
}

TEST(ExtremesTest, HundredThousandFramesDoNotDriftBalanced) {
  const TiledWalk walk = tiled_walk(kLongClipFrames);
  RetargetResult result = retarget(walk.clip, rigged_figure());
  const auto start = std::chrono::steady_clock::now();
  refine_balanced(result, walk.clip);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("balanced, %d frames: refine %.2f s (%.0f frames/s), peak RSS %.0f MiB\n", kLongClipFrames, seconds,
              kLongClipFrames / seconds, peak_rss_mib());
  expect_finite_unit(result.transfer.clip, "100k balanced");
  // The first and last tiles may settle differently (warm start, windows at the clip's ends);
  // the second and the second last must agree, 3.8 km apart. Not to rounding: the floor fitted to
  // the tiled walk keeps a residual slope of order 1e-9 rad, so the levelled source climbs some
  // micrometres over the 3.8 km, and the refinement, which holds planted feet at z = 0, bends the
  // legs by that much (measured: 3e-7 m and 3e-6 rad at the last tile, growing in proportion to
  // the distance, the slope's signature; a solver that drifted would wander instead).
  // The refinement may rescale the root's travel to the legs (RefineOptions::fit_stride): the
  // advance is whatever it makes of the second tile, repeated.
  const int last_full_tile = kLongClipFrames / walk.period - 1;
  const Vector3d advance = pelvis_position(result, 2 * walk.period) - pelvis_position(result, walk.period);
  expect_repeats(result, walk, 1, last_full_tile - 1, advance, 1e-4, "100k balanced");
  expect_limbs_under(result.report.result_metrics, 2.0, "100k balanced");
}

// --- Zero-length bones. ---

// The reference rig with `joint` moved onto its parent (its offset zero); its children keep
// their world positions.
Skeleton with_zero_length_bone(const Skeleton& skeleton, const std::string& joint) {
  const std::vector<RigidTransform<double>> rest = skeleton.rest_world();
  std::vector<Vector3d> positions;
  for (const auto& transform : rest) positions.push_back(transform.translation);
  const int j = skeleton.find(joint);
  positions[j] = positions[skeleton.parent(j)];
  return skeleton_from_positions(skeleton.names(), skeleton.parents(), positions, Vector3d::Zero());
}

bool has_degenerate_segment(const RetargetReport& report, const std::string& bone) {
  for (const auto& segment : report.segments) {
    if (segment.bone == bone) return segment.kind == "degenerate";
  }
  return false;
}

TEST(ExtremesTest, ZeroLengthBonesGiveNoNaN) {
  const Skeleton reference = reference_humanoid(ReferenceNames::smplx, 0);
  const Skeleton target_reference = reference_humanoid(ReferenceNames::smplx, 45);
  struct Case {
    std::string label;
    Skeleton source, target;
    std::string degenerate_bone, broken_limb;
  };
  const std::vector<Case> cases = {
      {"source upper arm of zero length", with_zero_length_bone(reference, "left_elbow"), target_reference,
       "left_shoulder->left_elbow", "left_arm"},
      {"target upper arm of zero length", reference, with_zero_length_bone(target_reference, "left_elbow"),
       "left_shoulder->left_elbow", "left_arm"},
      {"target shin of zero length", reference, with_zero_length_bone(target_reference, "right_ankle"),
       "right_knee->right_ankle", "right_leg"},
      {"spine joint of zero length on both", with_zero_length_bone(reference, "spine2"),
       with_zero_length_bone(target_reference, "spine2"), "spine1->spine2", "spine"}};
  for (const Case& c : cases) {
    const Clip source = swinging_motion(c.source, 60, 30, Vector3d(0, -1.1, 0));
    Character target;
    target.name = "target";
    target.skeleton = c.target;
    const RetargetResult result = retarget_fast(source, canonical_names_map(c.source), target, canonical_names_map(c.target));
    expect_finite_unit(result.transfer.clip, c.label);
    EXPECT_TRUE(has_degenerate_segment(result.report, c.degenerate_bone)) << c.label;
    const RetargetMetrics& metrics = result.report.result_metrics;
    EXPECT_TRUE(std::isfinite(metrics.bone_direction.mean_deg) && std::isfinite(metrics.end_effector_mean_m) &&
                std::isfinite(metrics.jitter))
        << c.label;
    // The bone is left out; every other bone, the rest of its limb included, is exact.
    EXPECT_LT(metrics.bone_direction.max_deg, 1e-6) << c.label;
    for (const auto& bone : metrics.bones) EXPECT_NE(bone.name, c.degenerate_bone) << c.label;
  }

  // A rig with no height at all cannot be scaled: rejected by name, not NaN.
  const Skeleton flat = skeleton_from_positions(reference.names(), reference.parents(),
                                                std::vector<Vector3d>(reference.joint_count(), Vector3d(0, 0, 1)), Vector3d::Zero());
  Character point;
  point.skeleton = flat;
  try {
    retarget_fast(swinging_motion(reference, 5, 30, Vector3d::Zero()), canonical_names_map(reference), point,
                  canonical_names_map(flat));
    FAIL() << "a rig without height was accepted";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("no height"), std::string::npos) << error.what();
  }
}

// --- Bones along the up axis. ---

// The reference rig with the spine, neck and head on one vertical line and each leg straight down.
Skeleton upright_rig(double arm_drop_deg, const Vector3d& bone_axis) {
  const Skeleton reference = reference_humanoid(ReferenceNames::smplx, arm_drop_deg);
  const std::vector<RigidTransform<double>> rest = reference.rest_world();
  std::vector<Vector3d> positions;
  for (const auto& transform : rest) positions.push_back(transform.translation);
  for (const char* name : {"spine1", "spine2", "spine3", "neck", "head"}) positions[reference.find(name)].head<2>().setZero();
  for (const char* side : {"left_", "right_"}) {
    const Vector3d hip = positions[reference.find(std::string(side) + "hip")];
    for (const char* name : {"knee", "ankle"}) positions[reference.find(side + std::string(name))].head<2>() = hip.head<2>();
  }
  return skeleton_from_positions(reference.names(), reference.parents(), positions, bone_axis);
}

TEST(ExtremesTest, BonesAlongTheUpAxis) {
  const Skeleton source_rig = upright_rig(0, Vector3d::Zero());
  for (const Vector3d& axis : {Vector3d(0, 0, 0), Vector3d(0, 0, 1), Vector3d(0, 1, 0)}) {
    const std::string label = "target frames with axis (" + std::to_string(axis.x()) + ", " + std::to_string(axis.y()) + ", " +
                              std::to_string(axis.z()) + ") along the bone";
    const Skeleton target_rig = upright_rig(45, axis);
    Character target;
    target.name = "upright";
    target.skeleton = target_rig;
    // The rest pose itself (the spine exactly along +z in every frame), then a swinging motion.
    Clip still = swinging_motion(source_rig, 3, 30, Vector3d::Zero());
    for (int f = 0; f < 3; ++f) {
      for (int j = 0; j < source_rig.joint_count(); ++j) still.rotations[std::size_t(f) * source_rig.joint_count() + j] = source_rig.rest_rotations()[j];
    }
    const BoneMap source_map = canonical_names_map(source_rig), target_map = canonical_names_map(target_rig);
    const RetargetResult at_rest = retarget_fast(still, source_map, target, target_map);
    EXPECT_LT(at_rest.rig.alignment.max_residual_deg, 0.01) << label;
    expect_finite_unit(at_rest.transfer.clip, label);
    // A T-posed source lifts the A-posed target's arms; the vertical spine and legs stay as they are.
    const std::vector<RigidTransform<double>> pose = world_pose(at_rest.transfer.clip, 0);
    const std::vector<RigidTransform<double>> rest = target_rig.rest_world();
    for (const char* name : {"spine1", "spine2", "spine3", "neck", "head", "left_knee", "left_ankle", "right_knee", "right_ankle"}) {
      const int j = target_rig.find(name), p = target_rig.parent(j);
      const Vector3d bone = (pose[j].translation - pose[p].translation).normalized();
      const Vector3d rest_bone = (rest[j].translation - rest[p].translation).normalized();
      EXPECT_LT((bone - rest_bone).norm(), 1e-6) << label << ": " << name;
    }
    const Clip moving = swinging_motion(source_rig, 90, 30, Vector3d(0, -1.1, 0));
    const RetargetResult result = retarget_fast(moving, source_map, target, target_map);
    expect_finite_unit(result.transfer.clip, label);
    expect_continuous_signs(result.transfer.clip, label);
    EXPECT_LT(result.report.result_metrics.bone_direction.max_deg, 1e-6) << label;
  }
}

// --- Off the floor. ---

// A clip lifted 1 m as a whole: the floor is fitted to the feet, so this is a capture floor 1 m
// up. The contacts are the same, and so is the result, up to one constant horizontal shift (the
// fitted floor of the CMU walk is tilted by 0.9 degrees, and levelling it turns the 1 m lift
// slightly sideways).
TEST(ExtremesTest, AClipLiftedOneMetreIsACaptureFloorOneMetreUp) {
  const Clip walk = cmu_walk();
  Clip lifted = walk;
  for (std::size_t t = 0; t < lifted.translations.size(); ++t) {
    if (lifted.translated_joints[t % lifted.translated_joints.size()] == 0) lifted.translations[t].z() += 1.0;
  }
  const Character figure = rigged_figure();
  const RetargetResult on_floor = retarget(walk, figure), raised = retarget(lifted, figure);
  EXPECT_EQ(raised.contacts.planted, on_floor.contacts.planted);
  EXPECT_GT(raised.contacts.planted_count(), walk.frame_count() / 2);
  EXPECT_LT(largest_rotation_difference(raised.transfer.clip, on_floor.transfer.clip), 1e-9);
  const std::size_t k = raised.transfer.clip.translated_joints.size();
  const Vector3d shift = raised.transfer.clip.translations[0] - on_floor.transfer.clip.translations[0];
  EXPECT_NEAR(shift.z(), 0.0, 1e-9);
  EXPECT_LT(shift.norm(), 0.02 * raised.rig.scale);  // sin(0.9 degrees) of the scaled 1 m
  for (int f = 0; f < walk.frame_count(); ++f) {
    for (std::size_t t = 0; t < k; ++t) {
      const Vector3d difference = raised.transfer.clip.translations[f * k + t] - on_floor.transfer.clip.translations[f * k + t];
      ASSERT_LT((difference - (raised.transfer.clip.translated_joints[t] == 0 ? shift : Vector3d::Zero())).norm(), 1e-9)
          << "frame " << f;
    }
  }
  EXPECT_NEAR(raised.report.result_metrics.floating_cm, on_floor.report.result_metrics.floating_cm, 1e-6);
}

// A source 1 m up whose feet never rest (the body moves at 2.5 m/s while the legs swing): no
// contact is found, so there is no floor to keep. The target is placed so that its feet's mean
// clearance over every frame equals the scaled source's above each foot joint's lowest point
// (transfer.h): it walks on the floor, not 1 m above it.
TEST(ExtremesTest, ASourceThatNeverTouchesTheFloor) {
  const Skeleton skeleton = reference_humanoid(ReferenceNames::smplx, 0);
  const Clip source = swinging_motion(skeleton, 120, 30, Vector3d(0, -2.5, 0), 1.0);
  const Character target = mixamo_reference_character(45);
  const RetargetResult result = retarget(source, target);
  EXPECT_EQ(result.contacts.planted_count(), 0);
  expect_finite_unit(result.transfer.clip, "airborne");
  expect_limbs_under(result.report.result_metrics, 2.0, "airborne");
  const RetargetMetrics& metrics = result.report.result_metrics;
  EXPECT_EQ(metrics.penetration_cm, 0.0);  // measured over contact frames: there are none
  EXPECT_EQ(metrics.floating_cm, 0.0);
  double lowest = std::numeric_limits<double>::infinity(), mean = 0;
  const int frames = result.transfer.clip.frame_count();
  for (int f = 0; f < frames; ++f) {
    const std::vector<RigidTransform<double>> pose = world_pose(result.transfer.clip, f);
    std::vector<Vector3d> positions;
    for (const auto& joint : pose) positions.push_back(joint.translation);
    for (int side = 0; side < 2; ++side) {
      const double clearance = foot_clearance(result.target_feet[side], positions);
      lowest = std::min(lowest, clearance);
      mean += clearance / (2 * frames);
    }
  }
  // Measured: the lowest step 2 cm below the floor, the feet 4 cm above it on average.
  EXPECT_NEAR(lowest, 0.0, 0.05) << "the lowest step reaches the floor";
  EXPECT_LT(mean, 0.1) << "the target walks on the floor, not 1 m above it";
}

// --- NaN and infinity in one frame. ---

TEST(ExtremesTest, NonFiniteValueInOneFrameNamesTheFrame) {
  const Skeleton skeleton = reference_humanoid(ReferenceNames::smplx, 0);
  const Character target = mixamo_reference_character(45);
  const BoneMap source_map = canonical_names_map(skeleton), target_map = detect_bone_map(target.skeleton);
  const auto message = [&](const Clip& clip) -> std::string {
    try {
      retarget_fast(clip, source_map, target, target_map, {}, "long_walk.bvh");
    } catch (const std::invalid_argument& error) {
      return error.what();
    }
    return "accepted";
  };
  Clip nan_rotation = swinging_motion(skeleton, 3000, 30, Vector3d(0, -1.1, 0));
  nan_rotation.rotations[std::size_t(2718) * skeleton.joint_count() + skeleton.find("right_knee")].w() =
      std::numeric_limits<double>::quiet_NaN();
  std::string text = message(nan_rotation);
  EXPECT_NE(text.find("long_walk.bvh"), std::string::npos) << text;
  EXPECT_NE(text.find("frame 2718"), std::string::npos) << text;
  EXPECT_NE(text.find("right_knee"), std::string::npos) << text;

  Clip infinite_root = swinging_motion(skeleton, 50, 30, Vector3d(0, -1.1, 0));
  infinite_root.translations[41].y() = std::numeric_limits<double>::infinity();
  text = message(infinite_root);
  EXPECT_NE(text.find("long_walk.bvh"), std::string::npos) << text;
  EXPECT_NE(text.find("frame 41"), std::string::npos) << text;
  EXPECT_NE(text.find("pelvis"), std::string::npos) << text;
}

}  // namespace
}  // namespace odyssey::retarget
