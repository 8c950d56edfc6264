// The outdoor example end to end through the CLI: its scattered props are dynamic, some get kicked
// by the walkers' feet and the forces, their points move in the sequences' anno.npz, every
// scattered prop is an instance of the sequences and shows in their masks, and a second run writes
// the same bytes.
#include <gtest/gtest.h>
#include <png.h>

#include <Eigen/Core>
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "cli_runner.h"
#include "mocap_io/npy.h"
#include "test_support.h"

namespace odyssey {
namespace {

namespace fs = std::filesystem;

std::string bytes_of(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// An 8-bit single-channel PNG's pixels, through libpng's simplified reader.
std::vector<std::uint8_t> gray_pixels(const fs::path& path) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&image, path.c_str())) return {};
  image.format = PNG_FORMAT_GRAY;
  std::vector<std::uint8_t> pixels(PNG_IMAGE_SIZE(image));
  if (!png_image_finish_read(&image, nullptr, pixels.data(), 0, nullptr)) return {};
  return pixels;
}

TEST(PropPhysicsCliTest, TheOutdoorExampleKicksItsScatteredPropsTheSameWayTwice) {
  const fs::path dir = test_support::scratch_dir("prop_physics_cli");
  const std::string scene = std::string(ODYSSEY_DATA_DIR) + "/scenes/outdoor.json";
  const test_support::CliResult run = test_support::run_cli("scene " + scene + " --out " + (dir / "a").string() + " --quiet");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const nlohmann::json report = nlohmann::json::parse(std::ifstream(dir / "a" / "report.json"));
  int dynamic = 0, moved = 0;
  for (const nlohmann::json& prop : report["props"]) {
    if (!prop.contains("dynamic")) continue;
    ++dynamic;
    moved += prop["dynamic"]["path_length_m"].get<double>() > 0.05;
    EXPECT_LT(prop["dynamic"]["deepest_penetration_m"].get<double>(), 0.01) << prop.dump();
  }
  EXPECT_EQ(dynamic, 12);
  EXPECT_GE(moved, 6);  // five lie on the walkers' paths, the forces kick the others at 0.3 a second
  EXPECT_GT(report["timings_s"]["physics"].get<double>(), 0.0);

  // The props' tracked points move in the files (the field, prop 0, stays).
  const io::NpzReader npz((dir / "a" / "outdoor_wide" / "anno.npz").string());
  const std::vector<float> trajs = npz.load("trajs_3d").to_float();
  const std::vector<std::int64_t> owner = npz.load("point_actor_ids").to_int64();
  const std::size_t n = owner.size(), last = trajs.size() / (3 * n) - 1;
  double field = 0, props = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (owner[i] >= 0) continue;
    const double travel = (Eigen::Vector3f::Map(&trajs[(last * n + i) * 3]) - Eigen::Vector3f::Map(&trajs[i * 3])).norm();
    double& most = owner[i] == -1 ? field : props;
    most = std::max(most, travel);
  }
  EXPECT_EQ(field, 0.0);
  EXPECT_GT(props, 0.3);

  // The sequences name every instance, the scattered props included, and their masks show them.
  const nlohmann::json info = nlohmann::json::parse(std::ifstream(dir / "a" / "outdoor_wide" / "scene_info.json"));
  const std::size_t actors = report["actors"].size();
  ASSERT_EQ(info["instances"].size(), actors + report["props"].size());
  std::set<int> seen;
  for (const char* frame : {"00000", "00045", "00089"}) {
    const fs::path mask = dir / "a" / "outdoor_wide" / "masks" / (std::string("mask_") + frame + ".png");
    ASSERT_TRUE(fs::exists(mask)) << mask;
    for (const std::uint8_t id : gray_pixels(mask)) seen.insert(id);
  }
  const int scattered = static_cast<int>(std::count_if(seen.begin(), seen.end(), [&](int id) { return id > static_cast<int>(actors) + 1; }));
  EXPECT_GE(scattered, 6) << "instance ids of scattered props in the wide camera's masks";

  const test_support::CliResult again = test_support::run_cli("scene " + scene + " --out " + (dir / "b").string() + " --quiet");
  ASSERT_EQ(again.exit_code, 0) << again.output;
  for (const char* name : {"outdoor_wide/anno.npz", "outdoor_orbit/anno.npz", "outdoor_video/anno.npz",
                           "outdoor_wide/masks/mask_00060.png", "outdoor_orbit/depths/depth_00060.png", "scene.glb"}) {
    EXPECT_TRUE(bytes_of(dir / "a" / name) == bytes_of(dir / "b" / name)) << name;
  }
}

}  // namespace
}  // namespace odyssey
