// `odyssey scene --layout pointodyssey` end to end, read as the trackers' loaders read it: one
// sequence folder per camera with anno.npz, info.npz, depths/, normals/, masks/ and
// scene_info.json, checked by tests/python/read_sequence.py with numpy and PIL (file names, keys,
// dtypes, shapes, depth decoded as value / 65535 x 1000, masks 8-bit single channel, visible points
// on a mask pixel of their own instance and at the depth the map holds); the bad inputs fail with
// one line naming the problem and leave nothing behind.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "cli_runner.h"
#include "test_support.h"

namespace odyssey {
namespace {

namespace fs = std::filesystem;
using test_support::contains;

const std::string kData = ODYSSEY_DATA_DIR;
const std::string kReader = std::string(ODYSSEY_SOURCE_DIR) + "/tests/python/read_sequence.py";

// Two walkers and a box on a ground, a head camera and an orbit, 1 s.
std::string small_scene(const std::string& outputs) {
  return R"({"version": 1, "name": "pair", "seconds": 1, "seed": 3,
  "actors": [
    {"name": "leader", "motion": ")" + kData + R"(/mocap/cmu_walk_cgspeed.bvh", "bvh_units": "cmu",
     "character": ")" + kData + R"(/characters/RiggedFigure.glb", "placement": {"x": 0, "y": 0, "yaw": 90}},
    {"name": "follower", "motion": ")" + kData + R"(/mocap/cmu_walk_cgspeed.bvh", "bvh_units": "cmu",
     "character": ")" + kData + R"(/characters/CesiumMan.glb", "placement": {"x": 0, "y": -1.5, "yaw": 90}}],
  "props": [{"type": "ground", "name": "floor", "size": [12, 12]},
            {"type": "box", "name": "crate", "size": [0.5, 0.5, 0.5], "position": [1.0, 1.0, 0], "category": "prop"},
            {"type": "box", "name": "wall", "size": [0.2, 6, 2.5], "position": [-3, 0, 0], "category": "structure"}],
  "cameras": [{"type": "ego", "name": "head", "actor": "follower", "width": 320, "height": 180},
              {"type": "orbit", "name": "orbit", "width": 320, "height": 180, "period": 4}],
  "outputs": )" + outputs + "}";
}

fs::path write_scene(const fs::path& dir, const std::string& json) {
  fs::create_directories(dir);
  const fs::path path = dir / "pair.json";
  std::ofstream(path) << json;
  return path;
}

