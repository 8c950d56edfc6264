// A character's own animation played without retargeting (skeleton/node_animation.h,
// mocap_io/gltf_character.h load_gltf_animation, scene_layouts/actor_source.h): joint and mesh
// positions against transforms chained by hand from the file's numbers, the refusal of scale that
// resizes geometry, the commands and scene files that play one, and their bad input.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <numbers>

#include "animated_rig.h"
#include "cli_runner.h"
#include "gltf_validator.h"
#include "mocap_io/gltf_character.h"
#include "mocap_io/input_error.h"
#include "scene_layouts/actor_source.h"
#include "scene_layouts/scene_file.h"
#include "skeleton/node_animation.h"
#include "skeleton/rotation.h"
#include "test_support.h"

namespace odyssey {
namespace {

namespace fs = std::filesystem;
using test_support::contains;

std::string quoted(const fs::path& path) {
  std::string text = "'";
  text += path.string();
  text += "'";
  return text;
}

fs::path rig_file(const animated_rig::RigOptions& options = {}, const std::string& name = "rig.glb") {
  const fs::path path = test_support::scratch_dir("character_animation") / name;
  animated_rig::write_rig(path.string(), options);
  return path;
}

Eigen::Matrix3d about(double degrees, const Eigen::Vector3d& axis) {
  return Eigen::AngleAxisd(degrees * std::numbers::pi / 180, axis).toRotationMatrix();
}

TEST(CharacterAnimationTest, TheTestRigIsAValidGltf) {
  if (const std::string missing = test_support::validator_missing(); !missing.empty()) GTEST_SKIP() << missing;
  const fs::path rig = rig_file();
  const fs::path log = fs::path(rig).replace_extension(".validator.txt");
  const int status = std::system(("node " + quoted(test_support::validator_dir() / "validate.mjs") + " " + quoted(rig) +
                                  " > " + quoted(log) + " 2>&1").c_str());
  std::ifstream in(log);
  const std::string report((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << report;
}

// At t = 0.5 s (a key of every track): mover T (0.4, 0.1, -0.2), R 20 deg about Y, S 2; hips STEP
// 25 deg about X; arm LINEAR 16 deg about Z; hand CUBICSPLINE (0.6, 0.1, 0). Chained by hand in
// glTF's Y up, then turned to Z up by (x, y, z) -> (x, -z, y).
TEST(CharacterAnimationTest, JointsAndTheRigidMeshSitWhereTheFilesTransformsChainThem) {
  const fs::path rig = rig_file();
  const Character character = io::load_character(rig.string());
  const NodeAnimation animation = io::load_gltf_animation(rig.string(), "Wave");
  EXPECT_EQ(animation.channels.size(), 6u);
  EXPECT_DOUBLE_EQ(animation.start, 0);
  EXPECT_DOUBLE_EQ(animation.end, 1);
  const std::vector<double> times = {0.25, 0.5};
  const Clip clip = play_node_animation(character, animation, times, 30);

  const Eigen::Matrix3d mover = 2 * about(20, Eigen::Vector3d::UnitY());
  const Eigen::Vector3d mover_t(0.4, 0.1, -0.2);
  const Eigen::Matrix3d hips_r = about(25, Eigen::Vector3d::UnitX());
  const Eigen::Vector3d hips = mover_t + mover * Eigen::Vector3d(0, 0.5, 0);
  const Eigen::Vector3d arm = hips + mover * hips_r * Eigen::Vector3d(0, 0.4, 0);
  const Eigen::Matrix3d arm_r = hips_r * about(16, Eigen::Vector3d::UnitZ());
  const Eigen::Vector3d hand = arm + mover * arm_r * Eigen::Vector3d(0.6, 0.1, 0);
  const Eigen::Matrix3d c = y_up_to_z_up();

  std::vector<RigidTransform<double>> world(clip.joint_count());
  clip.world_pose(1, world);
  const Skeleton& skeleton = character.skeleton;
  EXPECT_LT((world[skeleton.find("hips")].translation - c * hips).norm(), 1e-6);
  EXPECT_LT((world[skeleton.find("arm")].translation - c * arm).norm(), 1e-6);
  EXPECT_LT((world[skeleton.find("hand")].translation - c * hand).norm(), 1e-6);
  EXPECT_LT((world[skeleton.find("arm")].rotation - c * about(20, Eigen::Vector3d::UnitY()) * arm_r).norm(), 1e-6);

  // The block (rigid on "hand"): vertex (0.2, 0, 0) of the hand's space.
  const auto block = std::find_if(character.meshes.begin(), character.meshes.end(), [](const CharacterMesh& m) { return m.name == "block"; });
  ASSERT_NE(block, character.meshes.end());
  const std::vector<Eigen::Vector3d> skinned = skin_mesh_reference(*block, world);
  const Eigen::Vector3d corner = hand + mover * arm_r * Eigen::Vector3d(0.2, 0, 0);
  EXPECT_LT((skinned[1] - c * corner).norm(), 1e-6);

  // Between keys, t = 0.25, the hand's CUBICSPLINE translation is the Hermite curve of keys 0 and 1
  // (d = 0.5, s = 0.5): 0.5 (0.5, 0, 0) + 0.0625 (0, 0.4, 0) + 0.5 (0.6, 0.1, 0) - 0.0625 (0.2, 0, 0)
  // = (0.5375, 0.075, 0); its offset from the arm in the arm's frame carries the world scale 2.
  const int hand_joint = skeleton.find("hand");
  const auto slot = std::find(clip.translated_joints.begin(), clip.translated_joints.end(), hand_joint);
  ASSERT_NE(slot, clip.translated_joints.end());
  const Eigen::Vector3d offset = clip.translations[0 * clip.translated_joints.size() + (slot - clip.translated_joints.begin())];
  EXPECT_LT((offset - 2 * Eigen::Vector3d(0.5375, 0.075, 0)).norm(), 1e-6) << offset.transpose();
  // STEP holds hips at 0 deg until 0.5 s: at 0.25 the hips are unrotated relative to the mover.
  clip.world_pose(0, world);
  const Eigen::Matrix3d hips_relative = world[skeleton.find("hips")].rotation.transpose() * world[skeleton.find("arm")].rotation;
  EXPECT_LT((hips_relative - about(13, Eigen::Vector3d::UnitZ())).norm(), 1e-6);  // arm halfway 10 -> 16 deg
}

TEST(CharacterAnimationTest, ScaleThatResizesGeometryIsRefusedNamingTheJoint) {
  animated_rig::RigOptions options;
  options.grow_arm = true;
  const fs::path rig = rig_file(options, "growing.glb");
  scene::AnimationRequest request;
  request.character_path = rig.string();
  request.animation = "Wave";
  try {
    scene::play_character_animation(request);
    FAIL() << "an arm growing by half was played";
  } catch (const io::InputError& error) {
    EXPECT_EQ(error.file(), rig.string());
    EXPECT_TRUE(contains(error.problem(), "joint 'arm'")) << error.what();
    EXPECT_TRUE(contains(error.problem(), "carries mesh vertices")) << error.what();
  }
}

TEST(CharacterAnimationTest, LoopsAndScaleGiveTheRequestedLengthAndSize) {
  const fs::path rig = rig_file();
  scene::AnimationRequest request;
  request.character_path = rig.string();
  request.animation = "Wave";
  request.fps = 10;
  request.length.loops = 3;
  request.scale = 0.5;
  const auto motion = std::make_shared<const scene::ActorMotion>(scene::play_character_animation(request));
  const scene::TimedClip played = scene::played_clip(motion, request.fps);
  EXPECT_EQ(played.frame_count(), 31);  // 3 s at 10 fps
  EXPECT_TRUE(motion->loops);
  EXPECT_EQ(motion->clip.frame_count(), 11);  // one pass of 1 s
  // The mover moves the skeleton: its first joint (hips, under the folded mover) is the root.
  EXPECT_EQ(motion->character.skeleton.name(motion->root_joint), "hips");
  // Half size: the unscaled clip's hips, halved, at each loop's same phase.
  request.scale = 1;
  const auto full_motion = std::make_shared<const scene::ActorMotion>(scene::play_character_animation(request));
  const scene::TimedClip full = scene::played_clip(full_motion, request.fps);
  std::vector<RigidTransform<double>> half_world(played.joint_count()), full_world(full.joint_count());
  for (const int f : {0, 4, 14, 24, 30}) {
    played.world_pose(f, half_world);
    full.world_pose(f, full_world);
    for (int j = 0; j < played.joint_count(); ++j) {
      EXPECT_LT((half_world[j].translation - 0.5 * full_world[j].translation).norm(), 1e-12);
    }
    // Skinned vertices too: the inverse binds were scaled with the offsets.
    const std::vector<Eigen::Vector3d> half = skin_mesh_reference(motion->character.meshes[0], half_world);
    const std::vector<Eigen::Vector3d> whole = skin_mesh_reference(full_motion->character.meshes[0], full_world);
    for (std::size_t v = 0; v < half.size(); ++v) EXPECT_LT((half[v] - 0.5 * whole[v]).norm(), 1e-12);
  }
  full.world_pose(4, full_world);
  std::vector<RigidTransform<double>> later(full.joint_count());
  full.world_pose(14, later);  // one loop on: the same pose
  EXPECT_LT((later[0].translation - full_world[0].translation).norm(), 1e-9);
}

// A looping animation keeps one pass, however long it plays, and the shot's frames show the keys'
// poses: against the file's keys evaluated at every played time (start + loop_time(k / fps)).
TEST(CharacterAnimationTest, ALoopedAnimationKeepsOnePassAndPlaysTheKeysPoses) {
  const std::string fox = std::string(ODYSSEY_DATA_DIR) + "/characters/Fox.glb";
  scene::AnimationRequest request;
  request.character_path = fox;
  request.animation = "Walk";
  request.fps = 30;
  request.length.seconds = 6;
  const auto short_play = std::make_shared<const scene::ActorMotion>(scene::play_character_animation(request));
  request.length.seconds = 600;
  const auto long_play = std::make_shared<const scene::ActorMotion>(scene::play_character_animation(request));
  EXPECT_EQ(short_play->clip.frame_count(), long_play->clip.frame_count());
  EXPECT_LE(long_play->clip.frame_count(), 23);  // 0.708 s at 30 fps, rounded up, and its last key
  EXPECT_DOUBLE_EQ(long_play->played_seconds, 600);

  const scene::TimedClip played = scene::played_clip(short_play, 30);
  ASSERT_EQ(played.frame_count(), 181);
  const Character character = io::load_character(fox);
  const NodeAnimation animation = io::load_gltf_animation(fox, "Walk");
  std::vector<double> times(181);
  for (int k = 0; k <= 180; ++k) times[k] = animation.start + loop_time(k / 30.0, animation.duration(), 30);
  const Clip reference = play_node_animation(character, animation, times, 30);
  ASSERT_EQ(reference.frame_count(), 181);
  std::vector<RigidTransform<double>> ours(played.joint_count()), theirs(reference.joint_count());
  double worst = 0;
  for (int f = 0; f < 181; ++f) {
    played.world_pose(f, ours);
    reference.world_pose(f, theirs);
    for (int j = 0; j < played.joint_count(); ++j) worst = std::max(worst, (ours[j].translation - theirs[j].translation).norm());
  }
  const double size = character.rest_bounds().sizes().maxCoeff();
  std::printf("Fox walk looped for 6 s at 30 fps: joints within %.3g of the keys' poses (%.3g of its size)\n", worst, worst / size);
  EXPECT_LT(worst, 1e-9 * size);
}

TEST(CharacterAnimationCliTest, AMissingAnimationListsTheNamesAndWritesNothing) {
  const fs::path dir = test_support::scratch_dir("character_animation_cli");
  const fs::path fox = fs::path(ODYSSEY_DATA_DIR) / "characters" / "Fox.glb";
  const test_support::CliResult run =
      test_support::run_cli("trajectories --character " + quoted(fox) + " --animation Jump --out " + quoted(dir / "out.npz"));
  EXPECT_NE(run.exit_code, 0);
  EXPECT_TRUE(contains(run.output, "has no animation 'Jump'; its animations: 'Survey', 'Walk', 'Run'")) << run.output;
  EXPECT_TRUE(test_support::files_in(dir).empty());
  const test_support::CliResult cache =
      test_support::run_cli("point-cache --character " + quoted(fox) + " --animation Jump --out " + quoted(dir / "out.pc2"));
  EXPECT_NE(cache.exit_code, 0);
  EXPECT_TRUE(contains(cache.output, "its animations: 'Survey', 'Walk', 'Run'")) << cache.output;
  EXPECT_TRUE(test_support::files_in(dir).empty());

  const test_support::CliResult list = test_support::run_cli("trajectories --character " + quoted(fox) + " --list-animations");
  EXPECT_EQ(list.exit_code, 0) << list.output;
  for (const char* name : {"Survey", "Walk", "Run"}) EXPECT_TRUE(contains(list.output, name)) << list.output;
  const test_support::CliResult both =
      test_support::run_cli("trajectories --character " + quoted(fox) + " --animation Walk --motion x.bvh --out " + quoted(dir / "o.npz"));
  EXPECT_NE(both.exit_code, 0);
  EXPECT_TRUE(contains(both.output, "give no --motion")) << both.output;
}

// The bundled Fox walks through a scene file for 3 s with its tracked points: the walk loops, the
// points move with it and the camera sees some and not others.
TEST(CharacterAnimationCliTest, TheFoxWalksInASceneWithItsTrackedPoints) {
  const fs::path dir = test_support::scratch_dir("character_animation_scene");
  std::ofstream(dir / "fox.json") << R"({
    "version": 1, "fps": 30, "seconds": 3,
    "actors": [{"name": "fox", "character": "data:characters/Fox.glb", "animation": "Walk", "seconds": 3, "scale": 0.01,
                "placement": {"x": 0, "y": 0, "yaw": 90}, "points": 600}],
    "cameras": [{"name": "side", "type": "static", "position": [2.5, 0.3, 0.5], "target": [0, 0, 0.35]}],
    "outputs": {"trajectories": true, "point_caches": true, "glb": true}
  })";
  const test_support::CliResult run = test_support::run_cli("scene " + quoted(dir / "fox.json") + " --out " + quoted(dir / "out"));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const nlohmann::json report = nlohmann::json::parse(std::ifstream(dir / "out" / "report.json"));
  EXPECT_EQ(report["frames"], 91);
  const nlohmann::json& fox = report["actors"][0];
  EXPECT_EQ(fox["source"]["source"], "animation");
  EXPECT_TRUE(contains(fox["source"]["played"].get<std::string>(), "animation 'Walk'")) << fox.dump(1);
  EXPECT_EQ(fox["source"]["root_joint"], "b_Hip_01");
  const nlohmann::json& camera = report["cameras"][0]["point_frames"];
  // Seen from its side, a fox shows roughly half its surface and hides the rest.
  EXPECT_GT(camera["visible"].get<double>(), 0.25) << camera.dump();
  EXPECT_GT(camera["occluded_by_actor"].get<double>(), 0.25) << camera.dump();
  EXPECT_TRUE(fs::exists(dir / "out" / "trajectories_side.npz"));
  EXPECT_TRUE(fs::exists(dir / "out" / "point_cache_fox.pc2"));
  EXPECT_TRUE(fs::exists(dir / "out" / "scene.glb"));

  // The point cache: a walk of 0.708 s looped over 3 s comes back to the same pose each loop,
  // about 80 cm tall after scale 0.01.
  std::ifstream pc2(dir / "out" / "point_cache_fox.pc2", std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(pc2)), std::istreambuf_iterator<char>());
  std::int32_t points = 0, frames = 0;
  std::memcpy(&points, bytes.data() + 16, 4);
  std::memcpy(&frames, bytes.data() + 28, 4);
  ASSERT_EQ(frames, 91);
  ASSERT_EQ(bytes.size(), 32 + std::size_t(points) * frames * 12);
  const auto vertex = [&](int frame, int v) {
    Eigen::Vector3f p;
    std::memcpy(p.data(), bytes.data() + 32 + (std::size_t(frame) * points + v) * 12, 12);
    return p;
  };
  float top = -INFINITY, bottom = INFINITY, moved = 0, loop_gap = 0;
  for (int v = 0; v < points; ++v) {
    top = std::max(top, vertex(0, v).z());
    bottom = std::min(bottom, vertex(0, v).z());
    moved = std::max(moved, (vertex(10, v) - vertex(0, v)).norm());
    loop_gap = std::max(loop_gap, (vertex(0, v) - vertex(85, v)).norm());  // 85 / 30 s = 4 loops of 17 / 24 s
  }
  EXPECT_NEAR(top - bottom, 0.79, 0.05);
  EXPECT_GT(moved, 0.05f);
  EXPECT_LT(loop_gap, 1e-4f);
}

}  // namespace
}  // namespace odyssey

