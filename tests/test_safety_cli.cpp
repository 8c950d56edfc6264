// Nothing lost, nothing left behind: a rerun that fails at its commit keeps the previous run's
// outputs byte for byte; SIGINT and SIGTERM remove everything a run staged and exit 130 / 143; what
// a SIGKILL left is swept by the next run into the same folder.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <thread>

#include "cli_runner.h"
#include "mocap_io/amass.h"
#include "mocap_io/input_error.h"
#include "mocap_io/output_file.h"
#include "synthetic/synthetic_walk.h"
#include "test_support.h"

namespace odyssey {
namespace {

namespace fs = std::filesystem;
using test_support::contains;

const std::string kData = ODYSSEY_DATA_DIR;

std::string read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// Every file under `dir` with its bytes, by path relative to `dir`.
std::map<std::string, std::string> snapshot(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    if (entry.is_regular_file()) files[fs::relative(entry.path(), dir).string()] = read_bytes(entry.path());
  }
  return files;
}

// Names under `dir` that a run stages or keeps aside while committing.
std::vector<std::string> staged_leftovers(const fs::path& dir) {
  std::vector<std::string> found;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (contains(name, ".partial-") || contains(name, ".previous-")) found.push_back(entry.path().string());
  }
  return found;
}

// The odyssey binary run in the background, its output in a log, so that a test can act on the
// file system or send a signal while it works.
class BackgroundCli {
 public:
  BackgroundCli(const std::string& arguments, const fs::path& log) : log_(log) {
    pid_ = ::fork();
    if (pid_ == 0) {
      const std::string command = "exec " + std::string(ODYSSEY_CLI) + " " + arguments + " > '" + log.string() + "' 2>&1";
      ::execl("/bin/sh", "sh", "-c", command.c_str(), static_cast<char*>(nullptr));
      ::_exit(127);
    }
  }
  ~BackgroundCli() {
    if (pid_ > 0 && !waited_) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
  }
  pid_t pid() const { return pid_; }
  // Exit code, or 128 + the signal that ended it.
  int wait() {
    int status = 0;
    ::waitpid(pid_, &status, 0);
    waited_ = true;
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }
  std::string output() const { return read_bytes(log_); }

 private:
  fs::path log_;
  pid_t pid_ = -1;
  bool waited_ = false;
};

// Waits (up to a minute) until a staged file of the run appears under `dir`: its outputs' checks
// are behind it and its sinks are open.
bool wait_for_staging(const fs::path& dir) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (std::chrono::steady_clock::now() < until) {
    std::error_code ignored;
    for (const auto& entry : fs::directory_iterator(dir, ignored)) {
      if (contains(entry.path().filename().string(), ".partial-")) return true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return false;
}

// Two walkers, a box and two cameras for `seconds`: a short one finishes in about a second, a
// long one streams its frames for several.
fs::path write_scene(const fs::path& dir, double seconds, int points) {
  const fs::path path = dir / "walkers.json";
  std::ofstream(path) << R"({"version": 1, "name": "walkers", "seconds": )" << seconds << R"(, "seed": 3,
  "actors": [
    {"name": "a", "motion": ")" << kData << R"(/mocap/cmu_walk_cgspeed.bvh", "bvh_units": "cmu", "quality": "fast",
     "character": ")" << kData << R"(/characters/RiggedFigure.glb", "placement": {"x": 0, "y": 0, "yaw": 90}},
    {"name": "b", "motion": ")" << kData << R"(/mocap/cmu_walk_cgspeed.bvh", "bvh_units": "cmu", "quality": "fast",
     "character": ")" << kData << R"(/characters/CesiumMan.glb", "placement": {"x": 0, "y": -1.5, "yaw": 90}}],
  "props": [{"type": "ground", "name": "floor", "size": [12, 12]},
            {"type": "box", "name": "crate", "size": [0.5, 0.5, 0.5], "position": [1.0, 1.0, 0]}],
  "cameras": [{"type": "orbit", "name": "orbit", "width": 320, "height": 180, "period": 4},
              {"type": "static", "name": "side", "width": 320, "height": 180, "position": [0, -6, 1.5], "target": [0, 0, 1]}],
  "outputs": {"points_per_actor": )" << points << R"(, "camera_paths": true, "glb": true, "report": true}})";
  return path;
}

