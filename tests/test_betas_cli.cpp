// --betas on the commands that take --model (pose, retarget; trajectories and point-cache share
// retarget's options), end to end: AMASS-style walks of 10, 16 and 300 betas on SMPL-X model
// files of 10 (10 + 10 expression) and 300 (300 + 100) shape directions. The default drops
// extras with a warning naming the file, the count and the largest magnitude, and pads missing
// betas with zeros (the posed result equals that of explicit zeros); `error` exits 1 naming both
// counts and the file, and writes nothing. The library side is tests/test_betas.cpp.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli_runner.h"
#include "mocap_io/amass.h"
#include "mocap_io/body_model_writer.h"
#include "mocap_io/npy.h"
#include "skeleton/body_sequence.h"
#include "synthetic/synthetic_body.h"
#include "synthetic/synthetic_walk.h"
#include "test_support.h"

namespace odyssey {
namespace {

namespace fs = std::filesystem;
using test_support::contains;
using test_support::run_cli;

const std::string kCesiumMan = std::string(ODYSSEY_SHARED_DIR) + "/assets/characters/CesiumMan.glb";
const std::string kWalkBvh = std::string(ODYSSEY_SHARED_DIR) + "/assets/mocap/cmu_walk_cgspeed.bvh";

fs::path scratch(const std::string& name) {
  const fs::path dir = test_support::scratch_root() / "betas_cli";
  fs::create_directories(dir);
  return dir / name;
}

// n betas, 0.1-ish values, with -2.5 at index 12 when n > 12.
std::vector<double> betas_of(int n) {
  std::vector<double> betas(n);
  for (int i = 0; i < n; ++i) betas[i] = 0.05 * ((i * 7) % 11) - 0.25;
  if (n > 12) betas[12] = -2.5;
  return betas;
}

std::string walk_with(const std::string& name, const std::vector<double>& betas) {
  const fs::path path = scratch(name + ".npz");
  if (!fs::exists(path)) {
    BodySequence walk = synthetic_walk(12, 30, BodyModelKind::SMPLX, 5);
    walk.betas = betas;
    io::write_amass(path.string(), walk);
  }
  return path.string();
}
std::string walk_file(int n) { return walk_with("walk_" + std::to_string(n), betas_of(n)); }

// The synthetic model (300 shape + 100 expression directions), and its first 10 of each.
std::string model_file(int shape) {
  const fs::path path = scratch("model" + std::to_string(shape) + ".npz");
  if (!fs::exists(path)) {
    SyntheticBody body = make_synthetic_body(0);
    if (shape == 10) {
      BodyModel& model = body.model;
      RowMatrixXd shapedirs(model.shapedirs.rows(), 20);
      shapedirs.leftCols(10) = model.shapedirs.leftCols(10);
      shapedirs.rightCols(10) = model.shapedirs.middleCols(model.shape_count, 10);
      model.shapedirs = std::move(shapedirs);
      model.shape_count = model.expression_count = 10;
      io::write_body_model(path.string(), model);
    } else {
      io::write_body_model(path.string(), body);
    }
  }
  return path.string();
}

std::string read_text(const fs::path& path) {
  std::ifstream in(path);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

struct Posed {
  std::vector<double> joints, vertices;
};
Posed posed(const fs::path& out) {
  const io::NpzReader archive(out.string());
  return {archive.load("joints").to_double(), archive.load("vertices").to_double()};
}

test_support::CliResult pose(const std::string& motion, const std::string& model, const fs::path& out,
                             const std::string& extra = "") {
  return run_cli("pose --model " + model + " --motion " + motion + " --out " + out.string() + extra);
}

TEST(BetasCli, PoseDropsExtraBetasWithAWarning) {
  const fs::path ten = scratch("ten.npz");
  const auto reference = pose(walk_file(10), model_file(10), ten);
  ASSERT_EQ(reference.exit_code, 0) << reference.output;
  EXPECT_TRUE(contains(reference.output, "betas 10 in the sequence, 10 shape directions in the model, policy fit: dropped 0, padded 0"))
      << reference.output;
  EXPECT_FALSE(contains(reference.output, "warning")) << reference.output;
  for (int n : {16, 300}) {
    for (const std::string policy : {"", " --betas fit", " --betas truncate"}) {
      const fs::path out = scratch("dropped_" + std::to_string(n) + ".npz");
      const auto result = pose(walk_file(n), model_file(10), out, policy);
      ASSERT_EQ(result.exit_code, 0) << result.output;
      const std::string dropped = std::to_string(n - 10);
      EXPECT_TRUE(contains(result.output, "warning: " + walk_file(n) + ": dropped " + dropped +
                                              " betas beyond the model's 10 shape directions"))
          << result.output;
      EXPECT_TRUE(contains(result.output, "largest magnitude dropped 2.5")) << result.output;
      EXPECT_TRUE(contains(result.output, "dropped " + dropped + " (largest magnitude 2.5), padded 0")) << result.output;
      // Dropped, not read as expression: the body of the first 10 betas.
      const Posed a = posed(out), b = posed(ten);
      EXPECT_EQ(a.joints, b.joints);
      EXPECT_EQ(a.vertices, b.vertices);
    }
  }
}

TEST(BetasCli, PosePadsMissingBetasWithZeros) {
  std::vector<double> explicit_zeros = betas_of(10);
  explicit_zeros.resize(300, 0.0);
  const fs::path reference_out = scratch("explicit.npz");
  const auto reference = pose(walk_with("walk_10_zeros", explicit_zeros), model_file(300), reference_out, " --betas error");
  ASSERT_EQ(reference.exit_code, 0) << reference.output;
  for (const std::string policy : {"", " --betas pad"}) {
    const fs::path out = scratch("padded.npz");
    const auto result = pose(walk_file(10), model_file(300), out, policy);
    ASSERT_EQ(result.exit_code, 0) << result.output;
    EXPECT_TRUE(contains(result.output, "betas 10 in the sequence, 300 shape directions in the model")) << result.output;
    EXPECT_TRUE(contains(result.output, "dropped 0, padded 290")) << result.output;
    EXPECT_FALSE(contains(result.output, "warning")) << result.output;
    const Posed a = posed(out), b = posed(reference_out);
    EXPECT_EQ(a.joints, b.joints);
    EXPECT_EQ(a.vertices, b.vertices);
  }
  const auto sixteen = pose(walk_file(16), model_file(300), scratch("sixteen.npz"));
  ASSERT_EQ(sixteen.exit_code, 0) << sixteen.output;
  EXPECT_TRUE(contains(sixteen.output, "padded 284")) << sixteen.output;
}

TEST(BetasCli, PoseRefusesWhatThePolicyRefuses) {
  struct Case {
    int betas, directions;
    std::string policy;
  };
  for (const Case& c : {Case{16, 10, "error"}, Case{300, 10, "error"}, Case{10, 300, "error"}, Case{16, 300, "error"},
                        Case{16, 10, "pad"}, Case{10, 300, "truncate"}}) {
    const fs::path out = scratch("refused.npz");
    const auto result = pose(walk_file(c.betas), model_file(c.directions), out, " --betas " + c.policy);
    EXPECT_EQ(result.exit_code, 1) << result.output;
    EXPECT_TRUE(contains(result.output, walk_file(c.betas))) << result.output;
    EXPECT_TRUE(contains(result.output, model_file(c.directions))) << result.output;
    EXPECT_TRUE(contains(result.output, std::to_string(c.betas) + " betas in the sequence")) << result.output;
    EXPECT_TRUE(contains(result.output, std::to_string(c.directions) + " shape directions")) << result.output;
    EXPECT_TRUE(contains(result.output, "'" + c.policy + "'")) << result.output;
    EXPECT_FALSE(fs::exists(out)) << c.policy;
  }
  const auto bad = pose(walk_file(16), model_file(10), scratch("bad.npz"), " --betas clip");
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_TRUE(contains(bad.output, "--betas expects fit, truncate, pad or error, got 'clip'")) << bad.output;
}

TEST(BetasCli, RetargetOnAModelReportsAndRefuses) {
  const fs::path out = scratch("walk.glb"), report_path = scratch("walk.json");
  const auto result = run_cli("retarget --motion " + walk_file(16) + " --model " + model_file(10) + " --character " +
                              kCesiumMan + " --out " + out.string() + " --report " + report_path.string());
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_TRUE(contains(result.output, "warning: " + walk_file(16) + ": dropped 6 betas")) << result.output;
  EXPECT_TRUE(contains(result.output, "largest magnitude dropped 2.5")) << result.output;
  const nlohmann::json betas = nlohmann::json::parse(read_text(report_path))["inputs"]["betas"];
  EXPECT_EQ(betas["policy"], "fit");
  EXPECT_EQ(betas["file_count"], 16);
  EXPECT_EQ(betas["model_count"], 10);
  EXPECT_EQ(betas["dropped"], 6);
  EXPECT_DOUBLE_EQ(betas["largest_dropped_magnitude"].get<double>(), 2.5);
  EXPECT_EQ(betas["padded"], 0);

  const fs::path refused = scratch("refused.glb");
  const auto error = run_cli("retarget --motion " + walk_file(16) + " --model " + model_file(10) + " --betas error --character " +
                             kCesiumMan + " --out " + refused.string());
  EXPECT_EQ(error.exit_code, 1) << error.output;
  EXPECT_TRUE(contains(error.output, walk_file(16))) << error.output;
  EXPECT_TRUE(contains(error.output, "16 betas in the sequence, the model has 10 shape directions")) << error.output;
  EXPECT_FALSE(fs::exists(refused));

  const auto bvh = run_cli("retarget --motion " + kWalkBvh + " --betas pad --character " + kCesiumMan + " --out " +
                           scratch("bvh.glb").string());
  EXPECT_EQ(bvh.exit_code, 2) << bvh.output;
  EXPECT_TRUE(contains(bvh.output, "--betas is for AMASS sequences")) << bvh.output;
}

TEST(BetasCli, TrajectoriesAndPointCacheTakeTheOption) {
  const fs::path out = scratch("refused.pc2");
  const auto result = run_cli("point-cache --motion " + walk_file(300) + " --model " + model_file(10) +
                              " --betas pad --character " + kCesiumMan + " --out " + out.string());
  EXPECT_EQ(result.exit_code, 1) << result.output;
  EXPECT_TRUE(contains(result.output, "300 betas in the sequence, the model has 10 shape directions")) << result.output;
  EXPECT_FALSE(fs::exists(out));
  for (const char* command : {"trajectories", "point-cache"}) {
    const auto help = run_cli(std::string(command) + " --help");
    EXPECT_TRUE(contains(help.output, "--betas")) << help.output;
  }
}

}  // namespace
}  // namespace odyssey
