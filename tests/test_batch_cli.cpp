// `odyssey batch` and `odyssey batch-report` end to end, on three short cuts of the shared CMU
// clips (two walks and a jump, 2 s each) onto two shared humanoids at `fast`, 30 fps:
//
//   BatchCli          the layout, the report, valid GLBs; a bad input fails its job only; a rerun
//                     skips what is done and redoes what changed; bad lists, shards, manifests and
//                     another batch's folder are refused with one line.
//   BatchIsolation    a job that aborts, one that hangs past --timeout and one that eats memory past
//                     --max-memory fail alone; the other jobs are done.
//   BatchResume       SIGKILL at seeded random moments, five times, then a rerun (a longer batch:
//                     twelve 10 s jumps onto both characters at balanced): the outputs equal an
//                     uninterrupted run byte for byte, and nothing partial is left anywhere.
//   BatchDeterminism  --jobs 1 and 2, and shards 1/2 + 2/2 (in one folder or two, merged by
//                     batch-report) give the same files.
//   BatchSlurm        the --slurm-script on a real one-node Slurm (scripts/slurm-local.sh) equals
//                     a local --jobs 2 run; skipped with a reason when no cluster answers, unless
//                     ODYSSEY_REQUIRE_SLURM=1 (CI sets it).
//
// "Byte for byte" holds for every data file (GLB, npz). Files that record how long things took
// (retarget.json's timings and solver summaries, the report's seconds) are compared with those
// fields removed; nothing else in them may differ.
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <thread>

#include "cli_runner.h"
#include "gltf_validator.h"
#include "test_support.h"

extern char** environ;

