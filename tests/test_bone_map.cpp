// Bone maps: presets on every shared character and the CMU BVH, detection from names in several
// naming conventions (it must agree with the presets), user maps over detection, the joints left
// unmapped, the humanoid check (the Fox is not one), and bone map files that are not right.
#include <gtest/gtest.h>

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
  EXPECT_EQ(presets, (std::vector<std::string>{"cesium_man", "cmu_bvh", "mixamo", "rigged_figure", "robot_expressive", "smplx"}));
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

}  // namespace
}  // namespace odyssey::retarget
