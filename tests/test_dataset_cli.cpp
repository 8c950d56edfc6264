// `odyssey dataset` end to end on a small recipe over the bundled assets:
//   DatasetRunTest    the same recipe and seed give the same bytes on any worker count; shards
//                     (and the report merged from them) equal the whole; a run killed in a
//                     sequence resumes to what an uninterrupted run makes; more --count adds
//                     sequences without touching the others; a scene file of the dataset re-makes
//                     its sequences with `odyssey scene`; every sequence reads as the trackers'
//                     loaders read it (tests/python/read_sequence.py); a broken asset fails only
//                     the sequences that drew it; the bundled example runs as printed.
//   DatasetCliTest    bad recipes and command lines: one line naming the file and JSON path,
//                     exit non-zero, nothing written.
//   DatasetSlurm      the --slurm-script on a real one-node Slurm equals a local run.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "cli_runner.h"
#include "test_support.h"

namespace odyssey {
namespace {

namespace fs = std::filesystem;
using test_support::contains;
using test_support::run_cli;

const std::string kData = ODYSSEY_DATA_DIR;
const std::string kReader = std::string(ODYSSEY_SOURCE_DIR) + "/tests/python/read_sequence.py";

std::string quoted(const fs::path& path) { return "'" + path.string() + "'"; }

std::string read(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// One or two people (two characters, the CMU walk), 1 s, one or two 320x180 cameras, a few kicked
// boxes, depth, normals and masks; split train/test.
std::string small_recipe(const std::string& motions = "\"" + kData + "/mocap/cmu_walk_cgspeed.bvh\"") {
  return R"({"version": 1, "name": "t", "seed": 3,
  "libraries": {"characters": [")" + kData + R"(/characters/RiggedFigure.glb", ")" + kData + R"(/characters/CesiumMan.glb"],
                "motions": [{"path": )" + motions + R"(, "bvh_units": "cmu"}]},
  "shots": {"seconds": 1, "actors": [1, 2], "quality": {"fast": 1}},
  "cameras": {"count": [1, 2], "kinds": {"static": 1, "orbit": 1, "ego": 1}, "width": 320, "height": 180},
  "props": {"scatter": [0, 2], "force_rate": 0.5},
  "points": {"per_actor": 300},
  "outputs": {"depth": true, "normals": true, "masks": true},
  "splits": {"train": 0.5, "test": 0.5}})";
}

fs::path scratch() { return test_support::scratch_dir("dataset_cli"); }

fs::path write(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path) << text;
  return path;
}

// Every file of the dataset the recipe determines (the sequences and scene files), by relative
// name; not the journals, reports and manifest, which hold times.
std::map<std::string, std::string> dataset_files(const fs::path& folder) {
  std::map<std::string, std::string> files;
  for (const auto& entry : fs::recursive_directory_iterator(folder)) {
    if (!entry.is_regular_file()) continue;
    const std::string name = entry.path().lexically_relative(folder).generic_string();
    if (name.starts_with("train/") || name.starts_with("test/") || name.starts_with("scenes/")) files[name] = read(entry.path());
  }
  return files;
}

void expect_same_dataset(const fs::path& a, const fs::path& b) {
  const auto left = dataset_files(a), right = dataset_files(b);
  ASSERT_FALSE(left.empty());
  std::vector<std::string> names_a, names_b;
  for (const auto& [name, text] : left) names_a.push_back(name);
  for (const auto& [name, text] : right) names_b.push_back(name);
  ASSERT_EQ(names_a, names_b);
  for (const auto& [name, text] : left) EXPECT_TRUE(text == right.at(name)) << name << " differs between " << a << " and " << b;
}

nlohmann::json manifest(const fs::path& folder) { return nlohmann::json::parse(read(folder / "dataset.json")); }

std::string run_reader(const fs::path& sequence) {
  const std::string command = test_support::numpy_python() + " " + kReader + " " + quoted(sequence) + " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  std::string text;
  char buffer[4096];
  while (pipe && std::fgets(buffer, sizeof buffer, pipe)) text += buffer;
  const int status = pipe ? pclose(pipe) : -1;
  return status == 0 ? text : "FAILED " + text;
}