namespace odyssey::batch {
namespace {

namespace fs = std::filesystem;
using test_support::contains;
using test_support::run_cli;

const fs::path kAssets = fs::path(ODYSSEY_SHARED_DIR) / "assets";

std::string read(const fs::path& path) {
  std::ifstream file(path, std::ios::binary);
  std::stringstream text;
  text << file.rdbuf();
  return text.str();
}

void write(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

std::string quoted(const fs::path& path) { return "'" + path.string() + "'"; }

// Frames [first, first + count) of a BVH file, as a BVH file.
std::string bvh_cut(const fs::path& source, int first, int count) {
  std::istringstream in(read(source));
  std::string line, out;
  while (std::getline(in, line) && line.rfind("MOTION", 0) != 0) out += line + "\n";
  out += "MOTION\nFrames: " + std::to_string(count) + "\n";
  std::getline(in, line);  // Frames:
  std::getline(in, line);  // Frame Time:
  out += line + "\n";
  for (int frame = 0; std::getline(in, line) && frame < first + count; ++frame) {
    if (frame >= first) out += line + "\n";
  }
  return out;
}

// The test's inputs: motions/{walk_a,walk_b,jump}.bvh and the two characters in chars/.
struct Inputs {
  fs::path root, motions, characters;
};
Inputs make_inputs(const fs::path& root) {
  Inputs inputs{root, root / "motions", root / "chars"};
  write(inputs.motions / "walk_a.bvh", bvh_cut(kAssets / "mocap/cmu_walk_cgspeed.bvh", 0, 240));
  write(inputs.motions / "walk_b.bvh", bvh_cut(kAssets / "mocap/cmu_walk_cgspeed.bvh", 100, 240));
  write(inputs.motions / "jump.bvh", bvh_cut(kAssets / "mocap/cmu_jump_cgspeed.bvh", 600, 240));
  fs::create_directories(inputs.characters);
  for (const char* character : {"RiggedFigure.glb", "CesiumMan.glb"}) {
    fs::copy_file(kAssets / "characters" / character, inputs.characters / character);
  }
  return inputs;
}

const char* const kSettings = " --quality fast --fps 30";

std::string batch_arguments(const Inputs& inputs, const fs::path& out, const std::string& extra = "", bool quiet = true) {
  return "batch --motions " + quoted(inputs.motions) + " --characters " + quoted(inputs.characters) + " --out " +
         quoted(out) + kSettings + (quiet ? " --quiet " : " ") + extra;
}

const std::vector<std::string> kJobNames = {"CesiumMan/jump", "CesiumMan/walk_a", "CesiumMan/walk_b",
                                            "RiggedFigure/jump", "RiggedFigure/walk_a", "RiggedFigure/walk_b"};

// A JSON file without the fields that record time: keys ending in "seconds", "timings_s", and the
// solvers' summaries (which print their times).
nlohmann::json without_times(nlohmann::json value) {
  if (value.is_object()) {
    nlohmann::json kept = nlohmann::json::object();
    for (auto& [key, item] : value.items()) {
      if (key.ends_with("seconds") || key == "timings_s" || key == "solver" || key == "solver_report") continue;
      kept[key] = without_times(item);
    }
    return kept;
  }
  if (value.is_array()) {
    for (auto& item : value) item = without_times(item);
  }
  return value;
}

// Every file under `folder` (relative name -> content; JSON files without their times), skipping
// the journals and Slurm's logs, which differ by design (a journal lists the attempts).
std::map<std::string, std::string> outputs_of(const fs::path& folder) {
  std::map<std::string, std::string> files;
  for (const auto& entry : fs::recursive_directory_iterator(folder)) {
    if (!entry.is_regular_file()) continue;
    const std::string name = entry.path().lexically_relative(folder).generic_string();
    if (name.rfind("journal", 0) == 0 || name.rfind("slurm-", 0) == 0 || name.rfind("report.", 0) == 0) continue;
    std::string content = read(entry.path());
    if (entry.path().extension() == ".json") content = without_times(nlohmann::json::parse(content)).dump(1);
    files[name] = std::move(content);
  }
  return files;
}

// The report's jobs without their times, by name.
nlohmann::json report_jobs(const fs::path& report) {
  const nlohmann::json parsed = nlohmann::json::parse(read(report));
  nlohmann::json jobs = nlohmann::json::object();
  for (const nlohmann::json& job : parsed["jobs"]) jobs[job["name"].get<std::string>()] = without_times(job);
  return jobs;
}

void expect_same_outputs(const fs::path& expected, const fs::path& actual) {
  const auto want = outputs_of(expected), got = outputs_of(actual);
  ASSERT_EQ(want.size(), got.size()) << expected << " against " << actual;
  for (const auto& [name, content] : want) {
    const auto found = got.find(name);
    ASSERT_NE(found, got.end()) << name << " missing from " << actual;
    EXPECT_TRUE(found->second == content) << name << " differs between " << expected << " and " << actual;
  }
}

// Names under `folder` that a finished batch must not leave: staging folders, files being
// written, folders being replaced.
std::vector<std::string> leftovers(const fs::path& folder) {
  std::vector<std::string> found;
  for (const auto& entry : fs::recursive_directory_iterator(folder)) {
    const std::string name = entry.path().filename().string();
    if (name == ".staging" || contains(name, ".partial") || name.ends_with(".old")) found.push_back(entry.path().string());
  }
  return found;
}

fs::path scratch() { return test_support::scratch_dir("batch_cli"); }

TEST(BatchCli, CrossProductWritesTheLayoutTheReportAndValidGlbs) {
  const fs::path dir = scratch();
  const Inputs inputs = make_inputs(dir);
  const fs::path out = dir / "out";
  const auto result = run_cli(batch_arguments(inputs, out, "--jobs 2 --outputs glb,report,trajectories"));
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_TRUE(contains(result.output, "batch   6 jobs: 6 done (0 earlier), 0 failed, 0 flagged")) << result.output;
  for (const std::string& name : kJobNames) {
    EXPECT_EQ(test_support::files_in(out / "jobs" / name),
              (std::vector<std::string>{"animation.glb", "camera.json", "retarget.json", "trajectories.npz"}))
        << name;
  }
  EXPECT_TRUE(leftovers(out).empty());
  EXPECT_EQ(test_support::files_in(out), (std::vector<std::string>{"jobs", "journal.jsonl", "report.csv", "report.json"}));

  const nlohmann::json report = nlohmann::json::parse(read(out / "report.json"));
  EXPECT_EQ(report["batch"]["jobs"], 6);
  EXPECT_EQ(report["batch"]["done"], 6);
  EXPECT_EQ(report["batch"]["settings"]["quality"], "fast");
  ASSERT_EQ(report["jobs"].size(), 6u);
  for (const nlohmann::json& job : report["jobs"]) {
    EXPECT_EQ(job["status"], "done");
    EXPECT_EQ(job["frames"], 60) << job["name"];  // 240 frames at 120 fps, resampled to 30
    const nlohmann::json& metrics = job["metrics"];
    // Fast swings every chain bone onto the source's (docs/benchmarks.md: Retargeting: speed and
    // accuracy) but the spine chain's, which it turns as one to share the performer's bend
    // (retarget/transfer.h): the spine, and the head on a rig whose chest carries it.
    EXPECT_LT(metrics["worst_limb_mean_deg"].get<double>(), 2.0) << job["name"];
    for (const auto& [limb, mean] : metrics["limbs_mean_deg"].items()) {
      if (limb == "spine" || limb == "head") continue;
      EXPECT_LT(mean.get<double>(), 0.01) << job["name"] << " " << limb;
    }
    // The report carries the source's figures beside the result's, measured on the same cut.
    EXPECT_GT(metrics["source_jitter"].get<double>(), 0.0);
    EXPECT_GT(metrics["jitter"].get<double>(), 0.0);
    for (const char* limb : {"head", "spine", "left_arm", "right_arm", "left_leg", "right_leg"}) {
      EXPECT_TRUE(metrics["limbs_mean_deg"].contains(limb)) << limb << ": " << metrics.dump();
    }
  }
  const std::string csv = read(out / "report.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 7);
  EXPECT_EQ(csv.rfind("name,status,error,kind,motion,character,scene,quality,frames,seconds,flags,bone_error_mean_deg", 0), 0u);

  if (const std::string missing = test_support::validator_missing(); !missing.empty()) GTEST_SKIP() << missing;
  std::string files;
  for (const std::string& name : kJobNames) files += " " + quoted(out / "jobs" / name / "animation.glb");
  const int status = std::system(("node " + quoted(test_support::validator_dir() / "validate.mjs") + files + " > " +
                                  quoted(dir / "validator.txt") + " 2>&1").c_str());
  EXPECT_EQ(status, 0) << read(dir / "validator.txt");
}

TEST(BatchCli, ABadInputFailsItsJobOnlyAndTheExitCodeSaysSo) {
  const fs::path dir = scratch();
  const Inputs inputs = make_inputs(dir);
  write(inputs.motions / "broken.bvh", bvh_cut(kAssets / "mocap/cmu_walk_cgspeed.bvh", 0, 240).substr(0, 6000));
  const fs::path out = dir / "out";
  const auto result = run_cli(batch_arguments(inputs, out, "--jobs 2 --outputs glb", false));
  EXPECT_EQ(result.exit_code, 1) << result.output;
  EXPECT_TRUE(contains(result.output, "failed  CesiumMan/broken: ")) << result.output;
  EXPECT_TRUE(contains(result.output, "broken.bvh")) << result.output;
  EXPECT_TRUE(contains(result.output, "8 jobs: 6 done (0 earlier), 2 failed")) << result.output;
  EXPECT_FALSE(fs::exists(out / "jobs/CesiumMan/broken"));
  EXPECT_TRUE(fs::exists(out / "jobs/CesiumMan/walk_a/animation.glb"));
  const nlohmann::json jobs = report_jobs(out / "report.json");
  EXPECT_EQ(jobs["RiggedFigure/broken"]["status"], "failed");
  EXPECT_TRUE(contains(jobs["RiggedFigure/broken"]["error"].get<std::string>(), "broken.bvh: ")) << jobs.dump(1);
  EXPECT_EQ(jobs["RiggedFigure/walk_a"]["status"], "done");
  EXPECT_TRUE(leftovers(out).empty());
}

TEST(BatchCli, ARerunSkipsWhatIsDoneAndRedoesWhatChanged) {
  const fs::path dir = scratch();
  const Inputs inputs = make_inputs(dir);
  const fs::path out = dir / "out";
  ASSERT_EQ(run_cli(batch_arguments(inputs, out, "--jobs 2")).exit_code, 0);
  const std::string glb = read(out / "jobs/CesiumMan/walk_b/animation.glb");
  auto result = run_cli(batch_arguments(inputs, out, "--jobs 2"));
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_TRUE(contains(result.output, "6 jobs: 6 done (6 earlier), 0 failed")) << result.output;

  // Another cut of the walk under walk_b's name: its two jobs run again, the rest do not. A job
  // whose folder was deleted runs again too.
  write(inputs.motions / "walk_b.bvh", bvh_cut(kAssets / "mocap/cmu_walk_cgspeed.bvh", 50, 240));
  fs::remove_all(out / "jobs/RiggedFigure/jump");
  result = run_cli(batch_arguments(inputs, out, "--jobs 2"));
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_TRUE(contains(result.output, "6 jobs: 6 done (3 earlier), 0 failed")) << result.output;
  EXPECT_NE(read(out / "jobs/CesiumMan/walk_b/animation.glb"), glb);
  EXPECT_TRUE(fs::exists(out / "jobs/RiggedFigure/jump/animation.glb"));
  EXPECT_EQ(report_jobs(out / "report.json").size(), 6u);
}

TEST(BatchCli, ASceneJobWithAPlayedSourceIsResumed) {
  // Its key hashes the played character's file (it hashed an empty path, so it never resumed).
  const fs::path dir = scratch();
  write(dir / "fox.json", R"({"version": 1, "name": "fox", "seconds": 1, "actors": [{"name": "fox", "character": ")" +
                              std::string(ODYSSEY_DATA_DIR) + R"(/characters/Fox.glb", "animation": "Walk", "scale": 0.01}],
      "cameras": [{"type": "orbit", "width": 160, "height": 90}], "outputs": {"points_per_actor": 200}})");
  write(dir / "jobs.csv", "scene\nfox.json\n");
  const fs::path out = dir / "out";
  const std::string arguments = "batch --manifest " + quoted(dir / "jobs.csv") + " --out " + quoted(out);
  auto result = run_cli(arguments);
  ASSERT_EQ(result.exit_code, 0) << result.output;
  result = run_cli(arguments);
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_TRUE(contains(result.output, "1 jobs: 1 done (1 earlier), 0 failed")) << result.output;
}

