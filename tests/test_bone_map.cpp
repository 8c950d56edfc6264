// Bone maps: presets on every shared character and the CMU BVH, detection from names in several
// naming conventions (it must agree with the presets; Rigify, KayKit, Unreal, MakeHuman), maps
// VRM files declare, user maps over detection, the joints left unmapped, the humanoid check (the
// Fox is not one; sides judged whichever way a rig faces), and bone map files that are not right.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "mocap_io/bone_map_file.h"
#include "mocap_io/bvh.h"
#include "mocap_io/gltf_character.h"
#include "mocap_io/input_error.h"
#include "retarget/bone_map.h"
#include "retarget/reference_rig.h"
#include "derived_characters.h"
#include "skeleton/rotation.h"
#include "test_support.h"

namespace odyssey::retarget {
namespace {

namespace fs = std::filesystem;

const std::string kAssets = std::string(ODYSSEY_SHARED_DIR) + "/assets";

Character character(const std::string& name) { return io::load_character(kAssets + "/characters/" + name); }

// canonical name -> rig joint name, for the mapped ones.
std::map<std::string, std::string> named(const Skeleton& rig, const BoneMap& map) {
  std::map<std::string, std::string> result;
  for (int c = 0; c < kCanonicalJointCount; ++c) {
    if (map.mapped(c)) result[std::string(canonical_name(c))] = rig.name(map.joints[c]);
  }
  return result;
}

std::string write_scratch(const std::string& name, const std::string& text) {
  const fs::path dir = odyssey::test_support::scratch_root() / "bone_map";
  fs::create_directories(dir);
  const fs::path path = dir / name;
  std::ofstream(path, std::ios::binary) << text;
  return path.string();
}

// The same skeleton with every joint renamed.
Skeleton renamed(const Skeleton& rig, const std::function<std::string(const std::string&)>& rename) {
  std::vector<std::string> names;
  for (const std::string& name : rig.names()) names.push_back(rename(name));
  return Skeleton(names, rig.parents(), rig.rest_offsets(), rig.rest_rotations());
}

std::map<std::string, std::string> preset_entries(const std::string& preset) {
  std::map<std::string, std::string> entries;
  for (const io::BoneMapEntry& entry : load_preset(preset).entries) entries[entry.canonical] = entry.rig_joints.front();
  return entries;
}

TEST(BoneMapTest, EveryPresetLoadsAndNamesOnlyCanonicalJoints) {
  const std::vector<std::string> presets = preset_names();
  EXPECT_EQ(presets, (std::vector<std::string>{"cesium_man", "cmu_bvh", "humanik", "max_biped", "mixamo", "poser_bvh",
                                             "rigged_figure", "robot_expressive", "smplx"}));
  for (const std::string& preset : presets) {
    for (const io::BoneMapEntry& entry : load_preset(preset).entries) {
      EXPECT_GE(canonical_index(entry.canonical), 0) << preset << ": " << entry.canonical;
      EXPECT_FALSE(entry.rig_joints.empty()) << preset << ": " << entry.canonical;
    }
  }
  EXPECT_THROW(load_preset("no_such_rig"), io::InputError);
}

TEST(BoneMapTest, SharedCharactersGetTheirPresets) {
  const std::map<std::string, std::string> expected = {{"CesiumMan.glb", "preset cesium_man"},
                                                       {"RiggedFigure.glb", "preset rigged_figure"},
                                                       {"RobotExpressive.glb", "preset robot_expressive"}};
  for (const auto& [file, origin] : expected) {
    const Character rig = character(file);
    const BoneMap map = humanoid_bone_map(rig.skeleton, file);
    EXPECT_EQ(map.origin, origin) << file;
    EXPECT_TRUE(humanoid_problems(rig.skeleton, map).empty()) << file;
  }
  // The joints nobody would guess: CesiumMan's unnamed nodes (its left side is +Y, it faces +X),
  // RobotExpressive's pelvis (Body, not Hips) and IK feet.
  const Character cesium = character("CesiumMan.glb");
  const auto cesium_map = named(cesium.skeleton, detect_bone_map(cesium.skeleton));
  EXPECT_EQ(cesium_map.at("left_shoulder"), "joint_16");
  EXPECT_EQ(cesium_map.at("left_wrist"), "joint_18");
  EXPECT_EQ(cesium_map.at("left_hip"), "joint_7");
  EXPECT_EQ(cesium_map.at("right_foot"), "joint_6");
  const Character robot = character("RobotExpressive.glb");
  const BoneMap robot_map = detect_bone_map(robot.skeleton);
  const auto robot_names = named(robot.skeleton, robot_map);
  EXPECT_EQ(robot_names.at("pelvis"), "Body");
  EXPECT_EQ(robot_names.at("left_ankle"), "Foot.L");
  EXPECT_EQ(robot_names.at("left_wrist"), "Palm2.L");
  ASSERT_EQ(robot_map.followers.size(), 4u);
  EXPECT_EQ(robot.skeleton.name(robot_map.followers[0].joint), "Palm1.L");
  EXPECT_EQ(robot_map.followers[0].canonical, canonical::left_wrist);
}

TEST(BoneMapTest, FoxIsNotHumanoid) {
  const Character fox = character("Fox.glb");
  try {
    humanoid_bone_map(fox.skeleton, "Fox.glb");
    FAIL() << "the Fox was taken for a humanoid";
  } catch (const io::InputError& error) {
    EXPECT_EQ(error.file(), "Fox.glb");
    EXPECT_NE(error.problem().find("not a humanoid rig"), std::string::npos) << error.what();
    EXPECT_NE(error.problem().find("left_hip, right_hip"), std::string::npos) << error.what();
  }
  for (const char* file : {"RiggedSimple.glb", "SimpleSkin.gltf"}) {
    EXPECT_THROW(humanoid_bone_map(character(file).skeleton, file), io::InputError) << file;
  }
}

TEST(BoneMapTest, CmuBvhPresetAndNamesAgree) {
  const Clip walk = io::load_bvh(kAssets + "/mocap/cmu_walk_cgspeed.bvh", {io::kCmuMetresPerUnit});
  const BoneMap map = humanoid_bone_map(walk.skeleton, "walk");
  EXPECT_EQ(map.origin, "preset cmu_bvh");
  const auto mapped = named(walk.skeleton, map);
  EXPECT_EQ(mapped.at("left_hip"), "LeftUpLeg");  // not the zero-length LHipJoint
  EXPECT_EQ(mapped.at("left_collar"), "LeftShoulder");
  EXPECT_EQ(mapped.at("left_shoulder"), "LeftArm");
  EXPECT_EQ(mapped.at("spine1"), "Spine");
  EXPECT_EQ(mapped.at("spine3"), "Spine1");
  EXPECT_EQ(mapped.at("neck"), "Neck1");
  EXPECT_EQ(mapped.at("left_foot"), "LeftToeBase");
  EXPECT_EQ(named(walk.skeleton, bone_map_from_names(walk.skeleton)), mapped);

  std::vector<std::string> unmapped;
  for (int j : unmapped_joints(walk.skeleton, map)) unmapped.push_back(walk.skeleton.name(j));
  EXPECT_EQ(unmapped, (std::vector<std::string>{"LHipJoint", "RHipJoint", "LowerBack", "Neck", "LeftFingerBase", "RightFingerBase"}));
}

TEST(BoneMapTest, MixamoRigGetsThePresetAndNamesAgree) {
  const Skeleton mixamo = reference_humanoid(ReferenceNames::mixamo, 45);
  const BoneMap map = humanoid_bone_map(mixamo, "mixamo rig");
  EXPECT_EQ(map.origin, "preset mixamo");
  const auto mapped = named(mixamo, map);
  EXPECT_EQ(mapped, preset_entries("mixamo"));
  EXPECT_EQ(mapped.at("left_shoulder"), "mixamorig:LeftArm");  // the upper arm, not LeftShoulder
  EXPECT_EQ(mapped.at("left_collar"), "mixamorig:LeftShoulder");
  EXPECT_EQ(named(mixamo, bone_map_from_names(mixamo)), mapped);
  std::vector<std::string> unmapped;
  for (int j : unmapped_joints(mixamo, map)) unmapped.push_back(mixamo.name(j));
  EXPECT_EQ(unmapped.size(), 13u);  // the end joints
  EXPECT_EQ(unmapped.front(), "mixamorig:HeadTop_End");
}

TEST(BoneMapTest, SmplxNamesMapToThemselves) {
  const Skeleton smplx = reference_humanoid(ReferenceNames::smplx, 0);
  EXPECT_EQ(detect_bone_map(smplx).origin, "preset smplx");
  const BoneMap by_names = bone_map_from_names(smplx);
  for (int c = 0; c < kCanonicalJointCount; ++c) EXPECT_EQ(by_names.joints[c], c) << canonical_name(c);
}

// The Mixamo body under other naming conventions: detection from names must find the same joints.
TEST(BoneMapTest, DetectionNormalisesPrefixesSeparatorsCaseAndSides) {
  const Skeleton mixamo = reference_humanoid(ReferenceNames::mixamo, 45);
  const auto expected = named(mixamo, bone_map_from_names(mixamo));
  const auto strip = [](const std::string& name) { return name.substr(name.find(':') + 1); };
  // Blender style: UpperArm.L; snake case with l_/r_ prefixes; another prefix; all lower case.
  const std::map<std::string, std::string> blender = {
      {"Hips", "hips"}, {"Spine", "spine"}, {"Spine1", "spine.001"}, {"Spine2", "chest"}, {"Neck", "neck"}, {"Head", "head"},
      {"LeftShoulder", "shoulder.L"}, {"LeftArm", "upper_arm.L"}, {"LeftForeArm", "forearm.L"}, {"LeftHand", "hand.L"},
      {"LeftUpLeg", "thigh.L"}, {"LeftLeg", "shin.L"}, {"LeftFoot", "foot.L"}, {"LeftToeBase", "toe.L"},
      {"RightShoulder", "shoulder.R"}, {"RightArm", "upper_arm.R"}, {"RightForeArm", "forearm.R"}, {"RightHand", "hand.R"},
      {"RightUpLeg", "thigh.R"}, {"RightLeg", "shin.R"}, {"RightFoot", "foot.R"}, {"RightToeBase", "toe.R"}};
  const Skeleton blender_rig = renamed(mixamo, [&](const std::string& name) {
    const auto it = blender.find(strip(name));
    return it != blender.end() ? it->second : "extra_" + strip(name);
  });
  const BoneMap blender_map = bone_map_from_names(blender_rig);
  for (const auto& [canonical, joint] : expected) {
    const int c = canonical_index(canonical);
    if (c > canonical::right_wrist || c == canonical::left_eye || c == canonical::right_eye) continue;  // fingers, eyes renamed away
    ASSERT_TRUE(blender_map.mapped(c)) << canonical;
    EXPECT_EQ(strip(mixamo.name(blender_map.joints[c])), strip(joint)) << canonical;
  }
  const auto variants = std::vector<std::function<std::string(const std::string&)>>{
      [&](const std::string& n) { return "Character1_" + strip(n); },  // another prefix, no colon
      [&](const std::string& n) { return "rig:" + strip(n); },
      [&](const std::string& n) {  // l_/r_ prefixes in snake case
        std::string s = strip(n);
        for (const auto& [side, short_side] : {std::pair("Left", "l_"), std::pair("Right", "r_")}) {
          if (s.starts_with(side)) s = short_side + s.substr(std::string(side).size());
        }
        return s;
      },
  };
  for (std::size_t v = 0; v < variants.size(); ++v) {
    const Skeleton rig = renamed(mixamo, variants[v]);
    const BoneMap map = bone_map_from_names(rig);
    for (const auto& [canonical, joint] : expected) {
      const int c = canonical_index(canonical);
      ASSERT_TRUE(map.mapped(c)) << "variant " << v << ": " << canonical;
      EXPECT_EQ(map.joints[c], mixamo.find(joint)) << "variant " << v << ": " << canonical;
    }
  }
}

TEST(BoneMapTest, UserMapOverridesAndUnmaps) {
  const Character figure = character("RiggedFigure.glb");
  const std::string path = write_scratch("figure.json", R"({
    "name": "mine",
    "joints": {"spine3": "torso_joint_2", "spine1": null, "left_wrist": ["arm_joint_L_3"]}
  })");
  const BoneMap map = humanoid_bone_map(figure.skeleton, "RiggedFigure.glb", path);
  EXPECT_EQ(map.origin, "user map " + path + " over preset rigged_figure");
  const auto mapped = named(figure.skeleton, map);
  EXPECT_EQ(mapped.at("spine3"), "torso_joint_2");
  EXPECT_EQ(mapped.count("spine1"), 0u);
  EXPECT_EQ(mapped.at("left_wrist"), "arm_joint_L_3");
  // torso_joint_3 lost its role to nobody: it is now unmapped.
  std::vector<std::string> unmapped;
  for (int j : unmapped_joints(figure.skeleton, map)) unmapped.push_back(figure.skeleton.name(j));
  EXPECT_EQ(unmapped, (std::vector<std::string>{"torso_joint_3"}));
}

TEST(BoneMapTest, UserMapProblemsNameTheFileAndTheJoint) {
  const Character figure = character("RiggedFigure.glb");
  const std::string unknown_joint = write_scratch("unknown_joint.json", R"({"joints": {"head": "skull"}})");
  try {
    humanoid_bone_map(figure.skeleton, "RiggedFigure.glb", unknown_joint);
    FAIL();
  } catch (const io::InputError& error) {
    EXPECT_EQ(error.file(), unknown_joint);
    EXPECT_NE(error.problem().find("'skull'"), std::string::npos) << error.what();
  }
  const std::string unknown_canonical = write_scratch("unknown_canonical.json", R"({"joints": {"left_tail": "neck_joint_1"}})");
  EXPECT_THROW(humanoid_bone_map(figure.skeleton, "RiggedFigure.glb", unknown_canonical), io::InputError);
  // Swapping the sides is caught by the rest-pose check.
  std::string swapped = R"({"joints": {)";
  for (const char* part : {"shoulder", "elbow", "wrist", "hip", "knee", "ankle", "foot"}) {
    const std::map<std::string, std::string> joint_of = {{"shoulder", "arm_joint_X_1"}, {"elbow", "arm_joint_X_2"}, {"wrist", "arm_joint_X_3"},
                                                         {"hip", "leg_joint_X_1"}, {"knee", "leg_joint_X_2"}, {"ankle", "leg_joint_X_3"},
                                                         {"foot", "leg_joint_X_5"}};
    std::string left = joint_of.at(part), right = left;
    left.replace(left.find('X'), 1, "R");
    right.replace(right.find('X'), 1, "L");
    swapped += std::string("\"left_") + part + "\": \"" + left + "\", \"right_" + part + "\": \"" + right + "\", ";
  }
  swapped.resize(swapped.size() - 2);
  swapped += "}}";
  try {
    humanoid_bone_map(figure.skeleton, "RiggedFigure.glb", write_scratch("swapped.json", swapped));
    FAIL();
  } catch (const io::InputError& error) {
    EXPECT_NE(error.problem().find("left and right are swapped"), std::string::npos) << error.what();
  }
}

TEST(BoneMapFileTest, RejectsBadFiles) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"{\"joints\": ", "not valid JSON"},
      {"[1, 2]", "must be a JSON object"},
      {"{\"name\": \"x\"}", "needs a \"joints\" object"},
      {"{\"joints\": {\"head\": 3}}", "'head' must map to"},
      {"{\"joints\": {\"head\": []}}", "empty list"},
      {"{\"joints\": {\"head\": \"Head\", \"neck\": \"Head\"}}", "mapped twice"},
      {"{\"joints\": {\"head\": \"\"}}", "empty joint name"},
      {"{\"name\": 1, \"joints\": {}}", "'name' must be a string"},
  };
  for (const auto& [text, problem] : cases) {
    try {
      io::parse_bone_map(text, "case.json");
      FAIL() << text;
    } catch (const io::InputError& error) {
      EXPECT_EQ(error.file(), "case.json");
      EXPECT_NE(error.problem().find(problem), std::string::npos) << text << " -> " << error.what();
    }
  }
  EXPECT_THROW(io::load_bone_map_file(odyssey::test_support::scratch_root().string() + "/bone_map/does_not_exist.json"), io::InputError);
  const io::BoneMapFile file = io::parse_bone_map(R"({"joints": {"pelvis": "Hips", "jaw": null, "left_wrist": ["a", "b"]}})", "ok");
  ASSERT_EQ(file.entries.size(), 3u);
  EXPECT_EQ(file.entries[0].canonical, "pelvis");  // file order kept
  EXPECT_TRUE(file.entries[1].rig_joints.empty());
  EXPECT_EQ(file.entries[2].rig_joints, (std::vector<std::string>{"a", "b"}));
}