TEST(DatasetRunTest, SameBytesShardsResumeAndLoaders) {
  REQUIRE_NUMPY();
  const fs::path dir = scratch();
  const fs::path recipe = write(dir / "recipe.json", small_recipe());
  const std::string base = "dataset " + quoted(recipe) + " --count 3 --quiet --out ";

  auto result = run_cli(base + quoted(dir / "a") + " --jobs 2");
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_TRUE(contains(result.output, "dataset 3 sequences: 3 done (0 earlier), 0 failed")) << result.output;
  const nlohmann::json a = manifest(dir / "a");
  ASSERT_EQ(a["sequences"].size(), 3u);
  long camera_sequences = 0;
  for (const auto& sequence : a["sequences"]) {
    EXPECT_TRUE(fs::is_regular_file(dir / "a" / sequence["scene_file"].get<std::string>()));
    EXPECT_EQ(sequence["frames"], 31);
    EXPECT_GE(sequence["redraws"].get<int>(), 0);
    EXPECT_FALSE(sequence["assets"].empty());
    for (const auto& asset : sequence["assets"]) EXPECT_NE(asset["licence"], "unknown") << asset;
    for (const auto& camera : sequence["cameras"]) {
      ++camera_sequences;
      const fs::path folder = dir / "a" / camera["sequence"].get<std::string>();
      EXPECT_GE(camera["valid"].get<double>(), 0.3) << folder;  // cameras.min_valid
      const std::string figures = run_reader(folder);
      ASSERT_FALSE(contains(figures, "FAILED")) << folder << ": " << figures;
      EXPECT_EQ(nlohmann::json::parse(figures)["frames"], 31);
    }
  }
  // The totals per split add up over the sequences.
  long sequences = 0, frames = 0;
  for (const auto& [split, totals] : a["splits"].items()) {
    sequences += totals["sequences"].get<long>();
    frames += totals["frames"].get<long>();
    EXPECT_GT(totals["visible_share"].get<double>(), 0.0);
    EXPECT_GT(totals["average_track_span_frames"].get<double>(), 0.3 * 31);
    EXPECT_EQ(totals["point_annotations"].get<long>() / 31, totals["tracks"].get<long>());
  }
  EXPECT_EQ(sequences, camera_sequences);
  EXPECT_EQ(frames, 31 * camera_sequences);

  // One worker: the same bytes.
  result = run_cli(base + quoted(dir / "b") + " --jobs 1");
  ASSERT_EQ(result.exit_code, 0) << result.output;
  expect_same_dataset(dir / "a", dir / "b");

  // Shards into one folder, then the merged report: the same dataset, and sequence 1 made alone
  // (shard 2 of 3) equals sequence 1 of the whole.
  for (const char* shard : {"1/3", "2/3", "3/3"}) {
    result = run_cli(base + quoted(dir / "c") + " --jobs 1 --shard " + shard);
    ASSERT_EQ(result.exit_code, 0) << result.output;
  }
  result = run_cli("dataset-report " + quoted(dir / "c"));
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_TRUE(contains(result.output, "dataset 3 sequences: 3 done, 0 failed, 0 not run")) << result.output;
  expect_same_dataset(dir / "a", dir / "c");
  EXPECT_EQ(manifest(dir / "c")["splits"], a["splits"]);

  // A run that dies in sequence 1 (the fault injection aborts its worker) keeps the others; the
  // rerun makes only it, and the dataset equals the uninterrupted one.
  ::setenv("ODYSSEY_BATCH_FAULT", "crash:t_00001", 1);
  result = run_cli(base + quoted(dir / "d") + " --jobs 2");
  ::unsetenv("ODYSSEY_BATCH_FAULT");
  EXPECT_EQ(result.exit_code, 1) << result.output;
  EXPECT_TRUE(contains(result.output, "2 done (0 earlier), 1 failed")) << result.output;
  result = run_cli(base + quoted(dir / "d") + " --jobs 2");
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_TRUE(contains(result.output, "3 done (2 earlier), 0 failed")) << result.output;
  expect_same_dataset(dir / "a", dir / "d");

  // More sequences leave the first three as they were.
  const auto before = dataset_files(dir / "d");
  result = run_cli("dataset " + quoted(recipe) + " --count 4 --quiet --jobs 2 --out " + quoted(dir / "d"));
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_TRUE(contains(result.output, "4 done (3 earlier)")) << result.output;
  const auto after = dataset_files(dir / "d");
  for (const auto& [name, text] : before) EXPECT_TRUE(after.at(name) == text) << name;
  EXPECT_GT(after.size(), before.size());

  // A scene file of the dataset re-makes its sequences.
  const nlohmann::json& first = a["sequences"][0];
  result = run_cli("scene " + quoted(dir / "a" / first["scene_file"].get<std::string>()) + " --out " + quoted(dir / "e") + " --quiet");
  ASSERT_EQ(result.exit_code, 0) << result.output;
  for (const auto& camera : first["cameras"]) {
    const std::string folder = fs::path(camera["sequence"].get<std::string>()).filename().string();
    EXPECT_TRUE(read(dir / "e" / folder / "anno.npz") == read(dir / "a" / camera["sequence"].get<std::string>() / "anno.npz")) << folder;
  }
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    EXPECT_FALSE(contains(entry.path().filename().string(), ".partial-")) << "left behind: " << entry.path();
  }
  EXPECT_FALSE(fs::exists(dir / "a" / ".staging"));
}