TEST(BatchCli, ASceneJobRunsAgainWhenAScatteredPropsMeshChanges) {
  // Its key hashes the scatter's template meshes like the scene's own props.
  const fs::path dir = scratch();
  const auto cube = [](double half) {
    std::string obj;
    for (int c = 0; c < 8; ++c) {
      obj += "v " + std::to_string(c & 1 ? half : -half) + " " + std::to_string(c & 2 ? 2 * half : 0.0) + " " +
             std::to_string(c & 4 ? half : -half) + "\n";
    }
    return obj + "f 1 3 2\nf 2 3 4\nf 5 6 7\nf 6 8 7\nf 1 2 5\nf 2 6 5\nf 3 7 4\nf 4 7 8\nf 1 5 3\nf 3 5 7\nf 2 4 6\nf 4 8 6\n";
  };
  write(dir / "cube.obj", cube(0.1));
  write(dir / "kick.json", R"({"version": 1, "name": "kick", "seconds": 1, "actors": [{"name": "walker", "motion": ")" +
                               std::string(ODYSSEY_DATA_DIR) + R"(/mocap/cmu_walk_cgspeed.bvh", "bvh_units": "cmu", "character": ")" +
                               std::string(ODYSSEY_DATA_DIR) + R"(/characters/RiggedFigure.glb", "quality": "fast"}],
      "scatter": {"count": 3, "props": [{"type": "mesh", "path": "cube.obj", "dynamic": true}]},
      "cameras": [{"type": "orbit", "width": 160, "height": 90}], "outputs": {"points_per_actor": 100, "prop_points": 100}})");
  write(dir / "jobs.csv", "scene\nkick.json\n");
  const fs::path out = dir / "out";
  const std::string arguments = "batch --manifest " + quoted(dir / "jobs.csv") + " --out " + quoted(out);
  auto result = run_cli(arguments);
  ASSERT_EQ(result.exit_code, 0) << result.output;
  result = run_cli(arguments);
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_TRUE(contains(result.output, "1 jobs: 1 done (1 earlier), 0 failed")) << result.output;
  write(dir / "cube.obj", cube(0.12));
  result = run_cli(arguments);
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_TRUE(contains(result.output, "1 jobs: 1 done (0 earlier), 0 failed")) << result.output;
}