// --- commit ------------------------------------------------------------------------------------

TEST(StagedCommitTest, AFailedCommitPutsEveryPreviousOutputBack) {
  const fs::path dir = test_support::scratch_dir("safety");
  std::ofstream(dir / "a.json") << "old a";
  std::ofstream(dir / "b.json") << "old b";
  fs::create_directories(dir / "seq" / "depths");
  std::ofstream(dir / "seq" / "depths" / "d.png") << "old depth";
  {
    io::StagedOutputs staged;
    io::write_file_atomically(staged.stage((dir / "a.json").string()), std::string("new a"));
    const fs::path seq = staged.stage_folder((dir / "seq").string());
    std::ofstream(seq / "anno.npz") << "new anno";
    staged.stage((dir / "b.json").string());  // never written: its rename fails, after a and seq went in
    io::write_file_atomically(staged.stage((dir / "c.json").string()), std::string("new c"));
    const std::string message = test_support::message_of<io::InputError>([&] { staged.commit(); });
    EXPECT_TRUE(contains(message, (dir / "b.json").string() + ": cannot rename")) << message;
    EXPECT_TRUE(contains(message, "the previous outputs are back in place")) << message;
  }
  EXPECT_EQ(read_bytes(dir / "a.json"), "old a");
  EXPECT_EQ(read_bytes(dir / "b.json"), "old b");
  EXPECT_FALSE(fs::exists(dir / "c.json"));
  EXPECT_EQ(read_bytes(dir / "seq" / "depths" / "d.png"), "old depth");
  EXPECT_FALSE(fs::exists(dir / "seq" / "anno.npz"));
  EXPECT_TRUE(staged_leftovers(dir).empty()) << staged_leftovers(dir).front();
}

TEST(StagedCommitTest, AWriterThatStagesNothingNeverReplacesAFifoOrAFolder) {
  const fs::path dir = test_support::scratch_dir("safety");
  ASSERT_EQ(::mkfifo((dir / "fifo.json").c_str(), 0644), 0);
  fs::create_directories(dir / "folder.json");
  for (const fs::path& target : {dir / "fifo.json", dir / "folder.json"}) {
    const std::string message =
        test_support::message_of<io::InputError>([&] { io::write_file_atomically(target.string(), std::string("x")); });
    EXPECT_TRUE(contains(message, target.string() + ": exists and is a")) << message;
  }
  EXPECT_TRUE(fs::is_fifo(dir / "fifo.json"));
  EXPECT_TRUE(fs::is_directory(dir / "folder.json"));
  EXPECT_TRUE(staged_leftovers(dir).empty()) << staged_leftovers(dir).front();
}

