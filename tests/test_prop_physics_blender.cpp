// Blender against the scene GLB of moving props: `odyssey scene` writes a walker kicking a crate
// on its path, a block dropped beside it and scattered crates knocked by seeded forces, with
// outputs glb and trajectories; Debian's blender imports the GLB headless and
// tests/blender/check_scene_glb.py measures, at frames before, during and after the kicks, how far
// Blender's evaluated props (their nodes' animated translation and rotation) put the tracked
// points from trajs_3d. Skipped only when blender is not installed.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>

#include "cli_runner.h"
#include "test_support.h"

namespace odyssey {
namespace {

namespace fs = std::filesystem;

std::string quoted(const fs::path& path) {
  std::string text = "'";
  text += path.string();
  text += "'";
  return text;
}

TEST(PropPhysicsBlenderTest, BlendersAnimatedPropsPutThePointsWhereTheTrajectoriesSay) {
  if (std::system("blender --version > /dev/null 2>&1") != 0) {
    GTEST_SKIP() << "blender is not installed (scripts/install-deps.sh installs Debian's blender)";
  }
  const fs::path dir = test_support::scratch_dir("prop_physics_blender");
  std::ofstream(dir / "shot.json") << R"({
  "version": 1,
  "name": "props_in_blender",
  "fps": 30,
  "seconds": 3,
  "seed": 5,
  "actors": [
    {"name": "walker", "motion": "data:mocap/cmu_walk_cgspeed.bvh", "bvh_units": "cmu",
     "character": "data:characters/RiggedFigure.glb", "quality": "fast",
     "placement": {"x": 0, "y": 0, "yaw": 0}, "points": 200}
  ],
  "props": [
    {"name": "kicked", "type": "box", "size": [0.25, 0.25, 0.25], "position": [0.91, -0.02, 0], "dynamic": true},
    {"name": "dropped", "type": "box", "size": [0.2, 0.3, 0.2], "position": [1.5, 1.5, 1], "yaw": 30, "dynamic": true,
     "angular_velocity": [1, 2, 0]},
    {"name": "block", "type": "mesh", "path": "data:props/kenney_brick.glb", "scale": 0.3, "position": [-1.0, 1.5, 0.5],
     "dynamic": true, "velocity": [0.5, 0, 1]}
  ],
  "scatter": {"count": 4, "region": [-3, -3, 3, 3],
              "props": [{"name": "crate", "type": "box", "size": [0.3, 0.2, 0.2], "dynamic": true}]},
  "forces": {"count": 2, "lever_arm": 0.1},
  "cameras": [{"name": "side", "type": "static", "position": [0.5, -6, 1.8], "target": [0.5, 0, 0.4]}],
  "outputs": {"glb": true, "trajectories": true, "camera_paths": false, "prop_points": 300}
}
)";
  const test_support::CliResult run = test_support::run_cli("scene " + quoted(dir / "shot.json") + " --out " + quoted(dir / "shot"));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  ASSERT_TRUE(fs::exists(dir / "shot" / "scene.glb")) << run.output;

  const fs::path script = fs::path(__FILE__).parent_path() / "blender" / "check_scene_glb.py";
  const fs::path report_path = dir / "blender_report.json", log_path = dir / "blender.log";
  const std::string command = "blender -b --factory-startup --python " + quoted(script) + " -- --glb " +
                              quoted(dir / "shot" / "scene.glb") + " --fps 30 --frames 0,12,25,40,60,90 --report " +
                              quoted(report_path) + " --camera side=" + quoted(dir / "shot" / "trajectories_side.npz");
  const int status = std::system((command + " > " + quoted(log_path) + " 2>&1").c_str());
  std::ifstream log_in(log_path);
  const std::string log((std::istreambuf_iterator<char>(log_in)), std::istreambuf_iterator<char>());
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << log;
  const nlohmann::json report = nlohmann::json::parse(std::ifstream(report_path));

  // float32 storage (vertices, node transforms, trajectories) and Blender's float evaluation stay
  // far below 0.1 mm; a prop left static in the GLB would be off by its travel (metres here).
  EXPECT_EQ(report["points"], 500);
  ASSERT_TRUE(report["max_error_3d_m_by_owner"].contains("props")) << report.dump(1);
  EXPECT_LE(report["max_error_3d_m_by_owner"]["props"].get<double>(), 1e-4) << report.dump(1);
  EXPECT_LE(report["max_error_3d_m"].get<double>(), 1e-4) << report.dump(1);
  std::printf("Blender vs trajs_3d, props: max %.3g m\n", report["max_error_3d_m_by_owner"]["props"].get<double>());
}

}  // namespace
}  // namespace odyssey
