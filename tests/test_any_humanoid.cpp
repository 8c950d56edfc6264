// Any humanoid: characters whose nodes hold another pose than the one their mesh was bound in
// (the rest pose comes from the skins' inverse bind matrices, as Blender's importer guesses it),
// BVH files whose rest pose lies down (the standing reference comes from the motion), and the
// rig conventions that are presets (DAZ/Poser/Second Life BVH, 3ds Max Biped, MotionBuilder
// HumanIK), each on files the tests write.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "derived_characters.h"
#include "humanoid_bvh.h"
#include "posed_characters.h"
#include "mocap_io/bvh.h"
#include "mocap_io/gltf_character.h"
#include "mocap_io/gltf_export.h"
#include "mocap_io/input_error.h"
#include "retarget/bone_map.h"
#include "retarget/canonical.h"
#include "retarget/retarget.h"
#include "test_support.h"

namespace odyssey {
namespace {

using namespace test_support::humanoid_bvh;

using Eigen::Matrix4d;
using Eigen::Quaterniond;
using Eigen::Vector3d;
using test_support::contains;
using test_support::kSharedCharacters;

const std::string kCmuWalk = std::string(ODYSSEY_SHARED_DIR) + "/assets/mocap/cmu_walk_cgspeed.bvh";

std::filesystem::path scratch(const std::string& name) { return test_support::scratch_dir("any_humanoid") / name; }

std::string message_of_load(const std::string& path) {
  return test_support::message_of<io::InputError>([&] { io::load_character(path); });
}

// ---------------------------------------------------------------------------------------------
// The bind pose.

// The shared characters the bind-pose tests pose (every shared humanoid: GLB and .gltf).
// (RobotExpressive's own nodes already hold another pose than its bind pose: below.)
const std::vector<std::string> kPosedCharacters = {"CesiumMan.glb", "RiggedFigure.glb", "male_base_mesh.glb",
                                                   "kaykit_mannequin/manny_med_mod.gltf"};

double rotation_angle(const Quaterniond& a, const Quaterniond& b) { return a.angularDistance(b); }

// The joints' height span (z) in a pose.
double joint_height(const std::vector<RigidTransform<double>>& world) {
  double low = 1e300, high = -1e300;
  for (const auto& joint : world) {
    low = std::min(low, joint.translation.z());
    high = std::max(high, joint.translation.z());
  }
  return high - low;
}

// World joint transforms of the character as its file's nodes pose them (what the rest pose was
// before the bind pose was read from the inverse bind matrices): the posed rotations replace the
// rest ones of the same joints.
std::vector<RigidTransform<double>> node_pose(const Character& bind, const std::filesystem::path& posed_file) {
  std::ifstream in(posed_file, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  nlohmann::json gltf;
  if (posed_file.extension() == ".gltf") {
    gltf = nlohmann::json::parse(bytes);
  } else {
    std::uint32_t length;
    std::memcpy(&length, bytes.data() + 12, 4);
    gltf = nlohmann::json::parse(bytes.substr(20, length));
  }
  const Skeleton& rig = bind.skeleton;
  std::vector<Quaterniond> rotations = rig.rest_rotations();
  for (int j = 0; j < rig.joint_count(); ++j) {
    if (rig.parent(j) < 0) continue;
    const nlohmann::json& node = gltf["nodes"][bind.source_node_of_joint[j]];
    if (!node.contains("rotation")) continue;
    const std::vector<double> r = node["rotation"];
    // Below the root, local rotations in the Z-up world equal the file's (C cancels), when the
    // parent's world scale is uniform, as in every shared character.
    rotations[j] = Quaterniond(r[3], r[0], r[1], r[2]).normalized();
  }
  const Skeleton posed(rig.names(), rig.parents(), rig.rest_offsets(), rotations);
  return posed.rest_world();
}

class PosedCharacterTest : public testing::TestWithParam<std::string> {};

TEST_P(PosedCharacterTest, RestPoseComesFromTheInverseBindMatrices) {
  const Character original = io::load_character(kSharedCharacters + GetParam());
  EXPECT_TRUE(original.rest_pose_origin.starts_with("node transforms")) << original.rest_pose_origin;
  EXPECT_TRUE(original.source_rest_local_of_joint.empty());
  const std::filesystem::path posed_path = test_support::posed_copy(GetParam());
  const Character posed = io::load_character(posed_path.string());
  EXPECT_TRUE(posed.rest_pose_origin.starts_with("inverse bind matrices (the node transforms hold another pose"))
      << posed.rest_pose_origin;
  ASSERT_EQ(posed.skeleton.names(), original.skeleton.names());
  EXPECT_EQ(posed.source_rest_local_of_joint.size(), std::size_t(posed.skeleton.joint_count()));

  // Joint by joint, the rest pose is the original's: float32 matrices inverted and chained agree
  // to about 1e-6 of the size.
  const auto want = original.skeleton.rest_world();
  const auto got = posed.skeleton.rest_world();
  const double height = original.rest_bounds().sizes().z();
  double worst_position = 0, worst_angle = 0;
  for (int j = 0; j < original.skeleton.joint_count(); ++j) {
    worst_position = std::max(worst_position, (got[j].translation - want[j].translation).norm());
    worst_angle = std::max(worst_angle, rotation_angle(Quaterniond(got[j].rotation), Quaterniond(want[j].rotation)));
  }
  EXPECT_LT(worst_position, 1e-5 * height) << GetParam();
  EXPECT_LT(worst_angle, 1e-4) << GetParam();
  // The mesh rests where it did: bounds to 1e-5 of the height.
  const Eigen::AlignedBox3d a = original.rest_bounds(), b = posed.rest_bounds();
  EXPECT_LT((a.min() - b.min()).norm(), 1e-5 * height) << GetParam();
  EXPECT_LT((a.max() - b.max()).norm(), 1e-5 * height) << GetParam();

  // What the rest pose would have been from the nodes: another shape (joints up to a third of the
  // height away), another height.
  const auto nodes = node_pose(original, posed_path);
  double moved = 0;
  for (std::size_t j = 0; j < nodes.size(); ++j) moved = std::max(moved, (nodes[j].translation - got[j].translation).norm());
  const double node_height = joint_height(nodes);
  const double bind_height = joint_height(got);
  std::printf("%s: joints %.4f m tall at bind (the rest pose), %.4f m as the nodes pose them (a joint up to %.4f m away); "
              "mesh %.4f m at rest\n",
              GetParam().c_str(), bind_height, node_height, moved, b.sizes().z());
  EXPECT_GT(moved, 0.1 * bind_height) << GetParam();

  // The humanoid map is the original's.
  const retarget::BoneMap map_original = retarget::humanoid_bone_map(original, "original");
  const retarget::BoneMap map_posed = retarget::humanoid_bone_map(posed, "posed");
  EXPECT_EQ(map_posed.joints, map_original.joints);
}

INSTANTIATE_TEST_SUITE_P(SharedCharacters, PosedCharacterTest, testing::ValuesIn(kPosedCharacters),
                         [](const auto& info) {
                           std::string name = std::filesystem::path(info.param).stem().string();
                           for (char& c : name) {
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           }
                           return name;
                         });

// RobotExpressive's own nodes hold its idle pose (arms down, standing on the floor) while its
// inverse bind matrices hold the T-pose its mesh was modelled in: the rest pose is the T-pose, as
// Blender imports it (test_any_humanoid_blender.cpp compares the two).
TEST(PosedCharacterTest, RobotExpressiveRestsInItsBindPose) {
  const Character robot = io::load_character(kSharedCharacters + "RobotExpressive.glb");
  EXPECT_TRUE(robot.rest_pose_origin.starts_with("inverse bind matrices (the node transforms hold another pose: 34 of 43 skin joints"))
      << robot.rest_pose_origin;
  const auto rest = robot.skeleton.rest_world();
  const auto z = [&](const char* joint) { return rest[robot.skeleton.find(joint)].translation.z(); };
  // The arms straight out sideways: shoulder, elbow and palm within 2% of the height of each other.
  const double height = robot.rest_bounds().sizes().z();
  for (const char* side : {".L", ".R"}) {
    const std::string s = side;
    EXPECT_NEAR(z(("LowerArm" + s).c_str()), z(("UpperArm" + s).c_str()), 0.02 * height) << side;
    EXPECT_NEAR(z(("Palm2" + s).c_str()), z(("UpperArm" + s).c_str()), 0.02 * height) << side;
  }
  std::printf("RobotExpressive: %s; mesh %.4f tall at rest, z from %.4f\n", robot.rest_pose_origin.c_str(), height,
              robot.rest_bounds().min().z());
  EXPECT_TRUE(retarget::humanoid_problems(robot.skeleton, retarget::humanoid_bone_map(robot, "robot")).empty());
}

// Retargeting onto the posed file gives the original's motion, and the written GLB holds the
// bind pose in its nodes, so it reads back as the original with the nodes' pose.
TEST(PosedCharacterRetargetTest, RetargetsAsTheOriginalAndWritesTheBindPose) {
  const Character original = io::load_character(kSharedCharacters + "CesiumMan.glb");
  const std::filesystem::path posed_path = test_support::posed_copy("CesiumMan.glb");
  const Character posed = io::load_character(posed_path.string());
  io::LoadedBvh walk = io::load_bvh_inferring_frame(kCmuWalk);
  const Clip source = walk.clip.resampled(30);
  const retarget::BoneMap source_map = retarget::humanoid_bone_map(source.skeleton, "walk");
  const auto a = retarget::retarget_fast(source, source_map, original, retarget::humanoid_bone_map(original, "a"));
  const auto b = retarget::retarget_fast(source, source_map, posed, retarget::humanoid_bone_map(posed, "b"));
  ASSERT_EQ(a.transfer.clip.frame_count(), b.transfer.clip.frame_count());
  EXPECT_NEAR(a.report.scale, b.report.scale, 1e-6 * a.report.scale);
  std::vector<RigidTransform<double>> wa(original.skeleton.joint_count()), wb(posed.skeleton.joint_count());
  double worst = 0;
  for (int f = 0; f < a.transfer.clip.frame_count(); f += 7) {
    a.transfer.clip.world_pose(f, wa);
    b.transfer.clip.world_pose(f, wb);
    for (std::size_t j = 0; j < wa.size(); ++j) worst = std::max(worst, (wa[j].translation - wb[j].translation).norm());
  }
  EXPECT_LT(worst, 1e-4) << "metres, CesiumMan is 1.5 m tall";

  const std::string out = scratch("posed_cesium_walk.glb").string();
  io::write_animated_glb(posed_path.string(), posed, b.transfer.clip, out);
  const Character written = io::load_character(out);
  EXPECT_TRUE(written.rest_pose_origin.starts_with("node transforms")) << written.rest_pose_origin;
  const auto want = original.skeleton.rest_world();
  const auto got = written.skeleton.rest_world();
  for (int j = 0; j < original.skeleton.joint_count(); ++j) {
    EXPECT_LT((got[j].translation - want[j].translation).norm(), 1e-5) << original.skeleton.name(j);
  }
}

// Base64 for the data URIs the bad files below carry.
std::string base64(const std::string& data) {
  static const char* digits = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (std::size_t i = 0; i < data.size(); i += 3) {
    const std::size_t n = std::min<std::size_t>(3, data.size() - i);
    std::uint32_t chunk = 0;
    for (std::size_t k = 0; k < 3; ++k) chunk = chunk << 8 | (k < n ? static_cast<std::uint8_t>(data[i + k]) : 0);
    for (std::size_t k = 0; k < 4; ++k) out.push_back(k <= n ? digits[(chunk >> (18 - 6 * k)) & 63] : '=');
  }
  return out;
}

// CesiumMan with inverse bind matrix `slot` replaced (a sparse substitution from a buffer of its
// own) by `matrix` (column-major, as glTF stores it).
std::filesystem::path with_inverse_bind(const std::string& name, int slot, const std::array<float, 16>& matrix, int& joint) {
  const std::filesystem::path out = scratch(name);
  test_support::write_derived_gltf(kSharedCharacters + "CesiumMan.glb", out, [&](nlohmann::json& gltf) {
    std::string bytes(4 + 64, '\0');
    bytes[0] = static_cast<char>(slot);  // the sparse index, padded to 4 bytes
    std::memcpy(bytes.data() + 4, matrix.data(), 64);
    const int buffer = static_cast<int>(gltf["buffers"].size());
    gltf["buffers"].push_back({{"byteLength", bytes.size()}, {"uri", "data:application/octet-stream;base64," + base64(bytes)}});
    const int view = static_cast<int>(gltf["bufferViews"].size());
    gltf["bufferViews"].push_back({{"buffer", buffer}, {"byteOffset", 0}, {"byteLength", bytes.size()}});
    nlohmann::json& accessor = gltf["accessors"][gltf["skins"][0]["inverseBindMatrices"].get<int>()];
    accessor["sparse"] = {{"count", 1},
                          {"indices", {{"bufferView", view}, {"byteOffset", 0}, {"componentType", 5121}}},
                          {"values", {{"bufferView", view}, {"byteOffset", 4}}}};
    joint = gltf["skins"][0]["joints"][slot];
  });
  return out;
}

TEST(PosedCharacterTest, SingularOrNonFiniteInverseBindMatricesNameTheSkinAndJoint) {
  // Matrix 0 with a linear part of rank 2 (it flattens the mesh onto a plane): no bind pose.
  int joint = -1;
  const std::filesystem::path flat = with_inverse_bind("ibm_singular.glb", 0, {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1}, joint);
  const std::string singular = message_of_load(flat.string());
  EXPECT_TRUE(contains(singular, flat.string() + ": skin 0 'Armature' inverse bind matrix 0 (joint node " +
                                     std::to_string(joint) + ") is singular (singular values 1, 1, 0)"))
      << singular;

  // Matrix 3 with an infinite translation.
  const float inf = std::numeric_limits<float>::infinity();
  const std::filesystem::path infinite =
      with_inverse_bind("ibm_infinite.glb", 3, {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, inf, 0, 0, 1}, joint);
  const std::string not_finite = message_of_load(infinite.string());
  EXPECT_TRUE(contains(not_finite, infinite.string() + ": skin 0 'Armature' inverse bind matrix 3 (joint node " +
                                       std::to_string(joint) + ") is not finite"))
      << not_finite;
}

// ---------------------------------------------------------------------------------------------
// BVH rest poses that do not stand up.

// The issue's file: 21 joints, every one with position channels, rest offsets along +x.
TEST(LyingBvhTest, TheFirstFrameStandsInForARestPoseAlongX) {
  const std::vector<BvhJoint> joints = humanoid(plain_names());
  const std::vector<BvhFrame> frames = walk_frames(joints, 60);
  const std::string lying = write_bvh("lying_x.bvh", joints, frames, RestKind::along_x, true);
  const std::string standing = write_bvh("standing.bvh", joints, frames, RestKind::standing, true);

  const io::LoadedBvh a = io::load_bvh_inferring_frame(lying);
  EXPECT_EQ(a.frame.measured_on, "first frame");
  EXPECT_EQ(a.frame.reference_frame, 0);
  EXPECT_EQ(a.frame.unit, "cm");
  EXPECT_EQ(a.frame.up, io::BvhUp::y);
  EXPECT_NEAR(a.frame.height_m(), 1.62, 0.005);  // head joint 98 + 10 + 24 + 20 + 10 = 162 cm, toe 98 - 6 - 43 - 42 - 7 = 0
  EXPECT_TRUE(a.frame.plausible);
  EXPECT_TRUE(contains(a.frame.description(), "the rest pose does not stand up, so the first frame is the rest pose"))
      << a.frame.description();

  // The rest pose is frame 0's, and every frame poses exactly as the file says (the same as the
  // file written with standing offsets).
  const io::LoadedBvh b = io::load_bvh_inferring_frame(standing);
  EXPECT_EQ(b.frame.measured_on, "rest pose");
  ASSERT_EQ(a.clip.frame_count(), b.clip.frame_count());
  std::vector<RigidTransform<double>> wa(a.clip.joint_count()), wb(b.clip.joint_count());
  a.clip.world_pose(0, wa);
  const auto rest = a.clip.skeleton.rest_world();
  for (std::size_t j = 0; j < wa.size(); ++j) EXPECT_LT((rest[j].translation - wa[j].translation).norm(), 1e-12);
  double worst = 0;
  for (int f = 0; f < a.clip.frame_count(); ++f) {
    a.clip.world_pose(f, wa);
    b.clip.world_pose(f, wb);
    for (std::size_t j = 0; j < wa.size(); ++j) worst = std::max(worst, (wa[j].translation - wb[j].translation).norm());
  }
  EXPECT_LT(worst, 1e-9);

  // It is a humanoid now, and retargets as the standing file does from its first frame.
  const retarget::BoneMap map_a = retarget::humanoid_bone_map(a.clip.skeleton, lying);
  const retarget::BoneMap map_b = retarget::humanoid_bone_map(b.clip.skeleton, standing);
  EXPECT_EQ(map_a.joints, map_b.joints);
  const Character target = io::load_character(kSharedCharacters + "CesiumMan.glb");
  const retarget::BoneMap target_map = retarget::humanoid_bone_map(target, "CesiumMan");
  retarget::RetargetOptions from_first_frame;
  from_first_frame.source_rest = retarget::SourceRest::first_frame;
  const auto ra = retarget::retarget_fast(a.clip.resampled(30), map_a, target, target_map);
  const auto rb = retarget::retarget_fast(b.clip.resampled(30), map_b, target, target_map, from_first_frame);
  EXPECT_NEAR(ra.report.scale, rb.report.scale, 1e-9);
  std::vector<RigidTransform<double>> ta(target.skeleton.joint_count()), tb(target.skeleton.joint_count());
  double worst_target = 0;
  for (int f = 0; f < ra.transfer.clip.frame_count(); ++f) {
    ra.transfer.clip.world_pose(f, ta);
    rb.transfer.clip.world_pose(f, tb);
    for (std::size_t j = 0; j < ta.size(); ++j) worst_target = std::max(worst_target, (ta[j].translation - tb[j].translation).norm());
  }
  EXPECT_LT(worst_target, 1e-6) << "metres";
  std::printf("lying BVH retargeted onto CesiumMan: %d frames, scale %.4f, worst joint %.2e m from the standing file's\n",
              ra.transfer.clip.frame_count(), ra.report.scale, worst_target);
}

TEST(LyingBvhTest, AFrameThatStandsWhenTheFirstDoesNot) {
  // Every offset zero, and the first frame collapsed too (every position channel zero): the
  // second frame is the first that stands.
  const std::vector<BvhJoint> joints = humanoid(plain_names());
  std::vector<BvhFrame> frames = walk_frames(joints, 10);
  const std::string path = write_bvh("zero_rest.bvh", joints, frames, RestKind::zero, true);
  std::string text;
  {
    std::ifstream in(path);
    text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  const std::size_t first = text.find("Frame Time: 0.0333333\n") + std::string("Frame Time: 0.0333333\n").size();
  const std::size_t end = text.find('\n', first);
  std::string zeros;
  for (std::size_t k = 0; k < 6 * joints.size(); ++k) zeros += "0 ";
  text.replace(first, end - first, zeros);
  std::ofstream(path) << text;
  const io::LoadedBvh loaded = io::load_bvh_inferring_frame(path);
  EXPECT_EQ(loaded.frame.measured_on, "frame 1");
  EXPECT_EQ(loaded.frame.reference_frame, 1);
  EXPECT_EQ(loaded.frame.unit, "cm");
  EXPECT_NO_THROW(retarget::humanoid_bone_map(loaded.clip.skeleton, path));
}

// ---------------------------------------------------------------------------------------------
// Conventions as presets, joint by joint on BVH files the tests write.

struct ConventionCase {
  std::string label;   // test name
  std::string preset;  // the preset expected
  std::map<std::string, std::string> names;
  std::string extra_root;
  std::string legs_from = "pelvis";
};

std::vector<ConventionCase> convention_cases() {
  std::vector<ConventionCase> cases;
  {
    ConventionCase poser{"PoserDazSecondLife", "poser_bvh", {{"pelvis", "hip"}, {"spine1", "abdomen"}, {"spine3", "chest"},
                                                             {"neck", "neck"}, {"head", "head"}}, ""};
    for (const auto& [side, s] : {std::pair("left_", "l"), std::pair("right_", "r")}) {
      const std::string p = side, n = s;
      poser.names[p + "collar"] = n + "Collar";
      poser.names[p + "shoulder"] = n + "Shldr";
      poser.names[p + "elbow"] = n + "ForeArm";
      poser.names[p + "wrist"] = n + "Hand";
      poser.names[p + "hip"] = n + "Thigh";
      poser.names[p + "knee"] = n + "Shin";
      poser.names[p + "ankle"] = n + "Foot";
      poser.names[p + "foot"] = n + "Toe";
      for (const auto& [finger, word] : {std::pair("thumb", "Thumb"), std::pair("index", "Index"), std::pair("middle", "Mid"),
                                         std::pair("ring", "Ring"), std::pair("pinky", "Pinky")}) {
        for (int k = 1; k <= 3; ++k) poser.names[p + finger + std::to_string(k)] = n + word + std::to_string(k);
      }
    }
    cases.push_back(poser);
    // Second Life's BVH files: the same names, no toes and no fingers.
    ConventionCase second_life = poser;
    second_life.label = "SecondLifeWithoutToesOrFingers";
    std::erase_if(second_life.names, [](const auto& item) {
      const std::string& role = item.first;
      return role.ends_with("_foot") || role.find("thumb") != std::string::npos || role.find("index") != std::string::npos ||
             role.find("middle") != std::string::npos || role.find("ring") != std::string::npos ||
             role.find("pinky") != std::string::npos;
    });
    cases.push_back(second_life);
  }
  for (const std::string prefix : {"Bip01 ", "Bip001 "}) {
    ConventionCase biped{prefix == "Bip01 " ? "MaxBiped" : "MaxBipedBip001", "max_biped",
                         {{"pelvis", prefix + "Pelvis"}, {"spine1", prefix + "Spine"}, {"spine2", prefix + "Spine1"},
                          {"spine3", prefix + "Spine2"}, {"neck", prefix + "Neck"}, {"head", prefix + "Head"}},
                         prefix.substr(0, prefix.size() - 1), "spine1"};
    for (const auto& [side, s] : {std::pair("left_", "L "), std::pair("right_", "R ")}) {
      const std::string p = side, n = prefix + s;
      biped.names[p + "collar"] = n + "Clavicle";
      biped.names[p + "shoulder"] = n + "UpperArm";
      biped.names[p + "elbow"] = n + "Forearm";
      biped.names[p + "wrist"] = n + "Hand";
      biped.names[p + "hip"] = n + "Thigh";
      biped.names[p + "knee"] = n + "Calf";
      biped.names[p + "ankle"] = n + "Foot";
      biped.names[p + "foot"] = n + "Toe0";
      int f = 0;
      for (const char* finger : {"thumb", "index", "middle", "ring", "pinky"}) {
        biped.names[p + finger + "1"] = n + "Finger" + std::to_string(f);
        biped.names[p + finger + "2"] = n + "Finger" + std::to_string(f) + "1";
        biped.names[p + finger + "3"] = n + "Finger" + std::to_string(f) + "2";
        ++f;
      }
    }
    cases.push_back(biped);
  }
  for (const std::string prefix : {"Character1_", "Character2_"}) {
    ConventionCase hik{prefix == "Character1_" ? "HumanIk" : "HumanIkCharacter2", "humanik",
                       {{"pelvis", prefix + "Hips"}, {"spine1", prefix + "Spine"}, {"spine2", prefix + "Spine1"},
                        {"spine3", prefix + "Spine2"}, {"neck", prefix + "Neck"}, {"head", prefix + "Head"}},
                       prefix + "Reference"};
    for (const auto& [side, s] : {std::pair("left_", "Left"), std::pair("right_", "Right")}) {
      const std::string p = side, n = prefix + s;
      hik.names[p + "collar"] = n + "Shoulder";
      hik.names[p + "shoulder"] = n + "Arm";
      hik.names[p + "elbow"] = n + "ForeArm";
      hik.names[p + "wrist"] = n + "Hand";
      hik.names[p + "hip"] = n + "UpLeg";
      hik.names[p + "knee"] = n + "Leg";
      hik.names[p + "ankle"] = n + "Foot";
      hik.names[p + "foot"] = n + "ToeBase";
      for (const auto& [finger, word] : {std::pair("thumb", "Thumb"), std::pair("index", "Index"), std::pair("middle", "Middle"),
                                         std::pair("ring", "Ring"), std::pair("pinky", "Pinky")}) {
        for (int k = 1; k <= 3; ++k) hik.names[p + finger + std::to_string(k)] = n + "Hand" + word + std::to_string(k);
      }
    }
    cases.push_back(hik);
  }
  return cases;
}

class ConventionTest : public testing::TestWithParam<ConventionCase> {};

TEST_P(ConventionTest, EveryJointMapsAsTheConventionSays) {
  const ConventionCase& c = GetParam();
  const std::vector<BvhJoint> joints = humanoid(c.names, c.extra_root, c.legs_from);
  const std::string path = write_bvh(c.label + ".bvh", joints, walk_frames(joints, 4), RestKind::standing, false);
  const io::LoadedBvh loaded = io::load_bvh_inferring_frame(path);
  EXPECT_EQ(loaded.frame.unit, "cm");
  const retarget::BoneMap map = retarget::humanoid_bone_map(loaded.clip.skeleton, path);
  EXPECT_EQ(map.origin, "preset " + c.preset);
  const Skeleton& rig = loaded.clip.skeleton;
  int checked = 0;
  for (const auto& [canonical, name] : c.names) {
    const int index = retarget::canonical_index(canonical);
    ASSERT_GE(index, 0) << canonical;
    ASSERT_TRUE(map.mapped(index)) << c.label << ": " << canonical << " (" << name << ") unmapped";
    EXPECT_EQ(rig.name(map.joints[index]), name) << c.label << ": " << canonical;
    ++checked;
  }
  // Every canonical joint the file does not name stays unmapped.
  EXPECT_EQ(map.mapped_count(), checked) << c.label;
  if (!c.extra_root.empty()) {
    EXPECT_EQ(map.canonical_of(rig.find(c.extra_root)), -1);
  }
}

INSTANTIATE_TEST_SUITE_P(Presets, ConventionTest, testing::ValuesIn(convention_cases()),
                         [](const auto& info) { return info.param.label; });

}  // namespace
}  // namespace odyssey