TEST(StagedCommitTest, ATargetBlockedAfterStagingReplacesNothingAndIsNamed) {
  const fs::path dir = test_support::scratch_dir("safety");
  std::ofstream(dir / "a.json") << "old a";
  std::ofstream(dir / "b.json") << "old b";
  {
    io::StagedOutputs staged;
    io::write_file_atomically(staged.stage((dir / "a.json").string()), std::string("new a"));
    io::write_file_atomically(staged.stage((dir / "b.json").string()), std::string("new b"));
    fs::remove(dir / "b.json");
    fs::create_directories(dir / "b.json" / "inside");
    const std::string message = test_support::message_of<io::InputError>([&] { staged.commit(); });
    EXPECT_TRUE(contains(message, (dir / "b.json").string() + ": exists and is a folder")) << message;
    EXPECT_TRUE(contains(message, "nothing was replaced")) << message;
  }
  EXPECT_EQ(read_bytes(dir / "a.json"), "old a");
  EXPECT_TRUE(fs::is_directory(dir / "b.json" / "inside"));
  EXPECT_TRUE(staged_leftovers(dir).empty()) << staged_leftovers(dir).front();

  // Unblocked, the same outputs replace the previous ones and nothing is kept aside.
  fs::remove_all(dir / "b.json");
  io::StagedOutputs again;
  io::write_file_atomically(again.stage((dir / "a.json").string()), std::string("new a"));
  const fs::path seq = again.stage_folder((dir / "seq").string());
  std::ofstream(seq / "x") << "x";
  again.commit();
  EXPECT_EQ(read_bytes(dir / "a.json"), "new a");
  EXPECT_EQ(read_bytes(dir / "seq" / "x"), "x");
  EXPECT_TRUE(staged_leftovers(dir).empty()) << staged_leftovers(dir).front();
}

TEST(SafetyCliTest, ARerunBlockedAtCommitKeepsThePreviousOutputs) {
  const fs::path dir = test_support::scratch_dir("safety_cli");
  const fs::path scene = write_scene(dir, 20, 2000), out = dir / "out";
  const test_support::CliResult first = test_support::run_cli("scene " + scene.string() + " --out " + out.string() + " --quiet");
  ASSERT_EQ(first.exit_code, 0) << first.output;
  std::map<std::string, std::string> before = snapshot(out);
  ASSERT_TRUE(before.contains("trajectories_orbit.npz") && before.contains("scene.glb") && before.contains("camera_side.json"));

  // Once the rerun's checks are behind it, its report's path becomes a folder.
  BackgroundCli rerun("scene " + scene.string() + " --out " + out.string() + " --quiet", dir / "rerun.log");
  ASSERT_TRUE(wait_for_staging(out));
  fs::remove(out / "report.json");
  fs::create_directories(out / "report.json" / "blocker");
  before.erase("report.json");
  EXPECT_EQ(rerun.wait(), 1) << rerun.output();
  EXPECT_TRUE(contains(rerun.output(), (out / "report.json").string() + ": exists and is a folder, not a regular file"))
      << rerun.output();
  std::map<std::string, std::string> after = snapshot(out);
  after.erase("report.json/blocker");
  EXPECT_EQ(after.size(), before.size());
  for (const auto& [name, bytes] : before) {
    EXPECT_TRUE(after.contains(name) && after[name] == bytes) << name << " changed or went missing";
  }
  EXPECT_TRUE(staged_leftovers(out).empty()) << staged_leftovers(out).front();
}

// --- interrupts --------------------------------------------------------------------------------

TEST(SafetyCliTest, SigintAndSigtermRemoveEverythingStaged) {
  const fs::path dir = test_support::scratch_dir("safety_cli");
  const fs::path scene = write_scene(dir, 20, 4000), out = dir / "out";
  fs::create_directories(out);
  std::ofstream(out / "keep.txt") << "not ours";
  for (const auto& [signal, code] : {std::pair{SIGINT, 130}, std::pair{SIGTERM, 143}}) {
    for (const char* layout : {"files", "pointodyssey"}) {
      BackgroundCli run("scene " + scene.string() + " --out " + out.string() + " --layout " + layout + " --quiet",
                        dir / "run.log");
      ASSERT_TRUE(wait_for_staging(out));
      std::this_thread::sleep_for(std::chrono::milliseconds(300));  // frames under way
      ::kill(run.pid(), signal);
      EXPECT_EQ(run.wait(), code) << run.output();
      EXPECT_TRUE(contains(run.output(), signal == SIGINT ? "interrupted by SIGINT" : "interrupted by SIGTERM")) << run.output();
      EXPECT_EQ(test_support::files_in(out), std::vector<std::string>{"keep.txt"}) << layout;
    }
  }
}