// --- Rig conventions beyond Mixamo: each joint's role, asserted pair by pair. ---

void expect_roles(const Skeleton& rig, const BoneMap& map, const std::map<std::string, std::string>& roles,
                  const std::string& label) {
  const auto mapped = named(rig, map);
  for (const auto& [canonical, joint] : roles) {
    ASSERT_TRUE(mapped.count(canonical)) << label << ": nothing plays " << canonical;
    EXPECT_EQ(mapped.at(canonical), joint) << label << ": " << canonical;
  }
  EXPECT_TRUE(humanoid_problems(rig, map).empty()) << label;
}

// Blender Rigify metarig: the spine is spine, spine.001 .. spine.005 with no joint named head or
// neck; the shoulders hang from spine.003, so spine.004 is the neck and spine.005 the head. The
// armature is turned and offset at its root, and A-posed.
TEST(BoneMapTest, RigifyMaleBaseMeshGetsItsRoles) {
  const Character male = character("male_base_mesh.glb");
  const BoneMap map = humanoid_bone_map(male, "male_base_mesh.glb");
  EXPECT_EQ(map.origin, "joint names");
  expect_roles(male.skeleton, map,
               {{"pelvis", "spine"}, {"spine1", "spine.001"}, {"spine2", "spine.002"}, {"spine3", "spine.003"},
                {"neck", "spine.004"}, {"head", "spine.005"}, {"left_collar", "shoulder.L"}, {"left_shoulder", "upper_arm.L"},
                {"left_elbow", "forearm.L"}, {"left_wrist", "hand.L"}, {"right_wrist", "hand.R"}, {"left_hip", "thigh.L"},
                {"left_knee", "shin.L"}, {"left_ankle", "foot.L"}, {"left_foot", "toe.L"}, {"right_foot", "toe.R"},
                {"left_index1", "f_index.01.L"}, {"left_thumb3", "thumb.03.L"}},
               "Rigify");
}

