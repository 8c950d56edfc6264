// Blender against the toolkit's dense maps, and `odyssey render` with the real Blender.
//
// Agreement: a shot of two walkers, a ground, a box and a wall seen by a static, an orbit and an
// ego camera at 240x135 with exact maps and scene.glb, and the same shot seen by a file camera with
// an off-centre principal point and non-square pixels; Blender imports the GLB and renders three
// frames a camera with Cycles (one sample through each pixel's centre, camera placed by
// render/blender/render_sequence.py as `odyssey render` places it; tests/python/blender_passes.py),
// and tests/python/compare_render_passes.py compares its Z, Normal and IndexOB passes with the
// sequence's depth, normal and mask maps on the pixels where both see a surface. Printed per
// camera: the shares within 1e-3 relative depth, within 1 degree, and of the same instance.
//
// Render: rgbs/ of a few frames at half size, read by PIL; a rerun of another range replaces it
// whole; a Blender that fails on a broken scene.glb leaves the earlier rgbs/ as it was; two frames
// of the bundled indoor example's head camera.
//
// Skipped only when blender is not installed.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
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
const std::string kSource = ODYSSEY_SOURCE_DIR;

bool have_blender() { return std::system("blender --version > /dev/null 2>&1") == 0; }

const std::string kCameras =
    R"({"type": "static", "name": "side", "position": [1.0, -5.0, 1.6], "target": [-0.5, 0.3, 0.9], "width": 240, "height": 135},
       {"type": "orbit", "name": "orbit", "period": 4, "width": 240, "height": 135},
       {"type": "ego", "name": "head", "actor": "follower", "width": 240, "height": 135})";

// Two walkers, a ground, a box and a wall (tests/test_sequences_cli.cpp's small scene) seen by
// `cameras`: a static camera, an orbit and the follower's head by default.
std::string agreement_scene(const std::string& cameras = kCameras) {
  return R"({"version": 1, "name": "pair", "seconds": 1, "seed": 3,
  "actors": [
    {"name": "leader", "motion": ")" + kData + R"(/mocap/cmu_walk_cgspeed.bvh", "bvh_units": "cmu",
     "character": ")" + kData + R"(/characters/RiggedFigure.glb", "placement": {"x": 0, "y": 0, "yaw": 90}},
    {"name": "follower", "motion": ")" + kData + R"(/mocap/cmu_walk_cgspeed.bvh", "bvh_units": "cmu",
     "character": ")" + kData + R"(/characters/CesiumMan.glb", "placement": {"x": 0, "y": -1.5, "yaw": 90}}],
  "props": [{"type": "ground", "name": "floor", "size": [12, 12]},
            {"type": "box", "name": "crate", "size": [0.5, 0.5, 0.5], "position": [1.0, 1.0, 0], "category": "prop"},
            {"type": "box", "name": "wall", "size": [0.2, 6, 2.5], "position": [-3, 0, 0], "category": "structure"}],
  "cameras": [)" + cameras + R"(],
  "outputs": {"points_per_actor": 100, "prop_points": 50, "depth": true, "normals": true, "masks": true,
              "exact_maps": true, "glb": true}})";
}

fs::path run_scene(const fs::path& dir, const std::string& name = "out", const std::string& cameras = kCameras) {
  std::ofstream(dir / (name + ".json")) << agreement_scene(cameras);
  const test_support::CliResult run = test_support::run_cli("scene " + (dir / (name + ".json")).string() + " --out " +
                                                            (dir / name).string() + " --layout pointodyssey --quiet");
  EXPECT_EQ(run.exit_code, 0) << run.output;
  return dir / name;
}

