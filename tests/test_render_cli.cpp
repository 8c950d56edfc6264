// `odyssey render` on bad input, without needing Blender: a folder that is not a sequence (none,
// no scene_info.json, no anno.npz), a shot written without scene.glb, bad --frames, --samples and
// --scale, Blender missing ($ODYSSEY_BLENDER naming nothing, no blender on PATH), and a Blender
// that fails or writes nothing (a stand-in script as $ODYSSEY_BLENDER). Each fails with one line
// naming the path and the problem and leaves no rgbs/ and no temporary folder behind.
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "cli_runner.h"
#include "test_support.h"

namespace odyssey {
namespace {

namespace fs = std::filesystem;
using test_support::contains;

const std::string kData = ODYSSEY_DATA_DIR;

// One walker, a ground and a static camera, 10 frames: a sequence folder in a few tenths of a second.
std::string tiny_scene(bool glb) {
  return R"({"version": 1, "name": "tiny", "seconds": 0.3, "seed": 1,
  "actors": [{"name": "walker", "motion": ")" + kData + R"(/mocap/cmu_walk_cgspeed.bvh", "bvh_units": "cmu",
     "character": ")" + kData + R"(/characters/CesiumMan.glb", "quality": "fast"}],
  "props": [{"type": "ground", "name": "floor", "size": [6, 6]}],
  "cameras": [{"type": "static", "name": "front", "position": [0, -4, 1.5], "target": [0, 0, 0.9], "width": 64, "height": 36}],
  "outputs": {"points_per_actor": 50, "masks": true, "glb": )" + std::string(glb ? "true" : "false") + "}}";
}

fs::path make_sequence(const fs::path& dir, bool glb) {
  std::ofstream(dir / "tiny.json") << tiny_scene(glb);
  const test_support::CliResult run =
      test_support::run_cli("scene " + (dir / "tiny.json").string() + " --out " + (dir / "out").string() + " --layout pointodyssey --quiet");
  EXPECT_EQ(run.exit_code, 0) << run.output;
  return dir / "out" / "tiny_front";
}

std::size_t lines_in(const std::string& text) { return std::count(text.begin(), text.end(), '\n'); }

// Nothing of a render in the sequence folder: no rgbs/, no staged temporary.
void expect_no_render(const fs::path& seq) {
  EXPECT_FALSE(fs::exists(seq / "rgbs"));
  for (const auto& entry : fs::directory_iterator(seq)) {
    EXPECT_FALSE(contains(entry.path().filename().string(), "partial")) << "left behind: " << entry.path();
  }
}

// A stand-in Blender: a shell script with `body`.
fs::path fake_blender(const fs::path& dir, const std::string& body) {
  const fs::path path = dir / "fake-blender";
  std::ofstream(path) << "#!/bin/sh\n" << body << "\n";
  fs::permissions(path, fs::perms::owner_all);
  return path;
}

class ScopedEnv {
 public:
  ScopedEnv(const char* name, const std::string& value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    ::setenv(name, value.c_str(), 1);
  }
  ~ScopedEnv() { old_.empty() ? ::unsetenv(name_) : ::setenv(name_, old_.c_str(), 1); }

 private:
  const char* name_;
  std::string old_;
};

TEST(RenderCliTest, FoldersThatAreNotSequencesAreRefusedByName) {
  const fs::path dir = test_support::scratch_dir("render_cli");
  const test_support::CliResult none = test_support::run_cli("render " + (dir / "nowhere").string());
  EXPECT_EQ(none.exit_code, 1);
  EXPECT_TRUE(contains(none.output, (dir / "nowhere").string() + ": no such folder")) << none.output;
  EXPECT_EQ(lines_in(none.output), 1u) << none.output;

  fs::create_directories(dir / "empty");
  const test_support::CliResult empty = test_support::run_cli("render " + (dir / "empty").string());
  EXPECT_EQ(empty.exit_code, 1);
  EXPECT_TRUE(contains(empty.output, (dir / "empty" / "scene_info.json").string() + ": missing: not a sequence folder"))
      << empty.output;
  EXPECT_EQ(lines_in(empty.output), 1u) << empty.output;

  const fs::path seq = make_sequence(dir, true);
  fs::rename(seq / "anno.npz", dir / "anno.npz");
  const test_support::CliResult no_anno = test_support::run_cli("render " + seq.string());
  EXPECT_EQ(no_anno.exit_code, 1);
  EXPECT_TRUE(contains(no_anno.output, (seq / "anno.npz").string() + ": missing: not a sequence folder")) << no_anno.output;
  expect_no_render(seq);
}

