// What `odyssey inspect` computes about a character, as library functions: the skins and
// animations of a glTF file (summarize_gltf_file), with figures read independently from the
// files' JSON (python's json module: skin joint lists, animation channels and the min/max of the
// sampler inputs), and the rest pose kind from the angle of the upper arms (classify_rest_pose)
// on rigs built with a known arm angle.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "mocap_io/gltf_character.h"
#include "mocap_io/input_error.h"
#include "retarget/bone_map.h"
#include "retarget/canonical.h"
#include "retarget/reference_rig.h"
#include "retarget/rest_pose.h"
#include "test_support.h"

namespace odyssey {
namespace {

std::string character_path(const std::string& file) {
  return std::string(ODYSSEY_SHARED_DIR) + "/assets/characters/" + file;
}

TEST(GltfSummaryTest, FoxSkinAndAnimations) {
  const io::GltfFileSummary summary = io::summarize_gltf_file(character_path("Fox.glb"));
  ASSERT_EQ(summary.skins.size(), 1u);
  EXPECT_EQ(summary.skins[0].name, "skin_0");  // the skin has no name in the file
  EXPECT_EQ(summary.skins[0].joint_count, 24);
  ASSERT_EQ(summary.animations.size(), 3u);
  const std::vector<std::string> names = {"Survey", "Walk", "Run"};
  const std::vector<double> ends = {3.4166667461395264, 0.7083333134651184, 1.1583333015441895};
  for (std::size_t a = 0; a < 3; ++a) {
    EXPECT_EQ(summary.animations[a].name, names[a]);
    EXPECT_EQ(summary.animations[a].channels, 21);
    EXPECT_EQ(summary.animations[a].samplers, 21);
    EXPECT_EQ(summary.animations[a].start, 0.0);
    EXPECT_NEAR(summary.animations[a].end, ends[a], 1e-7);
    EXPECT_NEAR(summary.animations[a].duration(), ends[a], 1e-7);
  }
}

TEST(GltfSummaryTest, RobotExpressiveTwoSkinsFourteenAnimations) {
  const io::GltfFileSummary summary = io::summarize_gltf_file(character_path("RobotExpressive.glb"));
  ASSERT_EQ(summary.skins.size(), 2u);
  for (const io::GltfSkinSummary& skin : summary.skins) EXPECT_EQ(skin.joint_count, 43);
  ASSERT_EQ(summary.animations.size(), 14u);
  EXPECT_EQ(summary.animations[0].name, "Dance");
  EXPECT_EQ(summary.animations[0].channels, 12);
  EXPECT_NEAR(summary.animations[0].end, 3.33333325386047, 1e-7);
  EXPECT_EQ(summary.animations[13].name, "Yes");
  EXPECT_EQ(summary.animations[13].channels, 7);
  EXPECT_NEAR(summary.animations[13].end, 1.66666662693024, 1e-7);
}

TEST(GltfSummaryTest, UnnamedAnimationAndNamedSkin) {
  const io::GltfFileSummary summary = io::summarize_gltf_file(character_path("CesiumMan.glb"));
  ASSERT_EQ(summary.skins.size(), 1u);
  EXPECT_EQ(summary.skins[0].name, "Armature");
  EXPECT_EQ(summary.skins[0].joint_count, 19);
  ASSERT_EQ(summary.animations.size(), 1u);
  EXPECT_EQ(summary.animations[0].name, "animation_0");
  EXPECT_EQ(summary.animations[0].channels, 57);
  EXPECT_NEAR(summary.animations[0].end, 2.0, 1e-7);
}

TEST(GltfSummaryTest, NoAnimationsNoProblem) {
  const io::GltfFileSummary summary = io::summarize_gltf_file(character_path("male_base_mesh.glb"));
  ASSERT_EQ(summary.skins.size(), 1u);
  EXPECT_EQ(summary.skins[0].name, "metarig");
  EXPECT_EQ(summary.skins[0].joint_count, 56);
  EXPECT_TRUE(summary.animations.empty());
}

// Two float times, 0 and a NaN, in a data URI buffer.
std::string gltf_with_times(const std::string& times_base64, int sampler_of_channel, int input_accessor) {
  return R"({"asset":{"version":"2.0"},"nodes":[{"name":"a"}],"scenes":[{"nodes":[0]}],"scene":0,
  "buffers":[{"byteLength":8,"uri":"data:application/octet-stream;base64,)" + times_base64 + R"("}],
  "bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":8}],
  "accessors":[{"bufferView":0,"componentType":5126,"count":2,"type":"SCALAR"},
               {"bufferView":0,"componentType":5126,"count":2,"type":"SCALAR"}],
  "animations":[{"name":"bad","channels":[{"sampler":)" + std::to_string(sampler_of_channel) +
         R"(,"target":{"node":0,"path":"translation"}}],
   "samplers":[{"input":)" + std::to_string(input_accessor) + R"(,"output":1,"interpolation":"LINEAR"}]}]})";
}