namespace odyssey {
namespace {

std::string scene_error(const std::string& actor) {
  const std::string text = R"({"version": 1, "actors": [)" + actor + "]}";
  try {
    scene::parse_scene(text, "/scenes/s.json");
  } catch (const io::InputError& error) {
    return error.what();
  }
  return "parsed";
}

TEST(ActorSourceSceneFileTest, AnimationAndAnimeActorsReadTheirKeys) {
  const scene::SceneFile file = scene::parse_scene(R"({"version": 1, "fps": 24, "actors": [
      {"name": "fox", "character": "chars/Fox.glb", "animation": "Run", "loops": 3, "scale": 0.01},
      {"name": "bear", "anime": "/data/bear.anime", "source_fps": 25, "up": "z", "seconds": 4.5}]})",
                                                   "/scenes/s.json");
  ASSERT_TRUE(std::holds_alternative<scene::AnimationRequest>(file.scene.actors[0].source));
  const scene::AnimationRequest& fox = std::get<scene::AnimationRequest>(file.scene.actors[0].source);
  EXPECT_EQ(fox.character_path, "/scenes/chars/Fox.glb");
  EXPECT_EQ(fox.animation, "Run");
  EXPECT_EQ(fox.length.loops, 3);
  EXPECT_DOUBLE_EQ(fox.scale, 0.01);
  EXPECT_DOUBLE_EQ(fox.fps, 24);
  ASSERT_TRUE(std::holds_alternative<scene::AnimeRequest>(file.scene.actors[1].source));
  const scene::AnimeRequest& bear = std::get<scene::AnimeRequest>(file.scene.actors[1].source);
  EXPECT_EQ(bear.path, "/data/bear.anime");
  EXPECT_DOUBLE_EQ(bear.source_fps, 25);
  EXPECT_TRUE(bear.up_z);
  EXPECT_EQ(bear.length.seconds, 4.5);
  EXPECT_DOUBLE_EQ(bear.fps, 24);
}