// Runs a shell command, returning its exit code and output.
test_support::CliResult shell(const std::string& command) {
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  test_support::CliResult result{-1, ""};
  if (!pipe) return result;
  char buffer[4096];
  while (std::fgets(buffer, sizeof buffer, pipe)) result.output += buffer;
  const int status = pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

TEST(RenderBlenderTest, CyclesPassesAgreeWithTheExactMapsForEveryCameraKind) {
  if (!have_blender()) GTEST_SKIP() << "blender is not installed (scripts/install-deps.sh installs Debian's blender)";
  ASSERT_FALSE(test_support::numpy_python().empty()) << "python3 with numpy not found";
  const fs::path dir = test_support::scratch_dir("render_blender");
  const fs::path out = run_scene(dir);
  ASSERT_TRUE(fs::exists(out / "scene.glb"));
  // A file camera with the principal point off the centre and pixels a quarter taller than wide,
  // the side camera's path otherwise: Blender's lens shift and pixel aspect must map cx, cy and fy.
  nlohmann::json path = nlohmann::json::parse(std::ifstream(out / "camera_side.json"));
  for (nlohmann::json& frame : path["frames"]) {
    frame["intrinsics"][0][2] = frame["intrinsics"][0][2].get<double>() + 17.3;
    frame["intrinsics"][1][2] = frame["intrinsics"][1][2].get<double>() - 9.6;
    frame["intrinsics"][1][1] = frame["intrinsics"][1][1].get<double>() * 1.25;
  }
  std::ofstream(dir / "skewed_path.json") << path.dump();
  const fs::path skewed = run_scene(dir, "skewed", R"({"type": "file", "name": "skewed", "path": ")" +
                                                       (dir / "skewed_path.json").string() + R"("})");
  ASSERT_TRUE(fs::exists(skewed / "scene.glb"));

  const std::string frames = "0,15,30";
  for (const std::string camera : {"side", "orbit", "head", "skewed"}) {
    const fs::path shot = camera == "skewed" ? skewed : out;
    const fs::path seq = shot / ("pair_" + camera), passes = dir / ("passes_" + camera);
    fs::create_directories(passes);
    const test_support::CliResult blender =
        shell("blender -b --factory-startup --python " + kSource + "/tests/python/blender_passes.py -- --render-dir " + kSource +
              "/render/blender --sequence " + seq.string() + " --glb " + (shot / "scene.glb").string() + " --out " +
              passes.string() + " --frames " + frames);
    ASSERT_EQ(blender.exit_code, 0) << blender.output;
    const test_support::CliResult compared = shell(test_support::numpy_python() + " " + kSource +
                                                   "/tests/python/compare_render_passes.py " + seq.string() + " " +
                                                   passes.string() + " " + frames);
    ASSERT_EQ(compared.exit_code, 0) << compared.output;
    // The figures are the last line (numpy may warn on the lines before).
    const std::string last = compared.output.substr(compared.output.rfind('\n', compared.output.size() - 2) + 1);
    const nlohmann::json shares = nlohmann::json::parse(last);
    std::printf("Blender vs maps, camera %-6s: %d pixels seen by both over %d frames; depth within 1e-3 %.4f%%, "
                "normal within 1 deg %.4f%%, same instance %.4f%%; seen by one only %.4f%% of all pixels\n",
                camera.c_str(), shares["pixels_both"].get<int>(), shares["frames"].get<int>(),
                100 * shares["depth_share"].get<double>(), 100 * shares["normal_share"].get<double>(),
                100 * shares["instance_share"].get<double>(), 100 * shares["one_only_share"].get<double>());
    // Each camera must see enough for the shares to mean something (240x135 = 32,400 a frame).
    EXPECT_GT(shares["pixels_both"].get<int>(), 20000) << camera;
    EXPECT_GE(shares["depth_share"].get<double>(), 0.995) << camera << ": " << compared.output;
    EXPECT_GE(shares["normal_share"].get<double>(), 0.995) << camera << ": " << compared.output;
    EXPECT_GE(shares["instance_share"].get<double>(), 0.995) << camera << ": " << compared.output;
    // Coverage: the two disagree on whether a centre is covered only on silhouette pixels.
    EXPECT_LE(shares["one_only_share"].get<double>(), 0.005) << camera << ": " << compared.output;
  }
}