TEST(RenderCliTest, AShotWithoutSceneGlbSaysToAskForIt) {
  const fs::path dir = test_support::scratch_dir("render_cli");
  const fs::path seq = make_sequence(dir, false);
  const test_support::CliResult run = test_support::run_cli("render " + seq.string());
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_TRUE(contains(run.output, (dir / "out" / "scene.glb").string() + ": missing:")) << run.output;
  EXPECT_TRUE(contains(run.output, "\"glb\": true")) << run.output;
  EXPECT_EQ(lines_in(run.output), 1u) << run.output;
  expect_no_render(seq);
}

TEST(RenderCliTest, BadFramesSamplesAndScaleAreUsageErrors) {
  const fs::path dir = test_support::scratch_dir("render_cli");
  const fs::path seq = make_sequence(dir, true);
  for (const std::string frames : {"5:2", "0:11", "x", "3:3", "-1:4", "", "2:4:6", "10", "1.5:3"}) {
    const test_support::CliResult run = test_support::run_cli("render " + seq.string() + " --frames '" + frames + "'");
    EXPECT_EQ(run.exit_code, 2) << frames << ": " << run.output;
    EXPECT_TRUE(contains(run.output, "--frames expects A:B") && contains(run.output, "<= 10, got '" + frames + "'"))
        << frames << ": " << run.output;
    EXPECT_EQ(lines_in(run.output), 1u) << run.output;
  }
  const test_support::CliResult samples = test_support::run_cli("render " + seq.string() + " --samples 0");
  EXPECT_EQ(samples.exit_code, 2);
  EXPECT_TRUE(contains(samples.output, "--samples must be between 1 and")) << samples.output;
  const test_support::CliResult scale = test_support::run_cli("render " + seq.string() + " --scale 0.001");
  EXPECT_EQ(scale.exit_code, 2);
  EXPECT_TRUE(contains(scale.output, "--scale makes the image smaller than one pixel")) << scale.output;
  expect_no_render(seq);
}

TEST(RenderCliTest, MissingBlenderIsNamed) {
  const fs::path dir = test_support::scratch_dir("render_cli");
  const fs::path seq = make_sequence(dir, true);
  {
    const ScopedEnv blender("ODYSSEY_BLENDER", (dir / "no-blender-here").string());
    const test_support::CliResult run = test_support::run_cli("render " + seq.string());
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_TRUE(contains(run.output, (dir / "no-blender-here").string() + ": ODYSSEY_BLENDER names no executable file"))
        << run.output;
    EXPECT_EQ(lines_in(run.output), 1u) << run.output;
  }
  {
    const ScopedEnv blender("ODYSSEY_BLENDER", "");
    const ScopedEnv path("PATH", (dir / "empty-bin").string());
    const test_support::CliResult run = test_support::run_cli("render " + seq.string());
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_TRUE(contains(run.output, "blender: not found on PATH")) << run.output;
  }
  expect_no_render(seq);
}

TEST(RenderCliTest, AFailingBlenderShowsItsLastErrorLineAndLeavesNoFrames) {
  const fs::path dir = test_support::scratch_dir("render_cli");
  const fs::path seq = make_sequence(dir, true);
  {
    // A Blender that writes a frame, then fails: the frame must not appear.
    const ScopedEnv blender("ODYSSEY_BLENDER", fake_blender(dir, R"(out=""; while [ $# -gt 0 ]; do [ "$1" = --out ] && out="$2"; shift; done
echo "Fra:1 Mem:12M | Syncing"; printf 'JPEG' > "$out/rgb_00000.jpg"
echo "Error: Cannot read file 'scene.glb': not a glTF" >&2; echo "Blender quit"; exit 3)")
                                                   .string());
    const test_support::CliResult run = test_support::run_cli("render " + seq.string() + " --frames 0:2");
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_TRUE(contains(run.output, seq.string() + ": Blender (")) << run.output;
    EXPECT_TRUE(contains(run.output, "failed (exit status 3): Error: Cannot read file 'scene.glb': not a glTF")) << run.output;
    EXPECT_EQ(lines_in(run.output), 2u) << "the plan line and the error: " << run.output;
    expect_no_render(seq);
  }
  {
    // One that exits 0 without writing every frame.
    const ScopedEnv blender("ODYSSEY_BLENDER", fake_blender(dir, "echo render_sequence: frame 0; exit 0").string());
    const test_support::CliResult run = test_support::run_cli("render " + seq.string() + " --frames 0:2");
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_TRUE(contains(run.output, seq.string() + ": Blender exited without writing rgb_00000.jpg")) << run.output;
    expect_no_render(seq);
  }
}

}  // namespace
}  // namespace odyssey
