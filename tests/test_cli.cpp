// End-to-end: the odyssey command on real and generated files, checked from the outside
// (exit codes, messages, files on disk, and numpy reading what was written).
#include <gtest/gtest.h>

#include "cli_runner.h"

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "mocap_io/npy.h"
#include "test_support.h"

namespace {

namespace fs = std::filesystem;

using Result = odyssey::test_support::CliResult;
const auto run = odyssey::test_support::run_cli;

fs::path scratch(const std::string& name) {
  const fs::path dir = odyssey::test_support::scratch_root() / "cli";
  fs::create_directories(dir);
  return dir / name;
}

const std::string kShared = ODYSSEY_SHARED_DIR;

class CliTest : public ::testing::Test {
 protected:
  // One synthetic body and walk for the whole suite: generating them is the slow part.
  static void SetUpTestSuite() {
    body_ = scratch("body.npz").string();
    walk_ = scratch("walk.npz").string();
    const Result demo = run("demo --out " + scratch("demo").string() + " --seconds 1");
    ASSERT_EQ(demo.exit_code, 0) << demo.output;
    fs::copy_file(scratch("demo") / "body.npz", body_, fs::copy_options::overwrite_existing);
    fs::copy_file(scratch("demo") / "walk_smplx.npz", walk_, fs::copy_options::overwrite_existing);
  }
  static std::string body_, walk_;
};
std::string CliTest::body_, CliTest::walk_;

TEST_F(CliTest, EveryCommandHasHelp) {
  for (const char* command : {"demo", "inspect", "pose", "make-body"}) {
    const Result result = run(std::string(command) + " --help");
    EXPECT_EQ(result.exit_code, 0) << command;
    EXPECT_NE(result.output.find("usage: odyssey " + std::string(command)), std::string::npos) << result.output;
  }
  EXPECT_EQ(run("--help").exit_code, 0);
  EXPECT_EQ(run("no-such-command").exit_code, 2);
  EXPECT_EQ(run("pose --no-such-option").exit_code, 2);
}

TEST_F(CliTest, InspectReadsTheSharedBvhFiles) {
  const Result walk = run("inspect " + kShared + "/assets/mocap/cmu_walk_cgspeed.bvh --bvh-units cmu");
  ASSERT_EQ(walk.exit_code, 0) << walk.output;
  EXPECT_NE(walk.output.find("frames: 344"), std::string::npos) << walk.output;
  EXPECT_NE(walk.output.find("fps: 120"), std::string::npos) << walk.output;
  EXPECT_NE(walk.output.find("joints: 31"), std::string::npos) << walk.output;
  EXPECT_NE(walk.output.find("LeftUpLeg"), std::string::npos) << walk.output;
  const Result jump = run("inspect " + kShared + "/assets/mocap/cmu_jump_cgspeed.bvh");
  ASSERT_EQ(jump.exit_code, 0) << jump.output;
  EXPECT_NE(jump.output.find("frames: 2752"), std::string::npos) << jump.output;
}

TEST_F(CliTest, InspectReadsAmassAndBodyModel) {
  const Result walk = run("inspect " + walk_);
  ASSERT_EQ(walk.exit_code, 0) << walk.output;
  EXPECT_NE(walk.output.find("AMASS SMPL-X"), std::string::npos) << walk.output;
  EXPECT_NE(walk.output.find("frames: 31"), std::string::npos) << walk.output;
  const Result body = run("inspect " + body_);
  ASSERT_EQ(body.exit_code, 0) << body.output;
  EXPECT_NE(body.output.find("vertices: 10475"), std::string::npos) << body.output;
  EXPECT_NE(body.output.find("faces: 20908"), std::string::npos) << body.output;
  EXPECT_NE(body.output.find("right_thumb3"), std::string::npos) << body.output;
}

TEST_F(CliTest, PoseWritesJointsAndVerticesThatNumpyReads) {
  const std::string out = scratch("posed.npz").string();
  const Result result = run("pose --model " + body_ + " --motion " + walk_ + " --out " + out + " --fps 60");
  ASSERT_EQ(result.exit_code, 0) << result.output;
  const odyssey::io::NpzReader archive(out);
  // 1 s at 30 fps is 31 frames; resampled to 60 fps over the same duration, 61.
  EXPECT_EQ(archive.header("joints").shape, (std::vector<std::size_t>{61, 55, 3}));
  EXPECT_EQ(archive.header("vertices").shape, (std::vector<std::size_t>{61, 10475, 3}));
  EXPECT_EQ(archive.header("vertices").dtype, odyssey::io::DType::Float32);
  if (std::string(ODYSSEY_PYTHON).empty()) GTEST_SKIP() << "no python3 with numpy";
  const std::string script = scratch("check_posed.py").string();
  std::ofstream(script) << "import sys, numpy as np\n"
                           "d = np.load(sys.argv[1])\n"
                           "j, v = d['joints'], d['vertices']\n"
                           "assert j.dtype == np.float32 and v.dtype == np.float32\n"
                           "assert j.shape == (61, 55, 3) and v.shape == (61, 10475, 3)\n"
                           "assert np.isfinite(v).all()\n"
                           "assert float(d['fps']) == 60.0\n"
                           "assert list(d['joint_names'][:2]) == ['pelvis', 'left_hip']\n"
                           "h = v[0, :, 2].max() - v[0, :, 2].min()\n"
                           "assert 1.4 < h < 1.9, h\n";
  EXPECT_EQ(std::system((std::string(ODYSSEY_PYTHON) + " " + script + " " + out).c_str()), 0);
}

TEST_F(CliTest, PoseOfBvhWritesWorldJointsInMetres) {
  const std::string out = scratch("bvh_joints.npz").string();
  const Result result =
      run("pose --motion " + kShared + "/assets/mocap/cmu_walk_cgspeed.bvh --bvh-units cmu --out " + out);
  ASSERT_EQ(result.exit_code, 0) << result.output;
  const odyssey::io::NpzReader archive(out);
  EXPECT_EQ(archive.header("joints").shape, (std::vector<std::size_t>{344, 31, 3}));
  const std::vector<float> joints = archive.load("joints").to_float();
  // A walking adult: the head is 1.4-1.9 m above the lowest foot on the first frame.
  float low = 1e9f, high = -1e9f;
  for (int j = 0; j < 31; ++j) {
    low = std::min(low, joints[j * 3 + 2]);
    high = std::max(high, joints[j * 3 + 2]);
  }
  EXPECT_GT(high - low, 1.3f);
  EXPECT_LT(high - low, 1.9f);
}

TEST_F(CliTest, BadInputFailsWithOneLineAndNoOutputFile) {
  const fs::path truncated = scratch("truncated.bvh");
  {
    std::ifstream in(kShared + "/assets/mocap/cmu_walk_cgspeed.bvh");
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(truncated) << text.substr(0, text.size() / 2);
  }
  const fs::path out = scratch("should_not_exist.npz");
  fs::remove(out);
  const Result bvh = run("pose --motion " + truncated.string() + " --out " + out.string());
  EXPECT_EQ(bvh.exit_code, 1) << bvh.output;
  EXPECT_NE(bvh.output.find(truncated.string()), std::string::npos) << bvh.output;
  EXPECT_FALSE(fs::exists(out));

  const fs::path not_npz = scratch("not_a_zip.npz");
  std::ofstream(not_npz) << "this is not a zip archive";
  const Result npz = run("pose --model " + body_ + " --motion " + not_npz.string() + " --out " + out.string());
  EXPECT_EQ(npz.exit_code, 1) << npz.output;
  EXPECT_NE(npz.output.find(not_npz.string()), std::string::npos) << npz.output;
  EXPECT_FALSE(fs::exists(out));

  const Result missing = run("inspect " + scratch("missing.npz").string());
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_NE(missing.output.find("no such file"), std::string::npos) << missing.output;
  for (const fs::directory_entry& entry : fs::directory_iterator(scratch(""))) {
    EXPECT_EQ(entry.path().string().find(".partial"), std::string::npos) << "partial file left: " << entry.path();
  }
}

}  // namespace
