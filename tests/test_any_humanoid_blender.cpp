// The rest pose of characters whose nodes hold another pose than their bind pose
// (tests/posed_characters.h) against Blender's: Debian's blender imports the posed file with its
// own glTF importer at its defaults, which guess the original bind pose from the inverse bind
// matrices (tests/blender/rest_pose.py), and reports where each bone's head rests and the bounds
// of the meshes with the armatures at rest; odyssey's rest joints and rest bounds must agree within
// 1e-4 of the character's height. Skipped only when blender is not installed.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>

#include "mocap_io/gltf_character.h"
#include "posed_characters.h"
#include "test_support.h"

namespace odyssey {
namespace {

namespace fs = std::filesystem;

bool blender_missing() { return std::system("blender --version > /dev/null 2>&1") != 0; }

class PosedCharacterBlenderTest : public testing::TestWithParam<std::string> {};

// RobotExpressive ships with its nodes in another pose than its bind pose; the others are posed
// by posed_copy().
TEST_P(PosedCharacterBlenderTest, RestPoseIsBlenders) {
  if (blender_missing()) GTEST_SKIP() << "blender is not installed (scripts/install-deps.sh installs Debian's blender)";
  const fs::path posed = GetParam() == "RobotExpressive.glb" ? fs::path(test_support::kSharedCharacters + GetParam())
                                                             : test_support::posed_copy(GetParam());
  const fs::path dir = test_support::scratch_dir("any_humanoid_blender");
  const fs::path out = dir / (posed.stem().string() + ".json"), log = dir / (posed.stem().string() + ".log");
  const fs::path script = fs::path(__FILE__).parent_path() / "blender" / "rest_pose.py";
  const int status = std::system(("blender -b --factory-startup --python '" + script.string() + "' -- --file '" +
                                  posed.string() + "' --out '" + out.string() + "' > '" + log.string() + "' 2>&1")
                                     .c_str());
  std::ifstream log_in(log);
  const std::string log_text((std::istreambuf_iterator<char>(log_in)), std::istreambuf_iterator<char>());
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << log_text;
  const nlohmann::json blender = nlohmann::json::parse(std::ifstream(out));

  const Character character = io::load_character(posed.string());
  EXPECT_TRUE(character.rest_pose_origin.starts_with("inverse bind matrices")) << character.rest_pose_origin;
  const Eigen::AlignedBox3d bounds = character.rest_bounds();
  const double height = bounds.sizes().z();
  const auto rest = character.skeleton.rest_world();
  int compared = 0;
  double worst = 0;
  for (const auto& [name, head] : blender["bones"].items()) {
    const int joint = character.skeleton.find(name);
    if (joint < 0) continue;
    const Eigen::Vector3d theirs(head[0].get<double>(), head[1].get<double>(), head[2].get<double>());
    worst = std::max(worst, (theirs - rest[joint].translation).norm());
    ++compared;
  }
  const std::vector<double> b = blender["bounds"];
  const double bounds_error = std::max((Eigen::Vector3d(b[0], b[1], b[2]) - bounds.min()).norm(),
                                       (Eigen::Vector3d(b[3], b[4], b[5]) - bounds.max()).norm());
  std::printf("%s posed: %d bones, worst rest head %.3g m off Blender's; mesh bounds %.3g m off; %.4f m tall (Blender %.4f)\n",
              GetParam().c_str(), compared, worst, bounds_error, height, b[5] - b[2]);
  EXPECT_GE(compared, character.skeleton.joint_count() / 2);
  EXPECT_LT(worst, 1e-4 * height);
  EXPECT_LT(bounds_error, 1e-4 * height);
}

INSTANTIATE_TEST_SUITE_P(SharedCharacters, PosedCharacterBlenderTest,
                         testing::Values("RiggedFigure.glb", "male_base_mesh.glb", "kaykit_mannequin/manny_med_mod.gltf",
                                         "RobotExpressive.glb"),
                         [](const auto& info) {
                           std::string name = fs::path(info.param).stem().string();
                           for (char& c : name) {
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           }
                           return name;
                         });

}  // namespace
}  // namespace odyssey