TEST(DatasetRunTest, BrokenAssetFailsOnlyTheSequencesThatDrewIt) {
  const fs::path dir = scratch();
  const fs::path broken = write(dir / "motions" / "broken.bvh", "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0\n");
  fs::copy_file(kData + "/mocap/cmu_walk_cgspeed.bvh", dir / "motions" / "walk.bvh");
  const fs::path recipe = write(dir / "recipe.json", small_recipe("\"" + (dir / "motions").string() + "\""));
  const auto result = run_cli("dataset " + quoted(recipe) + " --count 6 --jobs 2 --quiet --out " + quoted(dir / "out"));
  EXPECT_EQ(result.exit_code, 1) << result.output;
  const nlohmann::json report = manifest(dir / "out");
  ASSERT_GT(report["failures"].size(), 0u) << result.output;
  ASSERT_GT(report["sequences"].size(), 0u) << result.output;
  for (const auto& failure : report["failures"]) EXPECT_TRUE(contains(failure["error"], broken.string())) << failure;
  for (const auto& sequence : report["sequences"]) {
    for (const auto& asset : sequence["assets"]) EXPECT_NE(asset["path"], broken.string());
  }
  // Nothing of a failed sequence is left in the dataset.
  for (const auto& failure : report["failures"]) {
    EXPECT_FALSE(fs::exists(dir / "out" / "scenes" / (failure["sequence"].get<std::string>() + ".json")));
  }
}

TEST(DatasetRunTest, TheExampleRunsAsPrinted) {
  REQUIRE_NUMPY();
  const fs::path dir = scratch();
  const auto printed = run_cli("dataset --print-example");
  ASSERT_EQ(printed.exit_code, 0) << printed.output;
  EXPECT_TRUE(contains(printed.output, "\"version\": 1")) << printed.output;
  const auto result = run_cli("dataset --example --count 2 --jobs 2 --quiet --out " + quoted(dir / "out"));
  ASSERT_EQ(result.exit_code, 0) << result.output;
  const nlohmann::json report = manifest(dir / "out");
  ASSERT_EQ(report["sequences"].size(), 2u);
  for (const auto& sequence : report["sequences"]) {
    for (const auto& camera : sequence["cameras"]) {
      const std::string figures = run_reader(dir / "out" / camera["sequence"].get<std::string>());
      EXPECT_FALSE(contains(figures, "FAILED")) << camera << ": " << figures;
    }
  }
}

