// The camera sources end to end through the odyssey command: per-frame intrinsics of a zoom in the
// trajectory npz and the camera JSON; a scene file with RealEstate10K and COLMAP tracks, a swoop, a
// dolly-zoom and a handheld shake; and bad camera files and options failing with one line naming
// the file, the line and the problem, a non-zero exit and nothing written.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "cli_runner.h"
#include "mocap_io/npy.h"
#include "test_support.h"

namespace odyssey {
namespace {

namespace fs = std::filesystem;
using test_support::contains;
constexpr double kPi = std::numbers::pi;

const std::string kData = ODYSSEY_DATA_DIR;
const std::string kWalk = kData + "/mocap/cmu_walk_cgspeed.bvh";
const std::string kFigure = kData + "/characters/RiggedFigure.glb";
const std::string kRealEstate = std::string(ODYSSEY_SHARED_DIR) + "/assets/cameras/realestate10k/0bf152ef84195293.txt";
const std::string kColmap = std::string(ODYSSEY_SHARED_DIR) + "/assets/cameras/colmap_unsorted";

nlohmann::json read_json(const fs::path& path) { return nlohmann::json::parse(std::ifstream(path)); }

// The lines of `output` that start with "odyssey trajectories: " (the error line).
std::vector<std::string> error_lines(const std::string& output) {
  std::vector<std::string> lines;
  std::istringstream in(output);
  for (std::string line; std::getline(in, line);) {
    if (line.starts_with("odyssey trajectories: ")) lines.push_back(line);
  }
  return lines;
}

// A zoom from 60 to 20 degrees: the npz's intrinsics [T,3,3] and the camera JSON's carry the focal
// length of every frame, fx(0) = 480 / tan 30 deg and fx(T-1) = 480 / tan 10 deg; the handheld shake
// leaves them alone.
TEST(CameraSourcesCliTest, ZoomWritesPerFrameIntrinsicsToTheNpzAndTheCameraJson) {
  const fs::path dir = test_support::scratch_dir("camera_sources_cli");
  const fs::path npz = dir / "zoom.npz", json = dir / "zoom.json";
  const test_support::CliResult result =
      test_support::run_cli("trajectories --motion " + kWalk + " --character " + kFigure + " --quality fast --points 100 " +
                            "--camera zoom --hfov 60 --hfov-end 20 --handheld 0.01 --out " + npz.string() +
                            " --camera-path " + json.string());
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_TRUE(contains(result.output, "camera     zoom+handheld")) << result.output;
  const std::vector<float> k = io::NpzReader(npz.string()).load("intrinsics").to_float();
  const nlohmann::json camera = read_json(json);
  const std::size_t frames = camera["frames"].size();
  ASSERT_EQ(k.size(), frames * 9);
  ASSERT_GT(frames, 10u);
  for (std::size_t f = 0; f < frames; ++f) {
    const double fx = camera["frames"][f]["intrinsics"][0][0];
    EXPECT_NEAR(k[f * 9], fx, 1e-6 * fx) << "frame " << f;
    EXPECT_NEAR(k[f * 9 + 4], camera["frames"][f]["intrinsics"][1][1].get<double>(), 1e-6 * fx);
    if (f > 0) EXPECT_GT(fx, camera["frames"][f - 1]["intrinsics"][0][0].get<double>()) << "frame " << f;
  }
  EXPECT_NEAR(camera["frames"][0]["intrinsics"][0][0].get<double>(), 480 / std::tan(kPi / 6), 1e-9);
  EXPECT_NEAR(camera["frames"][frames - 1]["intrinsics"][0][0].get<double>(), 480 / std::tan(kPi / 18), 1e-9);
}

// One scene, five camera sources: the RealEstate10K sample re-aimed at the actor and fitted to a
// 9 m circle about (0.5, -0.5); the COLMAP sample at 10 images a second; a rising swoop; a
// dolly-zoom whose f / d stays constant; a static camera with a handheld shake.
TEST(CameraSourcesCliTest, SceneFileRunsEveryCameraSource) {
  const fs::path dir = test_support::scratch_dir("camera_sources_cli");
  const nlohmann::json scene = {
      {"version", 1},
      {"fps", 30},
      {"seconds", 2},
      {"seed", 3},
      {"actors", {{{"name", "walker"}, {"motion", kWalk}, {"bvh_units", "cmu"}, {"character", kFigure}, {"quality", "fast"},
                   {"placement", {{"x", 0}, {"y", 0}, {"yaw", 90}}}}}},
      {"cameras",
       {{{"name", "video"}, {"type", "realestate10k"}, {"path", kRealEstate}, {"extent", 9}, {"target", {0.5, -0.5, 1}},
         {"height_m", 1.6}, {"aim", 0.5}},
        {{"name", "sfm"}, {"type", "colmap"}, {"path", kColmap}, {"anchor", "focus"}, {"fps", 10}, {"width", 640}, {"height", 480}},
        {{"name", "crane"}, {"type", "swoop"}, {"target", {0, 0, 1}}, {"radius", 6}, {"height_m", 0.5}, {"height_end", 5}},
        {{"name", "vertigo"}, {"type", "dolly-zoom"}, {"position", {0, -8, 1}}, {"target", {0, 0, 1}}, {"end_distance", 3}},
        {{"name", "shaky"}, {"type", "static"}, {"position", {4, -4, 1.5}}, {"handheld", {{"amplitude", 0.05}, {"band", {1, 4}}}}}}},
      {"outputs", {{"points_per_actor", 200}}}};
  const fs::path file = dir / "cameras.json";
  std::ofstream(file) << scene.dump(2);
  const fs::path out = dir / "out";
  const test_support::CliResult result = test_support::run_cli("scene " + file.string() + " --out " + out.string());
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_TRUE(contains(result.output, "note       camera 'sfm': ")) << result.output;
  EXPECT_TRUE(contains(result.output, "colmap_unsorted/cameras.txt: lens distortion of camera(s) 1, 2, 3 not applied")) << result.output;

  const nlohmann::json video = read_json(out / "camera_video.json");
  EXPECT_EQ(video["kind"], "realestate10k");
  const std::size_t frames = video["frames"].size();
  ASSERT_EQ(frames, 61u);
  // The centres' mean sits on (0.5, -0.5) at 1.6 m, the farthest 4.5 m from it.
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> centres;
  for (const auto& frame : video["frames"]) {
    centres.emplace_back(frame["centre"][0].get<double>(), frame["centre"][1].get<double>(), frame["centre"][2].get<double>());
    mean += centres.back() / double(frames);
    EXPECT_NEAR(frame["intrinsics"][0][0].get<double>(), 0.474812461 * 960, 1e-6);
  }
  EXPECT_LT((mean - Eigen::Vector3d(0.5, -0.5, 1.6)).norm(), 1e-9);
  double reach = 0;
  for (const Eigen::Vector3d& c : centres) reach = std::max(reach, (c - mean).head<2>().norm());
  EXPECT_NEAR(reach, 4.5, 1e-9);

  const nlohmann::json sfm = read_json(out / "camera_sfm.json");
  EXPECT_EQ(sfm["kind"], "colmap");
  // Image aaa (camera 3: 600 px on 1024 x 768) first, scaled to 640 x 480.
  EXPECT_NEAR(sfm["frames"][0]["intrinsics"][0][0].get<double>(), 600.0 / 1024 * 640, 1e-9);
  const nlohmann::json report = read_json(out / "report.json");
  ASSERT_TRUE(report["notes"].is_array());
  EXPECT_GE(report["notes"].size(), 2u);  // the distortion, and the track held after its 0.2 s

  const nlohmann::json crane = read_json(out / "camera_crane.json");
  EXPECT_NEAR(crane["frames"][0]["centre"][2].get<double>(), 0.5, 1e-9);
  EXPECT_NEAR(crane["frames"][60]["centre"][2].get<double>(), 5, 1e-9);

  const nlohmann::json vertigo = read_json(out / "camera_vertigo.json");
  for (const auto& frame : vertigo["frames"]) {
    const double d = std::hypot(frame["centre"][0].get<double>(), frame["centre"][1].get<double>());
    EXPECT_NEAR(frame["intrinsics"][0][0].get<double>() / d, 480 / std::tan(40 * kPi / 180) / 8, 1e-9);
  }
  EXPECT_NEAR(vertigo["frames"][60]["centre"][1].get<double>(), -3, 1e-9);

  const nlohmann::json shaky = read_json(out / "camera_shaky.json");
  EXPECT_EQ(shaky["kind"], "static+handheld");
  double moved = 0;
  for (const auto& frame : shaky["frames"]) {
    const Eigen::Vector3d c(frame["centre"][0].get<double>(), frame["centre"][1].get<double>(), frame["centre"][2].get<double>());
    moved = std::max(moved, (c - Eigen::Vector3d(4, -4, 1.5)).norm());
  }
  EXPECT_GT(moved, 0.01);
  EXPECT_LE(moved, 0.05 * std::sqrt(3) + 1e-9);

  // The same scene again draws the same shake.
  const fs::path again = dir / "again";
  ASSERT_EQ(test_support::run_cli("scene " + file.string() + " --out " + again.string()).exit_code, 0);
  EXPECT_EQ(read_json(again / "camera_shaky.json")["frames"], shaky["frames"]);
}

// A RealEstate10K frame line: timestamp, normalised intrinsics, two unused, an upright camera at
// (x, 0, 0) of a y-up world looking along +x, with `r01` written into its matrix.
std::string frame_line(long long time_us, double fx, double x, double r01 = 0) {
  std::ostringstream line;
  line << time_us << ' ' << fx << " 0.9 0.5 0.5 0 0 0 " << r01 << " 1 0  0 -1 0 0  1 0 0 " << -x;
  return line.str();
}

TEST(CameraSourcesCliTest, BadCameraFilesFailWithOneLineAndWriteNothing) {
  const fs::path dir = test_support::scratch_dir("camera_sources_cli");
  const std::string url = "https://example.com/clip\n";
  struct Case {
    std::string name, text, problem;
  };
  const std::vector<Case> cases = {
      {"sheared.txt", url + frame_line(0, 0.5, 0) + "\n" + frame_line(100, 0.5, 1, 0.3) + "\n",
       "line 3: the 3x3 part of the world-to-camera matrix is not a rotation"},
      {"unsorted.txt", url + frame_line(100, 0.5, 0) + "\n" + frame_line(50, 0.5, 1) + "\n", "line 3: timestamp 50 comes before line 2's"},
      {"repeated.txt", url + frame_line(100, 0.5, 0) + "\n" + frame_line(100, 0.5, 1) + "\n", "line 3: timestamp 100 repeats line 2's"},
      {"zero_focal.txt", url + frame_line(0, 0, 0) + "\n", "line 2: focal length 0 is not positive"},
      {"truncated.txt", url + frame_line(0, 0.5, 0) + "\n" + frame_line(100, 0.5, 1).substr(0, 30) + "\n",
       "line 3: a frame line has 19 numbers"},
  };
  const fs::path out = dir / "out";
  fs::create_directories(out);
  const std::string base = "trajectories --motion " + kWalk + " --character " + kFigure + " --quality fast --points 50 --out " +
                           (out / "t.npz").string() + " --camera-path " + (out / "c.json").string();
  for (const Case& c : cases) {
    const fs::path file = dir / c.name;
    std::ofstream(file) << c.text;
    const test_support::CliResult result = test_support::run_cli(base + " --camera realestate10k --camera-file " + file.string());
    EXPECT_EQ(result.exit_code, 1) << result.output;
    const std::vector<std::string> errors = error_lines(result.output);
    ASSERT_EQ(errors.size(), 1u) << result.output;
    EXPECT_TRUE(errors[0].starts_with("odyssey trajectories: " + file.string() + ": line ")) << errors[0];
    EXPECT_TRUE(contains(errors[0], c.problem)) << c.name << ": " << errors[0];
    EXPECT_TRUE(fs::is_empty(out)) << c.name << " left output behind";
  }

  // COLMAP: an unknown camera model, named with its line, through a scene file.
  const fs::path model = dir / "model";
  fs::create_directories(model);
  std::ofstream(model / "cameras.txt") << "# cameras\n1 FULL_OPENCV 640 480 500 500 320 240 0 0 0 0 0 0 0 0\n";
  std::ofstream(model / "images.txt") << "1 1 0 0 0 0 0 0 1 a.png\n\n";
  const test_support::CliResult colmap =
      test_support::run_cli(base + " --camera colmap --camera-file " + model.string());
  EXPECT_EQ(colmap.exit_code, 1) << colmap.output;
  const std::vector<std::string> errors = error_lines(colmap.output);
  ASSERT_EQ(errors.size(), 1u) << colmap.output;
  EXPECT_TRUE(contains(errors[0], (model / "cameras.txt").string() + ": line 2: unknown camera model 'FULL_OPENCV'")) << errors[0];
  EXPECT_TRUE(fs::is_empty(out));

  // Options: a track needs its file; a file is for the cameras that read one; a band past Nyquist.
  const struct {
    std::string arguments, message;
    int exit_code;
  } usage[] = {
      {" --camera realestate10k", "--camera realestate10k needs --camera-file", 2},
      {" --camera swoop --camera-file " + kRealEstate, "--camera-file is for", 2},
      {" --camera orbit --handheld 0.01 --handheld-band 1,20", "must have 0 < low <= high < fps / 2", 1},
      {" --camera static --handheld 0.01 --handheld-band 3", "--handheld-band expects LO,HI", 2},
      {" --camera realestate10k --camera-file " + kRealEstate + " --camera-extent 0", "--camera-extent must be positive", 2},
  };
  for (const auto& bad : usage) {
    const test_support::CliResult result = test_support::run_cli(base + bad.arguments);
    EXPECT_EQ(result.exit_code, bad.exit_code) << bad.arguments << "\n" << result.output;
    EXPECT_TRUE(contains(result.output, bad.message)) << bad.arguments << "\n" << result.output;
    EXPECT_TRUE(fs::is_empty(out));
  }
}

// Scene-file keys are checked per camera type.
TEST(CameraSourcesCliTest, SceneFileCameraKeysAreCheckedPerType) {
  const fs::path dir = test_support::scratch_dir("camera_sources_cli");
  const auto run_with_camera = [&](const nlohmann::json& camera) {
    const nlohmann::json scene = {
        {"version", 1},
        {"actors", {{{"motion", kWalk}, {"character", kFigure}, {"quality", "fast"}}}},
        {"cameras", {camera}}};
    const fs::path file = dir / "scene.json";
    std::ofstream(file) << scene.dump();
    return test_support::run_cli("scene " + file.string() + " --out " + (dir / "out").string());
  };
  const struct {
    nlohmann::json camera;
    std::string message;
  } cases[] = {
      {{{"type", "realestate10k"}, {"path", kRealEstate}, {"hfov", 50}}, "cameras[0].hfov: not a key of a realestate10k camera"},
      {{{"type", "colmap"}}, "cameras[0].path: missing"},
      {{{"type", "zoom"}, {"hfov_end", 190}}, "expected degrees between 0 and 180"},
      {{{"type", "swoop"}, {"end_distance", 2}}, "not a key of a swoop camera"},
      {{{"type", "static"}, {"handheld", {{"band", {3, 1}}}}}, "the band's high end lies below its low end"},
      {{{"type", "crane"}}, "expected static, orbit, ego, file, swoop, dolly-zoom, zoom, realestate10k or colmap"},
  };
  for (const auto& bad : cases) {
    const test_support::CliResult result = run_with_camera(bad.camera);
    EXPECT_NE(result.exit_code, 0) << result.output;
    EXPECT_TRUE(contains(result.output, bad.message)) << bad.camera.dump() << "\n" << result.output;
    EXPECT_FALSE(fs::exists(dir / "out" / "report.json"));
  }
}

}  // namespace
}  // namespace odyssey