TEST(SafetyCliTest, WhatASigkillLeftIsSweptByTheNextRun) {
  const fs::path dir = test_support::scratch_dir("safety_cli");
  const fs::path out = dir / "out";
  fs::create_directories(out);
  {
    BackgroundCli run("scene " + write_scene(dir, 20, 4000).string() + " --out " + out.string() + " --layout pointodyssey --quiet",
                      dir / "run.log");
    ASSERT_TRUE(wait_for_staging(out));
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    ::kill(run.pid(), SIGKILL);
    EXPECT_EQ(run.wait(), 128 + SIGKILL);
  }
  ASSERT_FALSE(staged_leftovers(out).empty()) << "a SIGKILL leaves its staged files";
  const test_support::CliResult rerun = test_support::run_cli("scene " + write_scene(dir, 1, 200).string() + " --out " +
                                                              out.string() + " --layout pointodyssey --quiet");
  ASSERT_EQ(rerun.exit_code, 0) << rerun.output;
  EXPECT_TRUE(staged_leftovers(out).empty()) << staged_leftovers(out).front();
  EXPECT_TRUE(fs::exists(out / "walkers_orbit" / "anno.npz"));
}

TEST(StagedSweepTest, OnlyLeftoversOfDeadProcessesOfThisHostGo) {
  const fs::path dir = test_support::scratch_dir("safety");
  // A process that has ended, and this host's tag as temporary_name() writes it.
  const pid_t dead = ::fork();
  if (dead == 0) ::_exit(0);
  ::waitpid(dead, nullptr, 0);
  const std::string name = fs::path(io::temporary_name((dir / "x").string())).filename().string();
  const std::string host = name.substr(name.rfind('-') + 1);
  const auto leftover = [&](const std::string& target, const char* kind, pid_t pid, const std::string& tag) {
    return dir / (target + "." + kind + "-" + std::to_string(pid) + "-7-" + tag);
  };
  std::ofstream(leftover("tracks.npz", "partial", dead, host)) << "x";
  std::ofstream(leftover("tracks.npz", "partial", dead, host).string() + ".partial-" + std::to_string(dead) + "-trajs_2d") << "x";
  fs::create_directories(leftover("seq", "partial", dead, host) / "depths");
  std::ofstream(leftover("lost.json", "previous", dead, host)) << "previous lost";
  std::ofstream(dir / "there.json") << "new";
  std::ofstream(leftover("there.json", "previous", dead, host)) << "previous there";
  std::ofstream(leftover("live.json", "partial", ::getppid(), host)) << "x";      // running
  std::ofstream(leftover("other.json", "partial", dead, "0badc0de")) << "x";      // another machine's
  std::ofstream(dir / "mine.json.partial-12-3") << "x";                           // not our pattern
  EXPECT_EQ(io::sweep_leftovers(dir.string()), 5);
  EXPECT_EQ(test_support::files_in(dir),
            (std::vector<std::string>{leftover("live.json", "partial", ::getppid(), host).filename().string(), "lost.json",
                                      "mine.json.partial-12-3", leftover("other.json", "partial", dead, "0badc0de").filename().string(),
                                      "there.json"}));
  EXPECT_EQ(read_bytes(dir / "lost.json"), "previous lost");
  EXPECT_EQ(read_bytes(dir / "there.json"), "new");
}

// --- caps ----------------------------------------------------------------------------------------