TEST(DatasetCliTest, BadRecipesFailInOneLineAndWriteNothing) {
  const fs::path dir = scratch();
  const fs::path out = dir / "out";
  const auto expect_refused = [&](const std::string& arguments, const std::string& message) {
    const auto result = run_cli(arguments);
    EXPECT_NE(result.exit_code, 0) << arguments;
    EXPECT_TRUE(contains(result.output, message)) << result.output;
    EXPECT_FALSE(fs::exists(out)) << arguments;
  };
  std::string recipe = small_recipe();
  const fs::path unknown = write(dir / "unknown.json", recipe.insert(recipe.rfind('}'), R"(, "lights": 2)"));
  expect_refused("dataset " + quoted(unknown) + " --out " + quoted(out), unknown.string() + ": lights: unknown key");
  const fs::path empty_folder = dir / "no_motions";
  fs::create_directories(empty_folder);
  const fs::path no_motions = write(dir / "no_motions.json", small_recipe("\"" + empty_folder.string() + "\""));
  expect_refused("dataset " + quoted(no_motions) + " --out " + quoted(out), no_motions.string() + ": libraries.motions[0].path: no usable motion");
  std::string three = small_recipe();
  three.replace(three.find(R"("splits": {"train": 0.5, "test": 0.5})"), 37, R"("splits": {"train": 0.8, "val": 0.1, "test": 0.1, "by": "motion"})");
  const fs::path splits = write(dir / "splits.json", three);
  expect_refused("dataset " + quoted(splits) + " --out " + quoted(out),
                 splits.string() + ": splits: 3 splits by motion need at least 3 motions, the libraries hold 1");
  expect_refused("dataset " + quoted(dir / "missing.json") + " --out " + quoted(out), (dir / "missing.json").string());
  expect_refused("dataset --out " + quoted(out), "give a RECIPE, or --example");
  expect_refused("dataset " + quoted(unknown) + " --example --out " + quoted(out), "give a RECIPE, or --example");
  expect_refused("dataset --example --count 0 --out " + quoted(out), "--count expects 1 to 1000000");
}

// The cluster answers when sinfo lists an idle, mixed or allocated node.
std::string slurm_missing() {
  if (std::system("command -v sbatch > /dev/null 2>&1") != 0) return "sbatch is not installed";
  if (std::system("sinfo -h -o %T 2>/dev/null | grep -qE '^(idle|mixed|allocated)'") != 0) {
    return "no Slurm cluster answers (start one with: sudo bash scripts/slurm-local.sh start)";
  }
  return "";
}

TEST(DatasetSlurm, TheScriptRunOnARealClusterEqualsALocalRun) {
  if (const std::string missing = slurm_missing(); !missing.empty()) {
    const char* required = std::getenv("ODYSSEY_REQUIRE_SLURM");
    if (required && std::string(required) == "1") FAIL() << missing;
    GTEST_SKIP() << missing;
  }
  const fs::path dir = scratch();
  const fs::path recipe = write(dir / "recipe.json", small_recipe());
  const std::string base = "dataset " + quoted(recipe) + " --count 3 --quiet --out ";
  auto result = run_cli(base + quoted(dir / "local") + " --jobs 2");
  ASSERT_EQ(result.exit_code, 0) << result.output;
  const fs::path out = dir / "cluster", script = dir / "dataset.sbatch";
  result = run_cli(base + quoted(out) + " --slurm-script " + quoted(script) + " --slurm-tasks 2 --slurm-cpus 1 --slurm-mem 1500 --slurm-time 20");
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_TRUE(contains(result.output, "3 sequences in 2 shards of 1 CPUs each")) << result.output;
  EXPECT_TRUE(contains(result.output, "then: odyssey dataset-report")) << result.output;
  const int status = std::system(("sbatch --wait " + quoted(script) + " > " + quoted(dir / "sbatch.txt") + " 2>&1").c_str());
  EXPECT_EQ(status, 0) << read(dir / "sbatch.txt");
  result = run_cli("dataset-report " + quoted(out));
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_TRUE(contains(result.output, "dataset 3 sequences: 3 done, 0 failed, 0 not run")) << result.output;
  expect_same_dataset(dir / "local", out);
}

}  // namespace
}  // namespace odyssey