TEST(BatchCli, BadListsShardsManifestsAndAnotherBatchsFolderAreRefusedInOneLine) {
  const fs::path dir = scratch();
  const Inputs inputs = make_inputs(dir);
  const fs::path out = dir / "out";
  const auto refused = [&](const std::string& arguments, int code, const std::string& message) {
    const auto result = run_cli(arguments);
    EXPECT_EQ(result.exit_code, code) << arguments << "\n" << result.output;
    EXPECT_TRUE(contains(result.output, message)) << arguments << "\n" << result.output;
    EXPECT_EQ(std::count(result.output.begin(), result.output.end(), '\n'), 1) << result.output;
  };
  refused("batch --motions " + quoted(dir / "nope") + " --characters " + quoted(inputs.characters) + " --out " + quoted(out),
          1, "nope: no such file or folder");
  fs::create_directories(dir / "empty");
  refused("batch --motions " + quoted(dir / "empty") + " --characters " + quoted(inputs.characters) + " --out " + quoted(out),
          1, "empty: the folder holds no motion file");
  refused(batch_arguments(inputs, out, "--shard 3/2"), 2, "--shard 3/2: I must be 1 to N");
  refused(batch_arguments(inputs, out, "--shard 0/0"), 2, "--shard 0/0: I must be 1 to N");
  refused(batch_arguments(inputs, out, "--threads 2"), 2, "--threads: a batch runs one thread per job");
  write(dir / "m.csv", "motion,character,fps\nmotions/walk_a.bvh,chars/CesiumMan.glb,thirty\n");
  refused("batch --manifest " + quoted(dir / "m.csv") + " --out " + quoted(out), 1, "m.csv: line 2, column fps: expected a frame rate");
  EXPECT_FALSE(fs::exists(out));

  ASSERT_EQ(run_cli(batch_arguments(inputs, out, "--jobs 2")).exit_code, 0);
  const std::string other = batch_arguments(inputs, out, "--jobs 2");
  refused(other.substr(0, other.find(" --quality")) + " --quality balanced --fps 30", 1,
          "the output folder holds another batch's journal (quality: \"balanced\" here, \"fast\" there)");
}

