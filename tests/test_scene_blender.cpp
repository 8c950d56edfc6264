// The real consumer of a scene GLB: Blender. `odyssey scene` writes a scene of two actors, a box
// and four cameras (static, orbit, ego on a head, and a file camera replaying a camera path that a
// first run wrote) with outputs glb, trajectories and camera_paths; Debian's blender imports the
// GLB headless with its own glTF importer and tests/blender/check_scene_glb.py measures, at a few
// frames, how far Blender's evaluated (armature-deformed) meshes put the tracked points from
// trajs_3d, and how far Blender's imported cameras project trajs_3d from trajs_2d. Skipped only
// when blender is not installed.
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

fs::path blender_script() { return fs::path(__FILE__).parent_path() / "blender" / "check_scene_glb.py"; }
// Built by appending: GCC 12 warns (-Wrestrict, falsely) on "'" + path.string() + "'".
std::string quoted(const fs::path& path) {
  std::string text = "'";
  text += path.string();
  text += "'";
  return text;
}

// Two walkers one behind the other (the one behind wears the head camera), a box beside them.
std::string scene_json(const std::string& cameras, const std::string& outputs) {
  return R"({
  "version": 1,
  "name": "blender_check",
  "fps": 30,
  "seconds": 1,
  "actors": [
    {"name": "follower", "motion": "data:mocap/cmu_walk_cgspeed.bvh", "bvh_units": "cmu",
     "character": "data:characters/RiggedFigure.glb", "quality": "fast",
     "placement": {"x": -2.0, "y": 0.0, "yaw": 0}, "points": 400},
    {"name": "leader", "motion": "data:mocap/cmu_walk_cgspeed.bvh", "bvh_units": "cmu",
     "character": "data:characters/CesiumMan.glb", "quality": "fast",
     "placement": {"x": -0.2, "y": 0.2, "yaw": 0}, "points": 400}
  ],
  "props": [{"name": "crate", "type": "box", "size": [0.6, 0.6, 0.8], "position": [1.0, 1.4, 0]}],
  "cameras": [)" + cameras +
         R"(],
  "outputs": )" + outputs +
         "\n}\n";
}

TEST(SceneBlenderTest, BlendersMeshesAndCamerasAgreeWithTheTrajectoriesForEveryCameraKind) {
  if (std::system("blender --version > /dev/null 2>&1") != 0) {
    GTEST_SKIP() << "blender is not installed (scripts/install-deps.sh installs Debian's blender)";
  }
  const fs::path dir = test_support::scratch_dir("scene_blender");

  // A camera path of the scene's frames for the file camera: an orbit from another angle, written
  // by a first run of the same scene.
  std::ofstream(dir / "first.json") << scene_json(
      R"({"name": "path", "type": "orbit", "radius": 5, "height_m": 2.2, "start_angle": 120, "period": 8})",
      R"({"trajectories": false, "camera_paths": true, "report": false})");
  const test_support::CliResult first = test_support::run_cli("scene " + quoted(dir / "first.json") + " --out " + quoted(dir / "first"));
  ASSERT_EQ(first.exit_code, 0) << first.output;
  ASSERT_TRUE(fs::exists(dir / "first" / "camera_path.json")) << first.output;

  std::ofstream(dir / "shot.json") << scene_json(
      R"({"name": "side", "type": "static", "position": [1.0, -5.0, 1.6], "target": [-0.5, 0.3, 0.9]},
         {"name": "orbit", "type": "orbit", "radius": 4.5, "height_m": 1.7, "period": 6},
         {"name": "head", "type": "ego", "actor": "follower"},
         {"name": "replay", "type": "file", "path": "first/camera_path.json"})",
      R"({"glb": true, "trajectories": true, "camera_paths": true, "prop_points": 100})");
  const test_support::CliResult run = test_support::run_cli("scene " + quoted(dir / "shot.json") + " --out " + quoted(dir / "shot"));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  ASSERT_TRUE(fs::exists(dir / "shot" / "scene.glb")) << run.output;

  const fs::path report_path = dir / "blender_report.json", log_path = dir / "blender.log";
  std::string command = "blender -b --factory-startup --python " + quoted(blender_script()) + " -- --glb " +
                        quoted(dir / "shot" / "scene.glb") + " --fps 30 --frames 0,7,16,30 --report " + quoted(report_path);
  for (const char* camera : {"side", "orbit", "head", "replay"}) {
    command += std::string(" --camera ") + camera + "=" + quoted(dir / "shot" / ("trajectories_" + std::string(camera) + ".npz"));
  }
  const int status = std::system((command + " > " + quoted(log_path) + " 2>&1").c_str());
  std::ifstream log_in(log_path);
  const std::string log((std::istreambuf_iterator<char>(log_in)), std::istreambuf_iterator<char>());
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << log;
  ASSERT_TRUE(fs::exists(report_path)) << log;
  const nlohmann::json report = nlohmann::json::parse(std::ifstream(report_path));

  // Tolerances: float32 storage (positions, joint and camera transforms, the trajectory files)
  // and Blender's float evaluation stay orders of magnitude below both.
  EXPECT_EQ(report["points"], 900);
  EXPECT_LE(report["max_error_3d_m"].get<double>(), 1e-4) << report.dump(1);
  for (const auto& [owner, error] : report["max_error_3d_m_by_owner"].items()) {
    std::printf("Blender vs trajs_3d, %s: max %.3g m\n", owner.c_str(), error.get<double>());
  }
  for (const char* camera : {"side", "orbit", "head", "replay"}) {
    const nlohmann::json& figures = report["cameras"][camera];
    EXPECT_LE(figures["max_error_px"].get<double>(), 0.01) << camera << ": " << report.dump(1);
    EXPECT_GT(figures["valid_point_frames"].get<int>(), 100) << camera << " sees too little to check";
    std::printf("Blender vs trajs_2d, camera %s: max %.3g px over %d valid point-frames\n", camera,
                figures["max_error_px"].get<double>(), figures["valid_point_frames"].get<int>());
  }
}

}  // namespace
}  // namespace odyssey
