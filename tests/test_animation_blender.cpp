// A character's own animation against Blender's: `odyssey point-cache --animation` plays a glTF
// animation, Debian's blender imports the same file with its own glTF importer, plays the same
// animation (tests/blender/check_animation.py) and reports every vertex's world position at the
// same times; both must agree within 1e-4 of the character's size (its largest rest extent).
//
// Which times. Blender's importer turns LINEAR rotation keys into per-component linear curves,
// which it normalises: between two keys that is not glTF's slerp (for the Fox's Run, 30 degrees
// a key, the two differ by up to 2.5e-4 of its size). So fast rotations are compared at key times,
// where both are the key itself, and between keys only where rotations change slowly (the Fox's
// Survey, the test rig's 6 degrees a key) or the samplers agree exactly (STEP, translations).
// Blender 3.4's importer ignores CUBICSPLINE tangents (automatic Bezier handles instead), so
// CUBICSPLINE tracks are compared at their keys only. The Fox's keys
// lie on a 24 fps grid (Run's last eight at 20.8 .. 27.8 frames), all of them on a 120 fps grid,
// so the point cache is written at 120 fps and frame k is time k / 120. Skipped only when blender
// is not installed.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>

#include "animated_rig.h"
#include "cli_runner.h"
#include "mocap_io/gltf_character.h"
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

struct Comparison {
  double max_error = 0, size = 0;
  int vertices = 0;
};

// Plays `animation` of `file` in odyssey (a point cache at 120 fps) and in Blender at frames
// `frames` of 120 fps, and measures the largest distance between the two over every vertex.
Comparison compare_with_blender(const fs::path& file, const std::string& animation, const std::vector<int>& frames) {
  const fs::path dir = test_support::scratch_dir("animation_blender") / animation;
  fs::create_directories(dir);
  const test_support::CliResult run = test_support::run_cli("point-cache --character " + quoted(file) + " --animation " + animation +
                                                            " --fps 120 --out " + quoted(dir / "cache.pc2"));
  EXPECT_EQ(run.exit_code, 0) << run.output;
  std::string times;
  for (const int f : frames) times += (times.empty() ? "" : ",") + std::to_string(f / 120.0);
  const fs::path script = fs::path(__FILE__).parent_path() / "blender" / "check_animation.py";
  const fs::path out = dir / "blender.json", log = dir / "blender.log";
  const int status = std::system(("blender -b --factory-startup --python " + quoted(script) + " -- --file " + quoted(file) +
                                  " --animation " + animation + " --fps 24 --times " + times + " --out " + quoted(out) + " > " +
                                  quoted(log) + " 2>&1").c_str());
  std::ifstream log_in(log);
  const std::string log_text((std::istreambuf_iterator<char>(log_in)), std::istreambuf_iterator<char>());
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << log_text;
  const nlohmann::json blender = nlohmann::json::parse(std::ifstream(out));

  std::ifstream pc2(dir / "cache.pc2", std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(pc2)), std::istreambuf_iterator<char>());
  std::int32_t points = 0, samples = 0;
  std::memcpy(&points, bytes.data() + 16, 4);
  std::memcpy(&samples, bytes.data() + 28, 4);
  Comparison result;
  const Eigen::AlignedBox3d rest = io::load_character(file.string()).rest_bounds();
  result.size = rest.sizes().maxCoeff();
  for (std::size_t t = 0; t < frames.size(); ++t) {
    EXPECT_LT(frames[t], samples);
    int vertex = 0;  // the cache's numbering: meshes in the loader's order, vertices as stored
    for (const nlohmann::json& mesh : blender["meshes"]) {
      for (const nlohmann::json& row : mesh["positions"][t]) {
        if (!row.is_null()) {
          float ours[3];
          std::memcpy(ours, bytes.data() + 32 + (std::size_t(frames[t]) * points + vertex) * 12, 12);
          const Eigen::Vector3d theirs(row[0].get<double>(), row[1].get<double>(), row[2].get<double>());
          result.max_error = std::max(result.max_error, (theirs - Eigen::Vector3f(ours[0], ours[1], ours[2]).cast<double>()).norm());
        }
        ++vertex;
      }
    }
    result.vertices = vertex;
  }
  EXPECT_EQ(result.vertices, points) << "Blender's meshes and the cache list different vertices";
  return result;
}

bool blender_missing() { return std::system("blender --version > /dev/null 2>&1") != 0; }

TEST(AnimationBlenderTest, TheFoxsAnimationsAgreeWithBlenders) {
  if (blender_missing()) GTEST_SKIP() << "blender is not installed (scripts/install-deps.sh installs Debian's blender)";
  const fs::path fox = fs::path(ODYSSEY_DATA_DIR) / "characters" / "Fox.glb";
  const std::vector<std::pair<std::string, std::vector<int>>> cases = {
      {"Walk", {0, 20, 45, 60, 85}},             // keys
      {"Run", {0, 25, 55, 80, 104, 139}},        // keys, the last two off the 24 fps grid
      {"Survey", {7, 101, 203, 333, 409}}};      // between keys: slow turns
  for (const auto& [animation, frames] : cases) {
    const Comparison c = compare_with_blender(fox, animation, frames);
    std::printf("Fox %s vs Blender: max %.3g over %d vertices, %.3g of its size %.4g\n", animation.c_str(), c.max_error,
                c.vertices, c.max_error / c.size, c.size);
    EXPECT_LE(c.max_error, 1e-4 * c.size) << animation;
  }
}

TEST(AnimationBlenderTest, EverySamplerAndANonJointParentAgreeWithBlender) {
  if (blender_missing()) GTEST_SKIP() << "blender is not installed (scripts/install-deps.sh installs Debian's blender)";
  const fs::path dir = test_support::scratch_dir("animation_blender_rig");
  // With CUBICSPLINE tracks: at the keys only, as Blender 3.4 ignores their tangents between keys
  // (test_keyframes.cpp and test_character_animation.cpp check the curves against hand-computed values).
  const fs::path cubic = dir / "rig_cubic.glb";
  animated_rig::write_rig(cubic.string());
  const Comparison at_keys = compare_with_blender(cubic, "Wave", {0, 60, 120});
  std::printf("test rig (cubic) vs Blender at keys: max %.3g over %d vertices, %.3g of its size %.4g\n", at_keys.max_error,
              at_keys.vertices, at_keys.max_error / at_keys.size, at_keys.size);
  EXPECT_LE(at_keys.max_error, 1e-4 * at_keys.size);
  // The same motion through LINEAR tracks, between keys too: STEP's jump at 60, LINEAR's 6 degrees
  // a key, the non-joint parent's translation, rotation and constant scale, the rigid block.
  animated_rig::RigOptions options;
  options.cubic = false;
  const fs::path linear = dir / "rig_linear.glb";
  animated_rig::write_rig(linear.string(), options);
  const Comparison between = compare_with_blender(linear, "Wave", {0, 15, 30, 36, 59, 60, 75, 108, 120});
  std::printf("test rig (linear) vs Blender: max %.3g over %d vertices, %.3g of its size %.4g\n", between.max_error,
              between.vertices, between.max_error / between.size, between.size);
  EXPECT_LE(between.max_error, 1e-4 * between.size);
}

}  // namespace
}  // namespace odyssey