TEST(ActorSourceSceneFileTest, MixedUpSourcesAreNamedByTheirJsonPath) {
  EXPECT_TRUE(contains(scene_error(R"({"anime": "a.anime", "animation": "Walk", "character": "c.glb"})"),
                       "actors[0].anime: an actor plays an animation or an anime, not both"))
      << scene_error(R"({"anime": "a.anime", "animation": "Walk", "character": "c.glb"})");
  EXPECT_TRUE(contains(scene_error(R"({"character": "c.glb", "animation": "Walk", "motion": "m.bvh"})"), "actors[0].motion"));
  EXPECT_TRUE(contains(scene_error(R"({"character": "c.glb", "animation": "Walk", "quality": "fast"})"),
                       "a retargeting setting, but this actor plays its own motion"));
  EXPECT_TRUE(contains(scene_error(R"({"character": "c.glb", "animation": "Walk", "loops": 2, "seconds": 3})"),
                       "give loops or seconds, not both"));
  EXPECT_TRUE(contains(scene_error(R"({"character": "c.glb", "motion": "m.bvh", "loops": 2})"),
                       "only an actor with an animation or an anime takes this key"));
  EXPECT_TRUE(contains(scene_error(R"({"anime": "a.anime", "up": "x"})"), "expected y or z"));
  EXPECT_TRUE(contains(scene_error(R"({"anime": "a.anime", "character": "c.glb"})"), "it takes no character"));
  EXPECT_TRUE(contains(scene_error(R"({"character": "c.glb", "animation": "Walk", "source_fps": 30})"), "only an anime actor"));
  EXPECT_TRUE(contains(scene_error(R"({"character": "c.glb", "animation": ""})"), "an empty animation name"));
}

}  // namespace
}  // namespace odyssey