TEST(GltfSummaryTest, BadAnimationsAreRefusedNamingTheFile) {
  const std::filesystem::path dir = test_support::scratch_dir("character_summary");
  const auto write = [&](const std::string& name, const std::string& text) {
    const std::string path = (dir / name).string();
    std::ofstream(path, std::ios::binary) << text;
    return path;
  };
  // 0.0f and 1.5f, then 0.0f and a quiet NaN (0x7fc00000).
  const std::string good = write("good.gltf", gltf_with_times("AAAAAAAAwD8=", 0, 0));
  const io::GltfFileSummary summary = io::summarize_gltf_file(good);
  ASSERT_EQ(summary.animations.size(), 1u);
  EXPECT_EQ(summary.animations[0].keyframes, 2u);
  EXPECT_EQ(summary.animations[0].end, 1.5);

  const std::string nan = write("nan.gltf", gltf_with_times("AAAAAAAAwH8=", 0, 0));
  std::string message = test_support::message_of<io::InputError>([&] { io::summarize_gltf_file(nan); });
  EXPECT_TRUE(test_support::contains(message, "nan.gltf")) << message;
  EXPECT_TRUE(test_support::contains(message, "non-finite time")) << message;

  const std::string sampler = write("sampler.gltf", gltf_with_times("AAAAAAAAwD8=", 3, 0));
  message = test_support::message_of<io::InputError>([&] { io::summarize_gltf_file(sampler); });
  EXPECT_TRUE(test_support::contains(message, "refers to sampler 3")) << message;

  const std::string accessor = write("accessor.gltf", gltf_with_times("AAAAAAAAwD8=", 0, 7));
  message = test_support::message_of<io::InputError>([&] { io::summarize_gltf_file(accessor); });
  EXPECT_TRUE(test_support::contains(message, "accessor 7")) << message;
}

TEST(RestPoseTest, ArmAngleTellsTFromA) {
  for (const double drop : {0.0, 5.0, 19.0, 21.0, 30.0, 45.0, 60.0, 80.0}) {
    const Skeleton rig = retarget::reference_humanoid(retarget::ReferenceNames::mixamo, drop);
    const retarget::RestPoseInfo info = retarget::classify_rest_pose(rig, retarget::detect_bone_map(rig));
    ASSERT_TRUE(info.left_drop_deg && info.right_drop_deg);
    EXPECT_NEAR(*info.left_drop_deg, drop, 1e-9);
    EXPECT_NEAR(*info.right_drop_deg, drop, 1e-9);
    EXPECT_NEAR(info.drop_deg, drop, 1e-9);
    EXPECT_EQ(info.kind, drop < retarget::kTPoseMaxDropDeg   ? retarget::RestPoseKind::t_pose
                         : drop <= retarget::kAPoseMaxDropDeg ? retarget::RestPoseKind::a_pose
                                                              : retarget::RestPoseKind::unknown)
        << drop;
  }
  EXPECT_STREQ(retarget::rest_pose_kind_name(retarget::RestPoseKind::t_pose), "T");
  EXPECT_STREQ(retarget::rest_pose_kind_name(retarget::RestPoseKind::a_pose), "A");
}

TEST(RestPoseTest, OneArmOrElbowlessArmStillMeasured) {
  const Skeleton rig = retarget::reference_humanoid(retarget::ReferenceNames::smplx, 40);
  retarget::BoneMap map = retarget::detect_bone_map(rig);
  map.joints[retarget::canonical::right_shoulder] = -1;  // right arm not measured
  map.joints[retarget::canonical::left_elbow] = -1;      // left arm measured to the wrist
  const retarget::RestPoseInfo info = retarget::classify_rest_pose(rig, map);
  EXPECT_FALSE(info.right_drop_deg.has_value());
  ASSERT_TRUE(info.left_drop_deg.has_value());
  EXPECT_NEAR(*info.left_drop_deg, 40.0, 1e-9);  // shoulder, elbow and wrist are collinear
  EXPECT_EQ(info.kind, retarget::RestPoseKind::a_pose);
}

TEST(RestPoseTest, NoArmsIsUnknown) {
  const Skeleton rig = retarget::reference_humanoid(retarget::ReferenceNames::smplx, 0);
  retarget::BoneMap map;  // nothing mapped
  const retarget::RestPoseInfo info = retarget::classify_rest_pose(rig, map);
  EXPECT_EQ(info.kind, retarget::RestPoseKind::unknown);
  EXPECT_FALSE(info.reason.empty());
  EXPECT_STREQ(retarget::rest_pose_kind_name(info.kind), "unknown");
}

}  // namespace
}  // namespace odyssey
