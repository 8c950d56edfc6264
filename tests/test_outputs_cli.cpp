// Outputs never replace what is not a regular file (issue: a device node given as --out became a
// regular file): a FIFO, a device node, a folder where a file goes and a file where a sequence
// folder goes are refused before any work, named with what they are, and left as they were.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "cli_runner.h"
#include "mocap_io/input_error.h"
#include "mocap_io/output_file.h"
#include "test_support.h"

namespace odyssey {
namespace {

namespace fs = std::filesystem;
using test_support::contains;

const std::string kData = ODYSSEY_DATA_DIR;
const std::string kRetarget = "retarget --motion " + kData + "/mocap/cmu_walk_cgspeed.bvh --character " + kData +
                              "/characters/RiggedFigure.glb";

TEST(OutputPathsTest, OnlyRegularFilesAndFoldersAreReplaced) {
  const fs::path dir = test_support::scratch_dir("outputs");
  std::ofstream(dir / "file") << "x";
  fs::create_directory(dir / "folder");
  ASSERT_EQ(::mkfifo((dir / "fifo").c_str(), 0644), 0);
  EXPECT_NO_THROW(io::require_replaceable_output((dir / "file").string()));
  EXPECT_NO_THROW(io::require_replaceable_output((dir / "missing").string()));
  EXPECT_NO_THROW(io::require_replaceable_output((dir / "folder").string(), true));
  const auto refused = [](const fs::path& path, bool folder) {
    return test_support::message_of<io::InputError>([&] { io::require_replaceable_output(path.string(), folder); });
  };
  EXPECT_TRUE(contains(refused(dir / "fifo", false), "exists and is a FIFO, not a regular file"));
  EXPECT_TRUE(contains(refused(dir / "folder", false), "exists and is a folder, not a regular file"));
  EXPECT_TRUE(contains(refused(dir / "file", true), "exists and is a file, not a folder"));
  io::StagedOutputs staged;
  EXPECT_THROW(staged.stage((dir / "fifo").string()), io::InputError);
}

TEST(OutputPathsCliTest, AFifoADeviceOrAFolderAsOutIsRefusedAndKept) {
  const fs::path dir = test_support::scratch_dir("outputs_cli");
  const fs::path fifo = dir / "out.glb";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0644), 0);
  test_support::CliResult run = test_support::run_cli(kRetarget + " --out " + fifo.string());
  EXPECT_NE(run.exit_code, 0);
  EXPECT_TRUE(contains(run.output, fifo.string() + ": exists and is a FIFO, not a regular file")) << run.output;
  EXPECT_TRUE(fs::is_fifo(fifo));

  fs::create_directory(dir / "report.json");
  run = test_support::run_cli(kRetarget + " --out " + (dir / "a.glb").string() + " --report " + (dir / "report.json").string());
  EXPECT_NE(run.exit_code, 0);
  EXPECT_TRUE(contains(run.output, "exists and is a folder, not a regular file")) << run.output;
  EXPECT_FALSE(fs::exists(dir / "a.glb")) << "no partial output";

  // A device node of our own (the null device's numbers), where this process may make one.
  const fs::path device = dir / "null";
  if (::mknod(device.c_str(), S_IFCHR | 0666, makedev(1, 3)) == 0) {
    run = test_support::run_cli(kRetarget + " --out " + device.string());
    EXPECT_NE(run.exit_code, 0);
    EXPECT_TRUE(contains(run.output, "exists and is a device, not a regular file")) << run.output;
    EXPECT_TRUE(fs::is_character_file(device));
  }
  for (const auto& entry : fs::directory_iterator(dir)) {
    EXPECT_FALSE(contains(entry.path().filename().string(), ".partial-")) << "left behind: " << entry.path();
  }
}

TEST(OutputPathsCliTest, AnOutputThatIsAnInputIsRefusedAndTheInputKept) {
  const fs::path dir = test_support::scratch_dir("outputs_cli");
  const fs::path motion = dir / "walk.bvh", character = dir / "figure.glb";
  fs::copy_file(kData + "/mocap/cmu_walk_cgspeed.bvh", motion);
  fs::copy_file(kData + "/characters/RiggedFigure.glb", character);
  const auto size = fs::file_size(motion);
  const std::string inputs = "retarget --motion " + motion.string() + " --character " + character.string();

  test_support::CliResult run = test_support::run_cli(inputs + " --out " + (dir / "out.glb").string() + " --report " + motion.string());
  EXPECT_NE(run.exit_code, 0);
  EXPECT_TRUE(contains(run.output, motion.string() + ": is also an input of this run (" + motion.string() + ")")) << run.output;
  EXPECT_EQ(fs::file_size(motion), size);
  EXPECT_FALSE(fs::exists(dir / "out.glb"));

  // The same file by another spelling, and through a link.
  fs::create_symlink(character, dir / "link.glb");
  run = test_support::run_cli(inputs + " --out " + (dir / "link.glb").string());
  EXPECT_NE(run.exit_code, 0);
  EXPECT_TRUE(contains(run.output, "is also an input of this run")) << run.output;
  run = test_support::run_cli(inputs + " --out " + (dir / "." / "figure.glb").string());
  EXPECT_NE(run.exit_code, 0);
  EXPECT_TRUE(contains(run.output, "is also an input of this run")) << run.output;
  EXPECT_TRUE(fs::is_symlink(dir / "link.glb"));

  // A scene whose report would land on the scene file itself.
  fs::create_directories(dir / "out");
  std::ofstream(dir / "out" / "report.json") << R"({"version": 1, "actors": [{"motion": ")" << motion.string()
                                              << R"(", "character": ")" << character.string() << R"("}], "cameras": [{"type": "orbit"}]})";
  const auto scene_size = fs::file_size(dir / "out" / "report.json");
  run = test_support::run_cli("scene " + (dir / "out" / "report.json").string() + " --out " + (dir / "out").string());
  EXPECT_NE(run.exit_code, 0);
  EXPECT_TRUE(contains(run.output, "report.json: is also an input of this run")) << run.output;
  EXPECT_EQ(fs::file_size(dir / "out" / "report.json"), scene_size);
}

}  // namespace
}  // namespace odyssey
