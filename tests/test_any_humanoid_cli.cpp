// Any humanoid end to end: `odyssey inspect` says where a character's rest pose comes from, and
// `odyssey retarget` takes a character whose nodes hold another pose than its bind pose, a BVH
// whose rest pose lies along +x, a DAZ-named BVH, and `--map auto-structure`, writing GLBs the
// Khronos validator accepts and reports that say what was done.
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
#include "gltf_validator.h"
#include "humanoid_bvh.h"
#include "mocap_io/gltf_character.h"
#include "posed_characters.h"
#include "test_support.h"

namespace odyssey {
namespace {

namespace fs = std::filesystem;
using namespace test_support::humanoid_bvh;
using test_support::contains;
using test_support::run_cli;

const std::string kWalk = std::string(ODYSSEY_SHARED_DIR) + "/assets/mocap/cmu_walk_cgspeed.bvh";

fs::path scratch(const std::string& name) { return test_support::scratch_dir("any_humanoid_cli") / name; }

nlohmann::json read_json(const fs::path& path) { return nlohmann::json::parse(std::ifstream(path)); }

// The Khronos validator finds no error in `file` (skipped with a note where it is not installed).
void expect_valid_gltf(const fs::path& file) {
  if (const std::string missing = test_support::validator_missing(); !missing.empty()) {
    std::printf("not validated (%s): %s\n", missing.c_str(), file.c_str());
    return;
  }
  const fs::path log = fs::path(file).replace_extension(".validator.txt");
  const int status = std::system(("node '" + (test_support::validator_dir() / "validate.mjs").string() + "' '" + file.string() +
                                  "' > '" + log.string() + "' 2>&1")
                                     .c_str());
  std::ifstream in(log);
  const std::string report((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << report;
  EXPECT_TRUE(contains(report, ": 0 errors,")) << report;
}

// Retargets and returns the report; the GLB must be written and valid.
nlohmann::json retarget(const std::string& motion, const std::string& character, const std::string& stem,
                        const std::string& extra = {}) {
  const fs::path out = scratch(stem + ".glb"), report = scratch(stem + ".json");
  const test_support::CliResult result = run_cli("retarget --motion '" + motion + "' --character '" + character +
                                                 "' --out '" + out.string() + "' --report '" + report.string() + "' " + extra);
  EXPECT_EQ(result.exit_code, 0) << result.output;
  if (result.exit_code != 0) return {};
  EXPECT_TRUE(fs::exists(out));
  expect_valid_gltf(out);
  return read_json(report);
}

TEST(AnyHumanoidCliTest, InspectSaysWhereTheRestPoseComesFrom) {
  const std::string original = test_support::kSharedCharacters + "RiggedFigure.glb";
  const std::string posed = test_support::posed_copy("RiggedFigure.glb").string();
  const test_support::CliResult a = run_cli("inspect '" + original + "'");
  const test_support::CliResult b = run_cli("inspect '" + posed + "'");
  ASSERT_EQ(a.exit_code, 0) << a.output;
  ASSERT_EQ(b.exit_code, 0) << b.output;
  EXPECT_TRUE(contains(a.output, "rest pose from: node transforms")) << a.output;
  EXPECT_TRUE(contains(b.output, "rest pose from: inverse bind matrices (the node transforms hold another pose")) << b.output;
  const auto height_line = [](const std::string& out) { return out.substr(out.find("rest height: "), 40); };
  EXPECT_EQ(height_line(a.output).substr(0, 22), height_line(b.output).substr(0, 22));
  EXPECT_TRUE(contains(b.output, "bone map: preset rigged_figure")) << b.output;
}

TEST(AnyHumanoidCliTest, RetargetsThePosedCharacterTheLyingBvhAndADazBvh) {
  const nlohmann::json posed = retarget(kWalk, test_support::posed_copy("CesiumMan.glb").string(), "posed_cesium");
  const nlohmann::json original = retarget(kWalk, test_support::kSharedCharacters + "CesiumMan.glb", "cesium");
  ASSERT_FALSE(posed.is_null());
  ASSERT_FALSE(original.is_null());
  EXPECT_NEAR(posed["scale"].get<double>(), original["scale"].get<double>(), 1e-6);

  const std::vector<BvhJoint> joints = humanoid(plain_names());
  const std::string lying = write_bvh("cli_lying.bvh", joints, walk_frames(joints, 60), RestKind::along_x, true);
  const nlohmann::json lying_report = retarget(lying, test_support::kSharedCharacters + "CesiumMan.glb", "lying");
  ASSERT_FALSE(lying_report.is_null());
  EXPECT_EQ(lying_report["inputs"]["bvh_units"]["measured_on"], "first frame");
  EXPECT_TRUE(contains(lying_report["inputs"]["bvh_units"]["description"].get<std::string>(),
                       "the rest pose does not stand up, so the first frame is the rest pose"))
      << lying_report["inputs"]["bvh_units"];

  std::map<std::string, std::string> daz = {{"pelvis", "hip"}, {"spine1", "abdomen"}, {"spine3", "chest"}, {"neck", "neck"},
                                            {"head", "head"}};
  for (const auto& [side, s] : {std::pair("left_", "l"), std::pair("right_", "r")}) {
    for (const auto& [role, word] : {std::pair("collar", "Collar"), std::pair("shoulder", "Shldr"), std::pair("elbow", "ForeArm"),
                                     std::pair("wrist", "Hand"), std::pair("hip", "Thigh"), std::pair("knee", "Shin"),
                                     std::pair("ankle", "Foot")}) {
      daz[std::string(side) + role] = std::string(s) + word;
    }
  }
  const std::vector<BvhJoint> daz_joints = humanoid(daz);
  const std::string daz_bvh = write_bvh("cli_daz.bvh", daz_joints, walk_frames(daz_joints, 60), RestKind::standing, false);
  const nlohmann::json daz_report = retarget(daz_bvh, test_support::kSharedCharacters + "CesiumMan.glb", "daz");
  ASSERT_FALSE(daz_report.is_null());
  EXPECT_EQ(daz_report["source"]["map"], "preset poser_bvh") << daz_report["source"];
}

TEST(AnyHumanoidCliTest, MapAutoStructure) {
  const nlohmann::json report =
      retarget(kWalk, test_support::kSharedCharacters + "CesiumMan.glb", "structure", "--map auto-structure");
  ASSERT_FALSE(report.is_null());
  EXPECT_EQ(report["target"]["map"], "skeleton structure") << report["target"];
}

// The keyword works where maps are given as files too: a scene's actor and a batch manifest's row
// (whose map column is hashed as a file unless it is a keyword).
TEST(AnyHumanoidCliTest, MapAutoStructureInASceneAndAManifest) {
  const std::string character = test_support::kSharedCharacters + "CesiumMan.glb";
  const fs::path dir = test_support::scratch_dir("any_humanoid_cli");  // taken once: each call empties it
  const fs::path scene = dir / "structure_scene.json";
  std::ofstream(scene) << R"({"version": 1, "fps": 30, "seconds": 1,
    "actors": [{"name": "a", "motion": ")" << kWalk << R"(", "bvh_units": "cmu", "character": ")" << character
                       << R"(", "quality": "fast", "map": "auto-structure"}],
    "cameras": [{"name": "wide", "type": "static", "position": [0, -6, 1.5], "target": [0, 0, 0.8]}],
    "outputs": {"report": true}})";
  const test_support::CliResult run = run_cli("scene '" + scene.string() + "' --out '" + (dir / "structure_scene").string() + "'");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const nlohmann::json report = read_json((dir / "structure_scene") / "report.json");
  EXPECT_EQ(report["actors"][0]["retarget"]["target"]["map"], "skeleton structure") << report["actors"][0];

  const fs::path manifest = dir / "structure_jobs.csv";
  std::ofstream(manifest) << "motion,character,map\n" << kWalk << "," << character << ",auto-structure\n";
  const test_support::CliResult batch =
      run_cli("batch --manifest '" + manifest.string() + "' --out '" + (dir / "structure_batch").string() + "' --quality fast");
  ASSERT_EQ(batch.exit_code, 0) << batch.output;
  const nlohmann::json jobs = read_json((dir / "structure_batch") / "report.json")["jobs"];
  ASSERT_EQ(jobs.size(), 1u) << jobs;
  EXPECT_EQ(jobs[0]["status"], "done") << jobs[0];
}

}  // namespace
}  // namespace odyssey