TEST(SafetyCliTest, AClipWhoseResamplingPassesTheFrameCapIsRefusedBeforeItIsMade) {
  const fs::path dir = test_support::scratch_dir("safety_cli");
  // Two frames a million seconds apart: 30 million frames at 30 fps.
  std::ofstream(dir / "slow.bvh") << "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition "
                                     "Zrotation Xrotation Yrotation\n  End Site\n  {\n    OFFSET 0 10 0\n  }\n}\nMOTION\n"
                                     "Frames: 2\nFrame Time: 1e6\n0 0 0 0 0 0\n0 0 0 0 0 0\n";
  test_support::CliResult run = test_support::run_cli("pose --motion " + (dir / "slow.bvh").string() + " --out " +
                                                      (dir / "slow.npz").string() + " --fps 30");
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_TRUE(contains(run.output, (dir / "slow.bvh").string() + ": 2 frames at 1e-06 fps resampled to 30 fps make 3e+07 frames, "
                                                                  "more than the cap of 10000000"))
      << run.output;
  EXPECT_FALSE(fs::exists(dir / "slow.npz"));
  // Retargeting resamples the clip too: the same cap, before the clip is made.
  run = test_support::run_cli("retarget --motion " + (dir / "slow.bvh").string() + " --character " + kData +
                              "/characters/RiggedFigure.glb --out " + (dir / "slow.glb").string());
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_TRUE(contains(run.output, "resampled to 30 fps make 3e+07 frames, more than the cap of 10000000")) << run.output;
  EXPECT_FALSE(fs::exists(dir / "slow.glb"));

  // An AMASS sequence at 1e-9 frames a second.
  BodySequence walk = synthetic_walk(2, 30, BodyModelKind::SMPLX, 0);
  walk.fps = 1e-9;
  io::write_amass((dir / "slow_amass.npz").string(), walk);
  ASSERT_EQ(test_support::run_cli("make-body --out " + (dir / "body.npz").string()).exit_code, 0);
  run = test_support::run_cli("pose --model " + (dir / "body.npz").string() + " --motion " + (dir / "slow_amass.npz").string() +
                              " --out " + (dir / "slow.npz").string() + " --fps 30 --joints-only");
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_TRUE(contains(run.output, "resampled to 30 fps make 3e+10 frames, more than the cap of 10000000")) << run.output;
}

// Problems found only once the clips are loaded name the scene file and the JSON path too.
TEST(SafetyCliTest, ErrorsAfterParsingNameTheFileAndJsonPath) {
  const fs::path dir = test_support::scratch_dir("safety_cli");
  const std::string actor = R"("motion": ")" + kData + R"(/mocap/cmu_walk_cgspeed.bvh", "bvh_units": "cmu", "quality": "fast",
      "character": ")" + kData + R"(/characters/RiggedFigure.glb")";
  std::ofstream(dir / "trim.json") << R"({"version": 1, "actors": [{"name": "a", )" << actor << R"(, "trim": [100, 200]}],
      "cameras": [{"type": "static"}]})";
  test_support::CliResult run = test_support::run_cli("scene " + (dir / "trim.json").string() + " --out " + (dir / "out").string());
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_TRUE(contains(run.output, (dir / "trim.json").string() + ": actors[0].trim: the trim starts at 100 s, after the clip's end at"))
      << run.output;
  EXPECT_FALSE(fs::exists(dir / "out")) << "the folder the failed run made is gone";
  std::ofstream(dir / "region.json") << R"({"version": 1, "actors": [{"name": "a", )" << actor << R"(, "placement": {"x": 0, "y": 0, "yaw": 0}},
      {"name": "b", )" << actor << R"(, "placement": {"region": [0, 0, 0.01, 0.01]}}], "cameras": [{"type": "static"}]})";
  run = test_support::run_cli("scene " + (dir / "region.json").string() + " --out " + (dir / "out").string());
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_TRUE(contains(run.output, (dir / "region.json").string() + ": actors[1].placement.region: no placement in the region keeps it clear of actor 'a'"))
      << run.output;
}

