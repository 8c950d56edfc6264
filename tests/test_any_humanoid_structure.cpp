// Bone maps from a skeleton's structure (retarget/bone_map_structure.h): on every shared humanoid,
// character or motion, with its names replaced by numbers, the structure's map against the map
// the names give, joint by joint; retargeting through it; and skeletons that are no humanoid
// refused with what was found.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "derived_characters.h"
#include "mocap_io/bvh.h"
#include "mocap_io/gltf_character.h"
#include "mocap_io/input_error.h"
#include "retarget/bone_map.h"
#include "retarget/bone_map_structure.h"
#include "retarget/canonical.h"
#include "retarget/retarget.h"
#include "test_support.h"

namespace odyssey {
namespace {

using retarget::BoneMap;
using test_support::contains;
using test_support::kSharedCharacters;

const std::string kMocap = std::string(ODYSSEY_SHARED_DIR) + "/assets/mocap/";

// The skeleton with every joint renamed "<index>": nothing left for names to read.
Skeleton numbered(const Skeleton& rig) {
  std::vector<std::string> names;
  for (int j = 0; j < rig.joint_count(); ++j) names.push_back(std::to_string(j));
  return Skeleton(names, rig.parents(), rig.rest_offsets(), rig.rest_rotations());
}

Character numbered(Character character) {
  character.skeleton = numbered(character.skeleton);
  return character;
}

struct Agreement {
  int both = 0, equal = 0;
  std::vector<std::string> differing;  // "canonical: names X, structure Y"
  std::vector<std::string> names_only, structure_only;
};

// Body joints (pelvis to wrists) both maps give, and whether they agree.
Agreement compare(const Skeleton& rig, const BoneMap& by_names, const BoneMap& by_structure) {
  Agreement a;
  for (int c = 0; c <= retarget::canonical::right_wrist; ++c) {
    const std::string name(retarget::canonical_name(c));
    if (by_names.mapped(c) && by_structure.mapped(c)) {
      ++a.both;
      if (by_names.joints[c] == by_structure.joints[c]) {
        ++a.equal;
      } else {
        a.differing.push_back(name + ": names " + rig.name(by_names.joints[c]) + ", structure " +
                              rig.name(by_structure.joints[c]));
      }
    } else if (by_names.mapped(c)) {
      a.names_only.push_back(name);
    } else if (by_structure.mapped(c)) {
      a.structure_only.push_back(name);
    }
  }
  return a;
}

std::string listed(const std::vector<std::string>& items) {
  std::string text;
  for (const std::string& item : items) text += (text.empty() ? "" : "; ") + item;
  return text.empty() ? "none" : text;
}

void print(const std::string& what, const BoneMap& by_names, const Agreement& a) {
  std::printf("%s (names: %s): %d of %d body joints both give agree; names only: %s; structure only: %s; differing: %s\n",
              what.c_str(), by_names.origin.c_str(), a.equal, a.both, listed(a.names_only).c_str(),
              listed(a.structure_only).c_str(), listed(a.differing).c_str());
}

struct CharacterCase {
  std::string file;
  int min_agreeing;  // body joints both give, all equal
};

class StructureCharacterTest : public testing::TestWithParam<CharacterCase> {};

TEST_P(StructureCharacterTest, StructureMapEqualsTheNameMap) {
  const Character character = io::load_character(kSharedCharacters + GetParam().file);
  const BoneMap by_names = retarget::humanoid_bone_map(character, GetParam().file);
  const Character anonymous = numbered(character);
  const retarget::StructureMap structure = retarget::bone_map_from_structure(anonymous);
  ASSERT_TRUE(structure.problem.empty()) << structure.problem;
  EXPECT_TRUE(retarget::humanoid_problems(anonymous.skeleton, structure.map).empty());
  const Agreement a = compare(character.skeleton, by_names, structure.map);
  print(GetParam().file, by_names, a);
  EXPECT_EQ(a.equal, a.both) << listed(a.differing);
  EXPECT_GE(a.both, GetParam().min_agreeing);
  // With no names to read, humanoid_bone_map falls back to the structure.
  const BoneMap fallback = retarget::humanoid_bone_map(anonymous, "numbered " + GetParam().file);
  EXPECT_TRUE(fallback.origin.starts_with("skeleton structure")) << fallback.origin;
  EXPECT_EQ(fallback.joints, structure.map.joints);
  const BoneMap asked = retarget::humanoid_bone_map(character, GetParam().file, retarget::kAutoStructureMap);
  EXPECT_EQ(asked.joints, structure.map.joints);
}

INSTANTIATE_TEST_SUITE_P(SharedCharacters, StructureCharacterTest,
                         testing::Values(CharacterCase{"CesiumMan.glb", 17}, CharacterCase{"RiggedFigure.glb", 17},
                                         CharacterCase{"male_base_mesh.glb", 21},
                                         CharacterCase{"kaykit_mannequin/manny_med_mod.gltf", 17}),
                         [](const auto& info) {
                           std::string name = std::filesystem::path(info.param.file).stem().string();
                           for (char& c : name) {
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           }
                           return name;
                         });

TEST(StructureMotionTest, CmuClipsStructureMapEqualsTheNameMap) {
  for (const char* file : {"cmu_walk_cgspeed.bvh", "cmu_jump_cgspeed.bvh"}) {
    const io::LoadedBvh bvh = io::load_bvh_inferring_frame(kMocap + file);
    const BoneMap by_names = retarget::humanoid_bone_map(bvh.clip.skeleton, file);
    const retarget::StructureMap structure = retarget::bone_map_from_structure(numbered(bvh.clip.skeleton));
    ASSERT_TRUE(structure.problem.empty()) << file << ": " << structure.problem;
    const Agreement a = compare(bvh.clip.skeleton, by_names, structure.map);
    print(file, by_names, a);
    EXPECT_EQ(a.equal, a.both) << file << ": " << listed(a.differing);
    EXPECT_GE(a.both, 21) << file;
  }
}

// The Unreal-named derivation of the Rigify character (derived_characters.h).
TEST(StructureCharacterTest, UnrealNamedCharacter) {
  const std::filesystem::path out = test_support::scratch_dir("any_humanoid_structure") / "unreal.glb";
  test_support::write_derived_gltf(kSharedCharacters + "male_base_mesh.glb", out,
                                   [](nlohmann::json& gltf) { test_support::rename_nodes(gltf, test_support::rigify_to_unreal()); });
  const Character character = io::load_character(out.string());
  const BoneMap by_names = retarget::humanoid_bone_map(character, "unreal");
  const retarget::StructureMap structure = retarget::bone_map_from_structure(numbered(character));
  ASSERT_TRUE(structure.problem.empty()) << structure.problem;
  const Agreement a = compare(character.skeleton, by_names, structure.map);
  print("male_base_mesh.glb under Unreal names", by_names, a);
  EXPECT_EQ(a.equal, a.both) << listed(a.differing);
  EXPECT_GE(a.both, 21);
}

// RobotExpressive hangs its feet from the root, outside the leg chains (an IK-style rig): the
// structure cannot find its ankles, which is why it has a preset; the names keep winning.
TEST(StructureCharacterTest, RobotExpressiveIsLeftToItsPreset) {
  const Character robot = io::load_character(kSharedCharacters + "RobotExpressive.glb");
  EXPECT_EQ(retarget::humanoid_bone_map(robot, "robot").origin, "preset robot_expressive");
  const retarget::StructureMap structure = retarget::bone_map_from_structure(numbered(robot));
  if (structure.problem.empty()) {
    const Agreement a = compare(robot.skeleton, retarget::humanoid_bone_map(robot, "robot"), structure.map);
    print("RobotExpressive.glb", retarget::humanoid_bone_map(robot, "robot"), a);
    EXPECT_LT(a.equal, a.both) << "the structure found RobotExpressive's feet: update the header's list of misses";
  } else {
    std::printf("RobotExpressive.glb by structure: %s\n", structure.problem.c_str());
  }
}

// Retargeting through the structure's map of a numbered CesiumMan gives what the name map gives.
TEST(StructureRetargetTest, RetargetsAsThroughTheNameMap) {
  const Character character = io::load_character(kSharedCharacters + "CesiumMan.glb");
  const Character anonymous = numbered(character);
  const io::LoadedBvh walk = io::load_bvh_inferring_frame(kMocap + "cmu_walk_cgspeed.bvh");
  const Clip source = walk.clip.resampled(30);
  const BoneMap source_map = retarget::humanoid_bone_map(source.skeleton, "walk");
  const auto a = retarget::retarget_fast(source, source_map, character, retarget::humanoid_bone_map(character, "named"));
  const auto b = retarget::retarget_fast(source, source_map, anonymous, retarget::humanoid_bone_map(anonymous, "numbered"));
  EXPECT_NEAR(a.report.scale, b.report.scale, 1e-12);
  std::vector<RigidTransform<double>> wa(character.skeleton.joint_count()), wb(character.skeleton.joint_count());
  double worst = 0;
  for (int f = 0; f < a.transfer.clip.frame_count(); ++f) {
    a.transfer.clip.world_pose(f, wa);
    b.transfer.clip.world_pose(f, wb);
    for (std::size_t j = 0; j < wa.size(); ++j) worst = std::max(worst, (wa[j].translation - wb[j].translation).norm());
  }
  EXPECT_LT(worst, 1e-9) << "metres";
}

std::string refusal(const Skeleton& rig, const std::string& label) {
  return test_support::message_of<io::InputError>([&] { retarget::humanoid_bone_map(rig, label); });
}

TEST(StructureRefusalTest, NonHumanoidsAreRefusedSayingWhatWasFound) {
  // The Fox: four legs, a tail and a head, lying horizontally.
  const Character fox = numbered(io::load_character(kSharedCharacters + "Fox.glb"));
  const retarget::StructureMap fox_structure = retarget::bone_map_from_structure(fox);
  EXPECT_FALSE(fox_structure.problem.empty());
  const std::string fox_refusal = test_support::message_of<io::InputError>([&] { retarget::humanoid_bone_map(fox, "fox"); });
  std::printf("Fox: %s\n", fox_refusal.c_str());
  EXPECT_TRUE(contains(fox_refusal, "fox: not a humanoid rig (bone map from joint names): no joint plays")) << fox_refusal;
  EXPECT_TRUE(contains(fox_refusal, "from the skeleton's structure: found")) << fox_refusal;
  EXPECT_TRUE(contains(fox_refusal, "give a bone map with --map FILE")) << fox_refusal;

  // Two joints: one chain end.
  const Skeleton two({"0", "1"}, {-1, 0}, {Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(0, 0, 0.5)});
  const std::string two_refusal = refusal(two, "two");
  std::printf("two joints: %s\n", two_refusal.c_str());
  EXPECT_TRUE(contains(two_refusal, "from the skeleton's structure: found 1 chain end, no two leg chains")) << two_refusal;

  // A snake: one chain lying flat along x.
  std::vector<std::string> names;
  std::vector<int> parents;
  std::vector<Eigen::Vector3d> offsets;
  for (int j = 0; j < 12; ++j) {
    names.push_back(std::to_string(j));
    parents.push_back(j - 1);
    offsets.push_back(j == 0 ? Eigen::Vector3d(0, 0, 0.05) : Eigen::Vector3d(0.1, 0.01 * (j % 2), 0));
  }
  const std::string snake = refusal(Skeleton(names, parents, offsets), "snake");
  std::printf("snake: %s\n", snake.c_str());
  EXPECT_TRUE(contains(snake, "from the skeleton's structure: found 12 joints and no height to stand on")) << snake;

  // A DAZ-named rig missing its upper arms names the closest convention and what it lacked.
  const Skeleton daz({"hip", "abdomen", "chest", "neck", "head", "lThigh", "lShin", "lFoot", "rThigh", "rShin", "rFoot"},
                     {-1, 0, 1, 2, 3, 0, 5, 6, 0, 8, 9},
                     {Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(0, 0, 0.1), Eigen::Vector3d(0, 0, 0.2), Eigen::Vector3d(0, 0, 0.2),
                      Eigen::Vector3d(0, 0, 0.1), Eigen::Vector3d(0, 0.1, -0.05), Eigen::Vector3d(0, 0, -0.45),
                      Eigen::Vector3d(0, 0, -0.45), Eigen::Vector3d(0, -0.1, -0.05), Eigen::Vector3d(0, 0, -0.45),
                      Eigen::Vector3d(0, 0, -0.45)});
  const std::string armless = refusal(daz, "armless");
  std::printf("armless: %s\n", armless.c_str());
  EXPECT_TRUE(contains(armless, "closest convention: preset poser_bvh (11 of its 19 body joints found, lacking 'lCollar'"))
      << armless;
  EXPECT_TRUE(contains(armless, "from the skeleton's structure: found two leg chains from 'hip' and no arm chains")) << armless;
}

}  // namespace
}  // namespace odyssey