// KayKit's dotted lower-case sides; wrist.l is the wrist and hand.l (its child) rides on it.
TEST(BoneMapTest, KayKitDottedNamesGetTheirRoles) {
  const Character kaykit = character("kaykit_mannequin/manny_med_mod.gltf");
  const BoneMap map = humanoid_bone_map(kaykit, "manny_med_mod.gltf");
  expect_roles(kaykit.skeleton, map,
               {{"pelvis", "hips"}, {"spine1", "spine"}, {"spine3", "chest"}, {"head", "head"}, {"left_shoulder", "upperarm.l"},
                {"left_elbow", "lowerarm.l"}, {"left_wrist", "wrist.l"}, {"right_wrist", "wrist.r"}, {"left_hip", "upperleg.l"},
                {"left_knee", "lowerleg.l"}, {"left_ankle", "foot.l"}, {"left_foot", "toes.l"}, {"right_foot", "toes.r"}},
               "KayKit");
}

TEST(BoneMapTest, SharedPresetCharactersKeepTheirRoles) {
  const Character figure = character("RiggedFigure.glb");
  expect_roles(figure.skeleton, humanoid_bone_map(figure, "RiggedFigure.glb"),
               {{"pelvis", "torso_joint_1"}, {"left_hip", "leg_joint_L_1"}, {"left_knee", "leg_joint_L_2"},
                {"left_shoulder", "arm_joint_L_1"}, {"left_wrist", "arm_joint_L_3"}, {"head", "neck_joint_2"}},
               "RiggedFigure");
  const Character robot = character("RobotExpressive.glb");
  expect_roles(robot.skeleton, humanoid_bone_map(robot, "RobotExpressive.glb"),
               {{"pelvis", "Body"}, {"left_hip", "UpperLeg.L"}, {"left_knee", "LowerLeg.L"}, {"left_ankle", "Foot.L"},
                {"left_shoulder", "UpperArm.L"}, {"left_wrist", "Palm2.L"}, {"head", "Head"}},
               "RobotExpressive");
  const Character cesium = character("CesiumMan.glb");
  expect_roles(cesium.skeleton, humanoid_bone_map(cesium, "CesiumMan.glb"),
               {{"left_shoulder", "joint_16"}, {"left_wrist", "joint_18"}, {"left_hip", "joint_7"}, {"right_foot", "joint_6"}},
               "CesiumMan");
}