TEST(BatchCli, AManifestRunsItsRowsWithTheirOwnSettingsAndNames) {
  const fs::path dir = scratch();
  const Inputs inputs = make_inputs(dir);
  write(dir / "jobs.csv",
        "name,motion,character,fps,outputs\n"
        "slow/walk,motions/walk_a.bvh,chars/CesiumMan.glb,15,glb\n"
        ",motions/jump.bvh,chars/RiggedFigure.glb,,\"glb,report\"\n");
  const fs::path out = dir / "out";
  const auto result = run_cli("batch --manifest " + quoted(dir / "jobs.csv") + " --out " + quoted(out) + kSettings + " --quiet");
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_EQ(test_support::files_in(out / "jobs/slow/walk"), std::vector<std::string>{"animation.glb"});
  EXPECT_EQ(test_support::files_in(out / "jobs/RiggedFigure/jump"), (std::vector<std::string>{"animation.glb", "retarget.json"}));
  const nlohmann::json jobs = report_jobs(out / "report.json");
  EXPECT_EQ(jobs["slow/walk"]["frames"], 30);
  EXPECT_EQ(jobs["RiggedFigure/jump"]["frames"], 60);
}

// A FIFO or a device named by a row is not read by the batch's own process (it would block before
// any worker and its --timeout): the row's job fails, the others are done, the batch ends.
TEST(BatchIsolation, FifoAndDeviceInputsFailTheirJobsAndNothingHangs) {
  const fs::path dir = scratch();
  const Inputs inputs = make_inputs(dir);
  ASSERT_EQ(::mkfifo((dir / "motions_fifo.bvh").c_str(), 0600), 0);
  ASSERT_EQ(::mkfifo((dir / "scene_fifo.json").c_str(), 0600), 0);
  write(dir / "jobs.json", R"({"jobs": [
    {"name": "good", "motion": "motions/walk_a.bvh", "character": "chars/CesiumMan.glb"},
    {"name": "fifo", "motion": "motions_fifo.bvh", "character": "chars/CesiumMan.glb"},
    {"name": "device", "motion": "/dev/zero", "character": "chars/CesiumMan.glb"},
    {"name": "scene", "scene": "scene_fifo.json"}]})");
  const fs::path out = dir / "out";
  const auto start = std::chrono::steady_clock::now();
  // `timeout` ends the test's wait, not the batch's work: a batch that hangs fails here.
  const std::string command = "timeout 120 " + std::string(ODYSSEY_CLI) + " batch --manifest " + quoted(dir / "jobs.json") +
                              " --out " + quoted(out) + kSettings + " --quiet --jobs 2 --timeout 30 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string output;
  char buffer[4096];
  while (std::fgets(buffer, sizeof buffer, pipe)) output += buffer;
  const int status = pclose(pipe);
  EXPECT_EQ(WEXITSTATUS(status), 1) << output;
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 100) << output;
  const nlohmann::json jobs = report_jobs(out / "report.json");
  EXPECT_EQ(jobs["good"]["status"], "done") << jobs.dump(1);
  for (const char* name : {"fifo", "device", "scene"}) EXPECT_EQ(jobs[name]["status"], "failed") << name;
  EXPECT_TRUE(contains(jobs["fifo"].value("error", ""), "not a regular file")) << jobs["fifo"];
  EXPECT_TRUE(contains(jobs["device"].value("error", ""), "not a regular file")) << jobs["device"];
}

