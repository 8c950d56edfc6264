// End to end: `odyssey inspect` on the shared characters. Every figure asserted here was read
// independently from the files' glTF JSON with python's json module: skin joint lists, the
// POSITION and index accessor counts of the mesh nodes' primitives, node parents, animation
// names, channel counts and the max of their sampler inputs.
#include <gtest/gtest.h>

#include <sstream>
#include <string>
#include <vector>

#include "cli_runner.h"
#include "test_support.h"

namespace odyssey {
namespace {

using test_support::contains;
using test_support::run_cli;

std::string character(const std::string& file) {
  return std::string(ODYSSEY_SHARED_DIR) + "/assets/characters/" + file;
}

// The first output line that holds `part`, or empty.
std::string line_with(const std::string& output, const std::string& part) {
  std::istringstream in(output);
  for (std::string line; std::getline(in, line);) {
    if (contains(line, part)) return line;
  }
  return {};
}

// The joint table row of `joint` names `parent` as its parent.
void expect_parent(const std::string& output, const std::string& joint, const std::string& parent) {
  const std::string row = line_with(output, "  " + joint + " ");
  EXPECT_TRUE(contains(row, "parent " + parent + " ")) << "row of " << joint << ": " << row;
}

test_support::CliResult inspect(const std::string& file) {
  const test_support::CliResult result = run_cli("inspect '" + character(file) + "'");
  EXPECT_EQ(result.exit_code, 0) << result.output;
  EXPECT_TRUE(contains(result.output, "kind: glTF character")) << result.output;
  return result;
}

TEST(InspectCliTest, RiggedFigure) {
  const std::string out = inspect("RiggedFigure.glb").output;
  EXPECT_TRUE(contains(out, "skins: 1\n")) << out;
  EXPECT_TRUE(contains(line_with(out, "Armature "), "19 joints")) << out;
  EXPECT_TRUE(contains(out, "meshes: 1 (370 vertices, 256 triangles in all)")) << out;
  EXPECT_TRUE(contains(line_with(out, "  Proxy "), "370 vertices")) << out;
  EXPECT_TRUE(contains(out, "joints: 19\n")) << out;
  expect_parent(out, "torso_joint_2", "torso_joint_1");
  expect_parent(out, "neck_joint_1", "torso_joint_3");
  EXPECT_TRUE(contains(out, "animations: 1\n")) << out;
  EXPECT_TRUE(contains(line_with(out, "animation_0"), "1.2500 s (0.0000 to 1.2500 s), 57 channels")) << out;
  EXPECT_TRUE(contains(out, "rest height: ")) << out;
  EXPECT_TRUE(contains(out, "rest pose: ")) << out;
  EXPECT_TRUE(contains(out, "bone map: preset rigged_figure, ")) << out;
  EXPECT_TRUE(contains(out, "unmapped joints: 0\n")) << out;
}

TEST(InspectCliTest, CesiumMan) {
  const std::string out = inspect("CesiumMan.glb").output;
  EXPECT_TRUE(contains(line_with(out, "Armature "), "19 joints")) << out;
  EXPECT_TRUE(contains(out, "meshes: 1 (3273 vertices, 4672 triangles in all)")) << out;
  EXPECT_TRUE(contains(line_with(out, "Cesium_Man"), "4672 triangles")) << out;
  EXPECT_TRUE(contains(line_with(out, "animation_0"), "2.0000 s (0.0000 to 2.0000 s), 57 channels")) << out;
  EXPECT_TRUE(contains(out, "bone map: preset cesium_man, ")) << out;
}

TEST(InspectCliTest, RobotExpressiveTwoSkinsRigidMeshesFourteenAnimations) {
  const std::string out = inspect("RobotExpressive.glb").output;
  EXPECT_TRUE(contains(out, "skins: 2\n")) << out;
  EXPECT_TRUE(contains(line_with(out, "skin_0"), "43 joints")) << out;
  EXPECT_TRUE(contains(line_with(out, "skin_1"), "43 joints")) << out;
  // 19 triangle primitives on 14 mesh nodes (Torso 2, Head 3, each hand 2).
  EXPECT_TRUE(contains(out, "meshes: 19 (7214 vertices, 3237 triangles in all)")) << out;
  EXPECT_TRUE(contains(line_with(out, "  Head#1 "), "876 vertices    460 triangles")) << out;
  expect_parent(out, "Hips", "Body");
  EXPECT_TRUE(contains(out, "animations: 14\n")) << out;
  const std::vector<std::pair<std::string, std::string>> animations = {
      {"Dance", "3.3333 s (0.0000 to 3.3333 s), 12 channels"}, {"Death", "0.9583 s (0.0000 to 0.9583 s), 18 channels"},
      {"Idle", "3.3333 s (0.0000 to 3.3333 s), 7 channels"},   {"Sitting", "0.4167 s (0.0000 to 0.4167 s), 10 channels"},
      {"Walking", "0.9583 s (0.0000 to 0.9583 s), 20 channels"}, {"Yes", "1.6667 s (0.0000 to 1.6667 s), 7 channels"}};
  for (const auto& [name, text] : animations) {
    EXPECT_TRUE(contains(line_with(out, "  " + name + " "), text)) << name << "\n" << out;
  }
  EXPECT_TRUE(contains(out, "bone map: preset robot_expressive, ")) << out;
}

// Rigify metarig in A-pose: whether or not a humanoid map is detected, everything else prints.
TEST(InspectCliTest, MaleBaseMeshPrintsEverythingEvenWithoutAMap) {
  const std::string out = inspect("male_base_mesh.glb").output;
  EXPECT_TRUE(contains(line_with(out, "metarig "), "56 joints")) << out;
  EXPECT_TRUE(contains(out, "meshes: 1 (1226 vertices, 1804 triangles in all)")) << out;
  expect_parent(out, "spine.001", "spine");
  expect_parent(out, "spine.003", "spine.002");
  EXPECT_TRUE(contains(out, "animations: 0\n")) << out;
  EXPECT_TRUE(contains(out, "rest pose: A-pose")) << out;
  if (contains(out, "bone map: none")) {
    EXPECT_TRUE(contains(out, "not a humanoid rig")) << out;
  } else {
    EXPECT_TRUE(contains(out, "canonical joints mapped")) << out;
  }
  EXPECT_TRUE(contains(out, "unmapped joints: ")) << out;
}

TEST(InspectCliTest, FoxIsNoHumanoidButListsJointsAndAnimations) {
  const std::string out = inspect("Fox.glb").output;
  EXPECT_TRUE(contains(line_with(out, "skin_0"), "24 joints")) << out;
  EXPECT_TRUE(contains(out, "meshes: 1 (1728 vertices, 576 triangles in all)")) << out;  // not indexed
  expect_parent(out, "b_Spine01_02", "b_Hip_01");
  EXPECT_TRUE(contains(out, "animations: 3\n")) << out;
  EXPECT_TRUE(contains(line_with(out, "  Survey "), "3.4167 s (0.0000 to 3.4167 s), 21 channels")) << out;
  EXPECT_TRUE(contains(line_with(out, "  Walk "), "0.7083 s (0.0000 to 0.7083 s), 21 channels")) << out;
  EXPECT_TRUE(contains(line_with(out, "  Run "), "1.1583 s (0.0000 to 1.1583 s), 21 channels")) << out;
  EXPECT_TRUE(contains(out, "bone map: none, no humanoid map detected: ")) << out;
  EXPECT_TRUE(contains(out, "not a humanoid rig")) << out;
  EXPECT_TRUE(contains(out, "rest pose: unknown")) << out;
}

TEST(InspectCliTest, MissingCharacterFailsNamingIt) {
  const test_support::CliResult result = run_cli("inspect '" + character("NoSuchFigure.glb") + "'");
  EXPECT_NE(result.exit_code, 0);
  EXPECT_TRUE(contains(result.output, "NoSuchFigure.glb")) << result.output;
}

}  // namespace
}  // namespace odyssey