// Unreal mannequin names on the Rigify rig (turned at its root, A-posed) and on the Mixamo
// reference rig (T-pose): pelvis, spine_01.., neck_01, clavicle_l, upperarm_l, lowerarm_l,
// hand_l, thigh_l, calf_l, foot_l, ball_l, index_01_l.
TEST(BoneMapTest, UnrealMannequinNamesGetTheirRoles) {
  const Character unreal = io::load_character(test_support::unreal_character(odyssey::test_support::scratch_root() / "bone_map"));
  const BoneMap map = humanoid_bone_map(unreal, "unreal_male.glb");
  expect_roles(unreal.skeleton, map,
               {{"pelvis", "pelvis"}, {"spine1", "spine_01"}, {"spine2", "spine_02"}, {"spine3", "spine_03"}, {"neck", "neck_01"},
                {"head", "head"}, {"left_collar", "clavicle_l"}, {"left_shoulder", "upperarm_l"}, {"left_elbow", "lowerarm_l"},
                {"left_wrist", "hand_l"}, {"left_hip", "thigh_l"}, {"left_knee", "calf_l"}, {"left_ankle", "foot_l"},
                {"left_foot", "ball_l"}, {"right_foot", "ball_r"}, {"left_index1", "index_01_l"}, {"right_thumb2", "thumb_02_r"}},
               "Unreal on Rigify");

  const Skeleton mixamo = reference_humanoid(ReferenceNames::mixamo, 45);
  const std::map<std::string, std::string> to_unreal = {
      {"Hips", "pelvis"}, {"Spine", "spine_01"}, {"Spine1", "spine_02"}, {"Spine2", "spine_03"}, {"Neck", "neck_01"},
      {"Head", "head"}, {"LeftShoulder", "clavicle_l"}, {"LeftArm", "upperarm_l"}, {"LeftForeArm", "lowerarm_l"},
      {"LeftHand", "hand_l"}, {"LeftUpLeg", "thigh_l"}, {"LeftLeg", "calf_l"}, {"LeftFoot", "foot_l"}, {"LeftToeBase", "ball_l"},
      {"RightShoulder", "clavicle_r"}, {"RightArm", "upperarm_r"}, {"RightForeArm", "lowerarm_r"}, {"RightHand", "hand_r"},
      {"RightUpLeg", "thigh_r"}, {"RightLeg", "calf_r"}, {"RightFoot", "foot_r"}, {"RightToeBase", "ball_r"}};
  const Skeleton renamed_mixamo = renamed(mixamo, [&](const std::string& name) {
    const std::string plain = name.substr(name.find(':') + 1);
    const auto it = to_unreal.find(plain);
    return it != to_unreal.end() ? it->second : "extra_" + plain;
  });
  std::map<std::string, std::string> roles;
  for (const auto& [canonical, joint] : named(mixamo, bone_map_from_names(mixamo))) {
    const auto it = to_unreal.find(joint.substr(joint.find(':') + 1));
    if (it != to_unreal.end()) roles[canonical] = it->second;
  }
  EXPECT_EQ(roles.size(), to_unreal.size());
  expect_roles(renamed_mixamo, humanoid_bone_map(renamed_mixamo, "unreal mixamo"), roles, "Unreal on Mixamo");
}