TEST(RenderBlenderTest, RenderWritesEveryAskedFrameAndReplacesRgbsWholeOnlyOnSuccess) {
  if (!have_blender()) GTEST_SKIP() << "blender is not installed (scripts/install-deps.sh installs Debian's blender)";
  ASSERT_FALSE(test_support::numpy_python().empty()) << "python3 with numpy not found";
  const fs::path dir = test_support::scratch_dir("render_blender");
  const fs::path out = run_scene(dir);
  ASSERT_TRUE(fs::exists(out / "scene.glb"));
  const fs::path seq = out / "pair_orbit";

  const test_support::CliResult run = test_support::run_cli("render " + seq.string() + " --samples 4 --scale 0.5 --frames 0:3");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_TRUE(contains(run.output, "3 frames at 120x68")) << run.output;  // 135 x 0.5 = 67.5, rounded away from 0
  EXPECT_EQ(test_support::files_in(seq / "rgbs"), (std::vector<std::string>{"rgb_00000.jpg", "rgb_00001.jpg", "rgb_00002.jpg"}));
  // PIL reads them at the asked size, and they are pictures: the sky, the ground and the actors
  // differ in colour (a blank or black frame would have no spread).
  const test_support::CliResult read = shell(
      test_support::numpy_python() + " -c \"import sys, numpy; from PIL import Image\n"
                                     "for k in range(3):\n"
                                     "    im = Image.open(sys.argv[1] + '/rgbs/rgb_%05d.jpg' % k)\n"
                                     "    a = numpy.asarray(im.convert('RGB'), dtype=float)\n"
                                     "    print(im.format, im.size[0], im.size[1], im.mode, int(a.std() > 10))\" " +
      seq.string());
  ASSERT_EQ(read.exit_code, 0) << read.output;
  EXPECT_EQ(read.output, "JPEG 120 68 RGB 1\nJPEG 120 68 RGB 1\nJPEG 120 68 RGB 1\n");

  // Another range replaces rgbs/ whole.
  const test_support::CliResult again = test_support::run_cli("render " + seq.string() + " --samples 1 --scale 0.25 --frames 30");
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_EQ(test_support::files_in(seq / "rgbs"), std::vector<std::string>{"rgb_00030.jpg"});

  // Blender failing on a broken scene.glb: its error line, and the earlier rgbs/ kept as it was.
  std::ofstream(out / "scene.glb", std::ios::trunc) << "not a GLB";
  const test_support::CliResult broken = test_support::run_cli("render " + seq.string() + " --samples 1 --frames 0:2");
  EXPECT_EQ(broken.exit_code, 1) << broken.output;
  EXPECT_TRUE(contains(broken.output, seq.string() + ": Blender (")) << broken.output;
  EXPECT_TRUE(contains(broken.output, "failed (exit status 1): ")) << broken.output;
  EXPECT_EQ(test_support::files_in(seq / "rgbs"), std::vector<std::string>{"rgb_00030.jpg"});
  for (const auto& entry : fs::directory_iterator(seq)) {
    EXPECT_FALSE(contains(entry.path().filename().string(), "partial")) << "left behind: " << entry.path();
  }
}

// The bundled indoor example, as a user runs it, and two frames of its head camera rendered small:
// the sequence holds rgbs/ beside its maps, one JPEG a frame at the asked size.
TEST(RenderBlenderTest, TheIndoorExampleRendersFromItsSequence) {
  if (!have_blender()) GTEST_SKIP() << "blender is not installed (scripts/install-deps.sh installs Debian's blender)";
  const fs::path out = test_support::scratch_dir("render_blender") / "indoor";
  const test_support::CliResult scene = test_support::run_cli("scene " + kData + "/scenes/indoor.json --out " + out.string() + " --quiet");
  ASSERT_EQ(scene.exit_code, 0) << scene.output;
  const fs::path seq = out / "indoor_head";
  const test_support::CliResult run = test_support::run_cli("render " + seq.string() + " --samples 2 --scale 0.125 --frames 40:42");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_TRUE(contains(run.output, "2 frames at 120x68")) << run.output;
  EXPECT_EQ(test_support::files_in(seq / "rgbs"), (std::vector<std::string>{"rgb_00040.jpg", "rgb_00041.jpg"}));
  for (const char* kept : {"anno.npz", "depths/depth_00040.png", "masks/mask_00041.png", "normals/normal_00040.jpg"}) {
    EXPECT_TRUE(fs::exists(seq / kept)) << kept;
  }
}

}  // namespace
}  // namespace odyssey