// Names that make one folder ("a//b" and "a/b") or hold a control character are refused before
// any work, naming both rows.
TEST(BatchInputsCli, JobNamesAreNormalisedOnceAndCollisionsNameBothRows) {
  const fs::path dir = scratch();
  const Inputs inputs = make_inputs(dir);
  write(dir / "jobs.csv",
        "name,motion,character\n"
        "a//b,motions/walk_a.bvh,chars/CesiumMan.glb\n"
        "a/b,motions/jump.bvh,chars/CesiumMan.glb\n");
  const fs::path out = dir / "out";
  auto result = run_cli("batch --manifest " + quoted(dir / "jobs.csv") + " --out " + quoted(out) + kSettings + " --quiet");
  EXPECT_EQ(result.exit_code, 1) << result.output;
  EXPECT_TRUE(contains(result.output, "two jobs would write into a/b")) << result.output;
  EXPECT_TRUE(contains(result.output, "jobs.csv: line 2")) << result.output;
  EXPECT_TRUE(contains(result.output, "jobs.csv: line 3")) << result.output;
  EXPECT_FALSE(fs::exists(out));
  // One of them alone runs into the folder its normal name makes, under that name.
  write(dir / "one.csv", "name,motion,character\na//b,motions/walk_a.bvh,chars/CesiumMan.glb\n");
  result = run_cli("batch --manifest " + quoted(dir / "one.csv") + " --out " + quoted(out) + kSettings + " --quiet");
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_TRUE(report_jobs(out / "report.json").contains("a/b"));
  write(dir / "nul.json", std::string(R"({"jobs": [{"name": "a\u0000b", "motion": "motions/walk_a.bvh", "character": "chars/CesiumMan.glb"}]})"));
  result = run_cli("batch --manifest " + quoted(dir / "nul.json") + " --out " + quoted(dir / "out2") + kSettings + " --quiet");
  EXPECT_NE(result.exit_code, 0) << result.output;
  EXPECT_TRUE(contains(result.output, "job name 'a\\x00b' holds a control character")) << result.output;
  EXPECT_FALSE(fs::exists(dir / "out2"));
}

TEST(BatchIsolation, ACrashAHangAndAMemoryBlowUpFailTheirJobsOnly) {
  const fs::path dir = scratch();
  const Inputs inputs = make_inputs(dir);
  const fs::path out = dir / "out";
  ::setenv("ODYSSEY_BATCH_FAULT", "crash:CesiumMan/jump,hang:RiggedFigure/walk_a,oom:CesiumMan/walk_b", 1);
  const auto result = run_cli(batch_arguments(inputs, out, "--jobs 2 --timeout 10 --max-memory 1.5"));
  ::unsetenv("ODYSSEY_BATCH_FAULT");
  EXPECT_EQ(result.exit_code, 1) << result.output;
  const nlohmann::json jobs = report_jobs(out / "report.json");
  ASSERT_EQ(jobs.size(), 6u) << jobs.dump(1);
  const auto error = [&](const char* name) { return jobs[name].value("error", std::string()); };
  EXPECT_TRUE(contains(error("CesiumMan/jump"), "the worker died of signal 6")) << error("CesiumMan/jump");
  EXPECT_EQ(error("RiggedFigure/walk_a"), "timed out after 10 s (--timeout)");
  EXPECT_EQ(error("CesiumMan/walk_b"), "out of memory");
  for (const char* name : {"CesiumMan/walk_a", "RiggedFigure/jump", "RiggedFigure/walk_b"}) {
    EXPECT_EQ(jobs[name]["status"], "done") << name;
    EXPECT_TRUE(fs::exists(out / "jobs" / name / "animation.glb")) << name;
  }
  EXPECT_TRUE(leftovers(out).empty());
}

TEST(BatchIsolation, ASecondBatchIntoTheSameFolderIsRefusedWhileTheFirstRuns) {
  const fs::path dir = scratch();
  const Inputs inputs = make_inputs(dir);
  const fs::path out = dir / "out";
  // The first batch holds the journal's lock for at least --timeout: one of its jobs hangs.
  const std::string first = "ODYSSEY_BATCH_FAULT=hang:CesiumMan/jump " + std::string(ODYSSEY_CLI) + " " +
                            batch_arguments(inputs, out, "--jobs 1 --timeout 6") + " > " + quoted(dir / "first.txt") + " 2>&1";
  const char* argv[] = {"/bin/sh", "-c", first.c_str(), nullptr};
  pid_t pid = 0;
  ASSERT_EQ(::posix_spawn(&pid, "/bin/sh", nullptr, nullptr, const_cast<char**>(argv), environ), 0);
  // The first job of the name-sorted list is the hanging one. The journal's header is written
  // after its lock is taken, so a journal with a header means the lock is held.
  const auto locked = [&] {
    std::error_code error;
    return fs::file_size(out / "journal.jsonl", error) > 0 && !error;
  };
  for (int wait = 0; wait < 100 && !locked(); ++wait) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  const auto second = run_cli(batch_arguments(inputs, out, "--jobs 1"));
  EXPECT_EQ(second.exit_code, 1) << second.output;
  EXPECT_TRUE(contains(second.output, "journal.jsonl: another batch (or the same shard) is running into this folder"))
      << second.output;
  int status = 0;
  ::waitpid(pid, &status, 0);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 1) << read(dir / "first.txt");  // the hung job failed
  const nlohmann::json jobs = report_jobs(out / "report.json");
  EXPECT_EQ(jobs["CesiumMan/jump"]["error"], "timed out after 6 s (--timeout)");
  EXPECT_EQ(jobs["RiggedFigure/walk_b"]["status"], "done");
}