TEST(SequencesCliTest, LoadersReadEverySequence) {
  const fs::path dir = test_support::scratch_dir("sequences_cli");
  const fs::path scene = write_scene(dir, small_scene(R"({"points_per_actor": 400, "prop_points": 100,
      "depth": true, "normals": true, "masks": true, "exact_maps": true, "glb": true})"));
  const fs::path out = dir / "out";
  const test_support::CliResult run = test_support::run_cli("scene " + scene.string() + " --out " + out.string() +
                                                            " --layout pointodyssey --quiet");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  for (const std::string camera : {"head", "orbit"}) {
    const fs::path seq = out / ("pair_" + camera);
    ASSERT_TRUE(fs::is_directory(seq)) << seq;
    for (const char* name : {"anno.npz", "info.npz", "scene_info.json", "depths/depth_00000.png", "depths/depth_00030.png",
                             "depths/depth_00000.npy", "normals/normal_00000.jpg", "normals/normal_00000.npy",
                             "masks/mask_00030.png"}) {
      EXPECT_TRUE(fs::exists(seq / name)) << seq / name;
    }
    EXPECT_FALSE(fs::exists(seq / "depths/depth_00031.png")) << "31 frames: 0 to 30";
    const nlohmann::json info = nlohmann::json::parse(std::ifstream(seq / "scene_info.json"));
    ASSERT_EQ(info["instances"].size(), 5u);
    EXPECT_EQ(info["instances"][0]["category"], "human");
    EXPECT_EQ(info["instances"][2]["category"], "ground");
    EXPECT_EQ(info["instances"][3]["category"], "prop");
    EXPECT_EQ(info["instances"][4]["category"], "structure");
    EXPECT_EQ(info["fps"], 30);

    ASSERT_FALSE(test_support::numpy_python().empty()) << "python3 with numpy not found";
    const std::string command = test_support::numpy_python() + " " + kReader + " " + seq.string() + " 2>&1";
    FILE* pipe = popen(command.c_str(), "r");
    ASSERT_NE(pipe, nullptr);
    std::string text;
    char buffer[4096];
    while (std::fgets(buffer, sizeof buffer, pipe)) text += buffer;
    ASSERT_EQ(pclose(pipe), 0) << text;
    const nlohmann::json figures = nlohmann::json::parse(text);
    std::printf("%s: %s", camera.c_str(), text.c_str());
    EXPECT_EQ(figures["frames"], 31);
    EXPECT_EQ(figures["points"], 900);
    EXPECT_GT(figures["visible_point_frames"].get<int>(), 1000);
    // A visible point's pixel is sampled at its centre, up to 0.7 px from the point: on a
    // silhouette it may show what lies behind (5-7% of the points at this size), but its own
    // instance is always within a pixel. On a silhouette a round body's depth also changes by
    // centimetres from one pixel to the next, more than the window's spread allows for some (the
    // depth map itself is checked against ray casting in test_dense_maps).
    EXPECT_GT(figures["on_own_mask"].get<double>(), 0.9);
    EXPECT_GT(figures["near_own_mask"].get<double>(), 0.995);
    EXPECT_GT(figures["depth_agrees"].get<double>(), 0.9);
  }
  EXPECT_TRUE(fs::exists(out / "scene.glb"));

  // A rerun replaces each sequence whole: a file the first run did not write goes with it.
  std::ofstream(out / "pair_orbit" / "stale.txt") << "from before";
  const test_support::CliResult again = test_support::run_cli("scene " + scene.string() + " --out " + out.string() +
                                                              " --layout pointodyssey --quiet");
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_FALSE(fs::exists(out / "pair_orbit" / "stale.txt"));
  EXPECT_TRUE(fs::exists(out / "pair_orbit" / "anno.npz"));
  for (const auto& entry : fs::directory_iterator(out)) {
    EXPECT_FALSE(contains(entry.path().filename().string(), ".partial-")) << "left behind: " << entry.path();
    EXPECT_FALSE(contains(entry.path().filename().string(), ".previous-")) << "left behind: " << entry.path();
  }
}

TEST(SequencesCliTest, BadLayoutsFailAndWriteNothing) {
  const fs::path dir = test_support::scratch_dir("sequences_cli");
  const fs::path scene = write_scene(dir, small_scene(R"({"depth": true})"));
  const fs::path out = dir / "out";
  const test_support::CliResult unknown = test_support::run_cli("scene " + scene.string() + " --out " + out.string() +
                                                                " --layout kubric");
  EXPECT_NE(unknown.exit_code, 0);
  EXPECT_TRUE(contains(unknown.output, "--layout expects files or pointodyssey, got 'kubric'")) << unknown.output;
  EXPECT_TRUE(!fs::exists(out) || fs::is_empty(out));

  // A file where a sequence folder goes is refused before any work, and kept.
  fs::create_directories(out);
  std::ofstream(out / "pair_head") << "not a folder";
  const test_support::CliResult blocked = test_support::run_cli("scene " + scene.string() + " --out " + out.string() +
                                                                " --layout pointodyssey");
  EXPECT_NE(blocked.exit_code, 0);
  EXPECT_TRUE(contains(blocked.output, (out / "pair_head").string() + ": exists and is a file, not a folder")) << blocked.output;
  EXPECT_EQ(test_support::files_in(out), std::vector<std::string>{"pair_head"});
  fs::remove(out / "pair_head");

  const fs::path in_file = write_scene(dir / "in_file", small_scene(R"({"layout": "pointodyssey", "depth": 1})"));
  const test_support::CliResult typed = test_support::run_cli("scene " + in_file.string() + " --out " + out.string());
  EXPECT_NE(typed.exit_code, 0);
  EXPECT_TRUE(contains(typed.output, "pair.json: outputs.depth: not true or false")) << typed.output;
  EXPECT_TRUE(!fs::exists(out) || fs::is_empty(out));
}

}  // namespace
}  // namespace odyssey