// VRM: the humanoid list the file declares decides, whatever the node names (all renamed n<i>).
TEST(BoneMapTest, VrmDeclaredHumanoidDecides) {
  const fs::path dir = odyssey::test_support::scratch_root() / "bone_map";
  const auto node_name = [](const std::string& source, const std::string& original) {
    std::ifstream in(source, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (source.ends_with(".glb")) {
      std::uint32_t length;
      std::memcpy(&length, bytes.data() + 12, 4);
      bytes = bytes.substr(20, length);
    }
    return "n" + std::to_string(test_support::node_indices(nlohmann::json::parse(bytes)).at(original));
  };
  const std::string kaykit_source = test_support::kSharedCharacters + "kaykit_mannequin/manny_med_mod.gltf";
  const Character vrm0 = io::load_character(test_support::vrm0_character(dir));
  EXPECT_EQ(vrm0.declared_humanoid_convention, "VRM 0.x");
  EXPECT_EQ(vrm0.declared_humanoid.size(), test_support::kaykit_vrm_bones().size());
  const BoneMap map0 = humanoid_bone_map(vrm0, "kaykit_vrm0.gltf");
  EXPECT_EQ(map0.origin, "VRM 0.x humanoid declared in the file");
  std::map<std::string, std::string> roles0;
  for (const auto& [canonical, original] : std::map<std::string, std::string>{
           {"pelvis", "hips"}, {"spine1", "spine"}, {"spine3", "chest"}, {"head", "head"}, {"left_shoulder", "upperarm.l"},
           {"left_wrist", "wrist.l"}, {"right_knee", "lowerleg.r"}, {"left_ankle", "foot.l"}, {"left_foot", "toes.l"}}) {
    roles0[canonical] = node_name(kaykit_source, original);
  }
  expect_roles(vrm0.skeleton, map0, roles0, "VRM 0.x");
  EXPECT_FALSE(map0.mapped(canonical::spine2));  // no upperChest: chest is the top of the spine
  // Names alone find nothing in n0, n1, ...
  EXPECT_FALSE(humanoid_problems(vrm0.skeleton, detect_bone_map(vrm0.skeleton)).empty());

  const std::string male_source = test_support::kSharedCharacters + "male_base_mesh.glb";
  const Character vrm1 = io::load_character(test_support::vrm1_character(dir));
  EXPECT_EQ(vrm1.declared_humanoid_convention, "VRM 1.0");
  const BoneMap map1 = humanoid_bone_map(vrm1, "male_vrm1.glb");
  EXPECT_EQ(map1.origin, "VRM 1.0 humanoid declared in the file");
  std::map<std::string, std::string> roles1;
  for (const auto& [canonical, original] : std::map<std::string, std::string>{
           {"pelvis", "spine"}, {"spine1", "spine.001"}, {"spine2", "spine.002"}, {"spine3", "spine.003"}, {"neck", "spine.004"},
           {"head", "spine.005"}, {"left_collar", "shoulder.L"}, {"right_elbow", "forearm.R"}, {"left_foot", "toe.L"},
           {"left_thumb1", "thumb.01.L"}, {"left_thumb2", "thumb.02.L"}, {"left_index1", "f_index.01.L"}}) {
    roles1[canonical] = node_name(male_source, original);
  }
  expect_roles(vrm1.skeleton, map1, roles1, "VRM 1.0");
}

TEST(BoneMapTest, BadVrmListsNameTheirJsonPath) {
  const fs::path dir = odyssey::test_support::scratch_root() / "bone_map";
  const fs::path out = dir / "bad_vrm.glb";
  test_support::write_derived_gltf(test_support::kSharedCharacters + "male_base_mesh.glb", out, [](nlohmann::json& g) {
    g["extensions"]["VRMC_vrm"] = {{"humanoid", {{"humanBones", {{"hips", {{"node", 100000}}}}}}}};
  });
  const std::string message = test_support::message_of<io::InputError>([&] { io::load_character(out.string()); });
  EXPECT_NE(message.find("extensions.VRMC_vrm.humanoid.humanBones.hips refers to node 100000"), std::string::npos) << message;
  test_support::write_derived_gltf(test_support::kSharedCharacters + "male_base_mesh.glb", out, [](nlohmann::json& g) {
    g["extensions"]["VRM"] = {{"humanoid", {{"humanBones", {{{"bone", "hips"}}}}}}};
  });
  const std::string missing = test_support::message_of<io::InputError>([&] { io::load_character(out.string()); });
  EXPECT_NE(missing.find("extensions.VRM.humanoid.humanBones[bone 'hips'] has no 'node'"), std::string::npos) << missing;
}

// MakeHuman's BVH skeleton as a source: its legs hang from Hips and its spine from Root, and
// every limb has a helper __X above X.
TEST(BoneMapTest, MakeHumanBvhGetsItsRoles) {
  const Clip walk = io::load_bvh_inferring_frame(kAssets + "/mocap/makehuman_walk1.bvh").clip;
  ASSERT_EQ(walk.joint_count(), 75);
  expect_roles(walk.skeleton, humanoid_bone_map(walk.skeleton, "makehuman_walk1.bvh"),
               {{"pelvis", "Root"}, {"spine1", "Spine1"}, {"spine2", "Spine2"}, {"spine3", "Spine3"}, {"neck", "Neck"},
                {"head", "Head"}, {"left_collar", "Clavicle_L"}, {"left_shoulder", "UpArm_L"}, {"left_elbow", "LoArm_L"},
                {"left_wrist", "Hand_L"}, {"left_hip", "UpLeg_L"}, {"right_hip", "UpLeg_R"}, {"left_knee", "LoLeg_L"},
                {"left_ankle", "Foot_L"}, {"left_foot", "Toe_L"}, {"left_index1", "Index1_L"}, {"jaw", "Jaw"},
                {"left_eye_smplhf", "Eye_L"}},
               "MakeHuman");
}

// The same rig turned about the vertical by any angle (an armature turned at its root) keeps its
// map and passes the side check; with its sides' names swapped it fails, naming the cues tried.
TEST(BoneMapTest, SidesHoldWhicheverWayTheRigFaces) {
  const Character kaykit = character("kaykit_mannequin/manny_med_mod.gltf");
  const Skeleton& rig = kaykit.skeleton;
  const auto expected = named(rig, bone_map_from_names(rig));
  const auto turned = [&](const Eigen::Quaterniond& turn, const Skeleton& from) {
    std::vector<Eigen::Vector3d> offsets = from.rest_offsets();
    std::vector<Eigen::Quaterniond> rotations = from.rest_rotations();
    for (int j = 0; j < from.joint_count(); ++j) {
      if (from.parent(j) >= 0) continue;
      offsets[j] = turn * offsets[j] + Eigen::Vector3d(3, -2, 0);
      rotations[j] = turn * rotations[j];
    }
    return Skeleton(from.names(), from.parents(), offsets, rotations);
  };
  const Skeleton swapped = renamed(rig, [](std::string name) {
    if (name.ends_with(".l")) name.back() = 'r';
    else if (name.ends_with(".r")) name.back() = 'l';
    return name;
  });
  for (const double degrees : {0.0, 90.0, 180.0, 270.0, 33.0}) {
    const Eigen::Quaterniond turn(Eigen::AngleAxisd(degrees * M_PI / 180, Eigen::Vector3d::UnitZ()));
    const Skeleton rig_turned = turned(turn, rig);
    const BoneMap map = bone_map_from_names(rig_turned);
    EXPECT_EQ(named(rig_turned, map), expected) << degrees;
    EXPECT_TRUE(humanoid_problems(rig_turned, map).empty()) << degrees;
    const Skeleton swapped_turned = turned(turn, swapped);
    const std::vector<std::string> problems = humanoid_problems(swapped_turned, bone_map_from_names(swapped_turned));
    ASSERT_EQ(problems.size(), 1u) << degrees;
    EXPECT_NE(problems[0].find("left and right are swapped: the joints mapped to left_* (upperleg.l, upperarm.l) are on the "
                               "rig's right, judged by where the feet (ankle to ball of the foot) point"),
              std::string::npos)
        << problems[0];
  }
  // Lying down (a Y-up rig read as Z-up): the message says where the body points.
  const Skeleton lying = turned(Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX())), rig);
  const std::vector<std::string> problems = humanoid_problems(lying, bone_map_from_names(lying));
  ASSERT_FALSE(problems.empty());
  EXPECT_NE(problems[0].find("(ankles to head points along -y in the Z-up world: is the rig turned at its root?)"),
            std::string::npos)
      << problems[0];
}

}  // namespace
}  // namespace odyssey::retarget