// One uninterrupted run, into `out`.
void reference_run(const Inputs& inputs, const fs::path& out) {
  const auto result = run_cli(batch_arguments(inputs, out, "--jobs 2"));
  ASSERT_EQ(result.exit_code, 0) << result.output;
}

TEST(BatchResume, KilledAtRandomMomentsThenRerunTheOutputsEqualAnUninterruptedRun) {
  // A longer batch than the others: twelve 10 s cuts of the jump onto both characters at
  // `balanced`, so that kills land while jobs run.
  const fs::path dir = scratch();
  Inputs inputs = make_inputs(dir);
  inputs.motions = dir / "jumps";
  for (int cut = 0; cut < 12; ++cut) {
    write(inputs.motions / ("jump_" + std::to_string(cut) + ".bvh"), bvh_cut(kAssets / "mocap/cmu_jump_cgspeed.bvh", 140 * cut, 1200));
  }
  const auto arguments = [&](const fs::path& out) {
    const std::string fast = batch_arguments(inputs, out, "--jobs 2");
    return fast.substr(0, fast.find(kSettings)) + " --quality balanced --fps 30 --quiet --jobs 2";
  };
  const auto start = std::chrono::steady_clock::now();
  auto result = run_cli(arguments(dir / "reference"));
  ASSERT_EQ(result.exit_code, 0) << result.output;
  const double whole_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  const fs::path out = dir / "killed";
  std::mt19937 random(20261202);
  // Each run gets through at most about a third of the batch before its kill; a job in flight
  // when the batch dies is lost and runs again.
  std::uniform_real_distribution<double> moment(0.05, 0.35);
  const std::string command = std::string(ODYSSEY_CLI) + " " + arguments(out) + " > /dev/null 2>&1";
  int interrupted = 0;
  for (int kill_number = 0; kill_number < 5; ++kill_number) {
    // exec replaces the shell, so the pid is the batch's own.
    const std::string exec = "exec " + command;
    const char* argv[] = {"/bin/sh", "-c", exec.c_str(), nullptr};
    pid_t pid = 0;
    ASSERT_EQ(::posix_spawn(&pid, "/bin/sh", nullptr, nullptr, const_cast<char**>(argv), environ), 0);
    const double after_s = moment(random) * whole_s;
    std::this_thread::sleep_for(std::chrono::duration<double>(after_s));
    ::kill(pid, SIGKILL);
    int status = 0;
    ::waitpid(pid, &status, 0);
    std::printf("kill %d after %.2f s of a %.2f s batch: %s\n", kill_number + 1, after_s, whole_s,
                WIFSIGNALED(status) ? "killed" : "it had already ended");
    interrupted += WIFSIGNALED(status) ? 1 : 0;
  }
  EXPECT_GE(interrupted, 3) << "the kills came too late to test anything";
  result = run_cli(arguments(out));
  ASSERT_EQ(result.exit_code, 0) << result.output;
  std::printf("%s", result.output.c_str());
  expect_same_outputs(dir / "reference", out);
  EXPECT_EQ(report_jobs(dir / "reference/report.json"), report_jobs(out / "report.json"));
  EXPECT_EQ(leftovers(out), std::vector<std::string>{});
  // Every journal line is whole JSON but for a torn record a kill may leave, and each job's last
  // record is "done".
  std::istringstream journal(read(out / "journal.jsonl"));
  std::map<std::string, std::string> last;
  for (std::string line; std::getline(journal, line);) {
    const nlohmann::json record = nlohmann::json::parse(line, nullptr, false);
    if (!record.is_discarded() && record.contains("job")) last[record["job"]] = record["status"];
  }
  EXPECT_EQ(last.size(), 24u);
  for (const auto& [name, status] : last) EXPECT_EQ(status, "done") << name;
}