TEST(SafetyCliTest, AnImageTooLargeIsRefusedAtParseTimeNamingItsJsonPath) {
  const fs::path dir = test_support::scratch_dir("safety_cli");
  std::ofstream(dir / "huge.json") << R"({"version": 1, "actors": [{"motion": ")" << kData
                                   << R"(/mocap/cmu_walk_cgspeed.bvh", "character": ")" << kData
                                   << R"(/characters/RiggedFigure.glb"}], "cameras": [{"type": "orbit"},
                                       {"type": "static", "width": 16384, "height": 16384}]})";
  const test_support::CliResult run = test_support::run_cli("scene " + (dir / "huge.json").string() + " --out " + (dir / "out").string());
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_TRUE(contains(run.output, (dir / "huge.json").string() + ": cameras[1].width: 16384 x 16384 pixels is larger than the cap "
                                                                  "of 16384 a side and 33554432 pixels in all"))
      << run.output;
  // The single-actor commands' --width and --height, the same cap.
  const test_support::CliResult wide = test_support::run_cli(
      "trajectories --motion " + kData + "/mocap/cmu_walk_cgspeed.bvh --character " + kData +
      "/characters/RiggedFigure.glb --camera static --width 20000 --height 100 --out " + (dir / "wide.npz").string());
  EXPECT_EQ(wide.exit_code, 2) << wide.output;
  EXPECT_TRUE(contains(wide.output, "--width and --height: 20000 x 100 pixels is larger than the cap")) << wide.output;
  EXPECT_FALSE(fs::exists(dir / "wide.npz"));
}

TEST(SafetyCliTest, AnEgoCameraOnAnActorWithoutABoneMapIsRefusedNamingItsJsonPath) {
  const fs::path dir = test_support::scratch_dir("safety_cli");
  std::ofstream(dir / "ego.json") << R"({"version": 1, "actors": [{"name": "dancer", "character": ")" << kData
                                  << R"(/characters/RiggedFigure.glb", "animation": "any"}],
                                      "cameras": [{"type": "ego", "actor": "dancer"}]})";
  const test_support::CliResult run = test_support::run_cli("scene " + (dir / "ego.json").string() + " --out " + (dir / "out").string());
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_TRUE(contains(run.output, (dir / "ego.json").string() + ": cameras[0].actor: actor 'dancer' plays its character's own "
                                                                 "animation, which has no bone map"))
      << run.output;
}

// --- pose and make-body outputs ---------------------------------------------------------------

TEST(SafetyCliTest, PoseAndMakeBodyRefuseOutputsThatAreNotFilesOrAreInputs) {
  const fs::path dir = test_support::scratch_dir("safety_cli");
  const fs::path motion = dir / "walk.bvh";
  fs::copy_file(kData + "/mocap/cmu_walk_cgspeed.bvh", motion);
  const auto size = fs::file_size(motion);
  ASSERT_EQ(::mkfifo((dir / "fifo.npz").c_str(), 0644), 0);
  fs::create_directories(dir / "folder.npz");
  const std::string pose = "pose --motion " + motion.string() + " --out ";
  for (const auto& [out, expected] : {std::pair{dir / "fifo.npz", "exists and is a FIFO, not a regular file"},
                                      std::pair{dir / "folder.npz", "exists and is a folder, not a regular file"},
                                      std::pair{motion, "is also an input of this run"},
                                      std::pair{dir / "." / "walk.bvh", "is also an input of this run"}}) {
    const test_support::CliResult run = test_support::run_cli(pose + out.string());
    EXPECT_EQ(run.exit_code, 1) << run.output;
    EXPECT_TRUE(contains(run.output, expected)) << run.output;
  }
  EXPECT_EQ(fs::file_size(motion), size);
  EXPECT_TRUE(fs::is_fifo(dir / "fifo.npz"));
  for (const fs::path& out : {dir / "fifo.npz", dir / "folder.npz"}) {
    const test_support::CliResult run = test_support::run_cli("make-body --out " + out.string());
    EXPECT_EQ(run.exit_code, 1) << run.output;
    EXPECT_TRUE(contains(run.output, "not a regular file")) << run.output;
  }
  EXPECT_TRUE(fs::is_fifo(dir / "fifo.npz"));
  EXPECT_TRUE(fs::is_directory(dir / "folder.npz"));
}

}  // namespace
}  // namespace odyssey