TEST(BatchDeterminism, WorkersAndShardsDoNotChangeTheFiles) {
  const fs::path dir = scratch();
  const Inputs inputs = make_inputs(dir);
  reference_run(inputs, dir / "two_workers");
  ASSERT_EQ(run_cli(batch_arguments(inputs, dir / "one_worker", "--jobs 1")).exit_code, 0);
  expect_same_outputs(dir / "two_workers", dir / "one_worker");

  // Shards into one folder, as a Slurm array writes them, then batch-report there.
  auto result = run_cli(batch_arguments(inputs, dir / "shared", "--jobs 1 --shard 2/2"));
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_TRUE(contains(result.output, "3 jobs in shard 2/2: 3 done")) << result.output;
  EXPECT_FALSE(fs::exists(dir / "shared/report.json"));  // a shard leaves the report to batch-report
  ASSERT_EQ(run_cli(batch_arguments(inputs, dir / "shared", "--jobs 1 --shard 1/2")).exit_code, 0);
  result = run_cli("batch-report " + quoted(dir / "shared"));
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_TRUE(contains(result.output, "6 jobs: 6 done, 0 failed, 0 flagged, 0 not run")) << result.output;
  expect_same_outputs(dir / "two_workers", dir / "shared");
  EXPECT_EQ(report_jobs(dir / "two_workers/report.json"), report_jobs(dir / "shared/report.json"));

  // Shards into two folders, merged.
  ASSERT_EQ(run_cli(batch_arguments(inputs, dir / "first", "--jobs 2 --shard 1/2")).exit_code, 0);
  result = run_cli("batch-report " + quoted(dir / "first") + " " + quoted(dir / "missing_second"));
  EXPECT_NE(result.exit_code, 0);
  EXPECT_TRUE(contains(result.output, "missing_second: holds no batch journal")) << result.output;
  ASSERT_EQ(run_cli(batch_arguments(inputs, dir / "second", "--jobs 2 --shard 2/2")).exit_code, 0);
  result = run_cli("batch-report " + quoted(dir / "first") + " " + quoted(dir / "second") + " --out " + quoted(dir / "merged"));
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_EQ(report_jobs(dir / "two_workers/report.json"), report_jobs(dir / "merged/report.json"));
  const nlohmann::json merged = nlohmann::json::parse(read(dir / "merged/report.json"));
  EXPECT_EQ(merged["batch"]["shards"].size(), 2u);
  // A gate on the merged report flags jobs without rerunning them; exit 3 says so.
  result = run_cli("batch-report " + quoted(dir / "first") + " " + quoted(dir / "second") + " --out " + quoted(dir / "gated") +
                   " --max-jitter 0.5");
  EXPECT_EQ(result.exit_code, 3) << result.output;
  EXPECT_TRUE(contains(result.output, "6 jobs: 6 done, 0 failed, 6 flagged")) << result.output;
}

// The cluster answers when sinfo lists an idle, mixed or allocated node.
std::string slurm_missing() {
  if (std::system("command -v sbatch > /dev/null 2>&1") != 0) return "sbatch is not installed";
  if (std::system("sinfo -h -o %T 2>/dev/null | grep -qE '^(idle|mixed|allocated)'") != 0) {
    return "no Slurm cluster answers (start one with: sudo bash scripts/slurm-local.sh start)";
  }
  return "";
}

TEST(BatchSlurm, TheScriptRunOnARealClusterEqualsALocalRun) {
  if (const std::string missing = slurm_missing(); !missing.empty()) {
    const char* required = std::getenv("ODYSSEY_REQUIRE_SLURM");
    if (required && std::string(required) == "1") FAIL() << missing;
    GTEST_SKIP() << missing;
  }
  const fs::path dir = scratch();
  const Inputs inputs = make_inputs(dir);
  reference_run(inputs, dir / "local");
  const fs::path out = dir / "cluster", script = dir / "batch.sbatch";
  auto result = run_cli(batch_arguments(inputs, out, "--slurm-script " + quoted(script) +
                                                         " --slurm-tasks 3 --slurm-cpus 1 --slurm-mem 1500 --slurm-time 20"));
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_TRUE(contains(result.output, "6 jobs in 3 shards of 1 CPUs each")) << result.output;
  const std::string text = read(script);
  EXPECT_TRUE(contains(text, "#SBATCH --array=1-3\n")) << text;
  const int status = std::system(("sbatch --wait " + quoted(script) + " > " + quoted(dir / "sbatch.txt") + " 2>&1").c_str());
  EXPECT_EQ(status, 0) << read(dir / "sbatch.txt");
  for (int shard = 1; shard <= 3; ++shard) {
    EXPECT_TRUE(fs::exists(out / ("journal.shard-" + std::to_string(shard) + "-of-3.jsonl"))) << shard;
  }
  result = run_cli("batch-report " + quoted(out));
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_TRUE(contains(result.output, "6 jobs: 6 done, 0 failed")) << result.output;
  expect_same_outputs(dir / "local", out);
  EXPECT_EQ(report_jobs(dir / "local/report.json"), report_jobs(out / "report.json"));
  EXPECT_TRUE(leftovers(out).empty());
}

}  // namespace
}  // namespace odyssey::batch
