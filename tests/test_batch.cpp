// The batch library's parts that need no worker processes (batch/): input lists and job names,
// manifests (JSON and CSV) and their errors, the CSV reader, shard specs (Slurm's variables
// included), the journal (torn lines, other settings), gates and the report files. The runs
// themselves (workers, faults, resume after SIGKILL, shards, Slurm) are in test_batch_cli.cpp.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "batch/batch.h"
#include "batch/journal.h"
#include "batch/report.h"
#include "batch/slurm_script.h"
#include "mocap_io/csv_file.h"
#include "mocap_io/input_error.h"
#include "test_support.h"

namespace odyssey::batch {
namespace {

namespace fs = std::filesystem;
using test_support::contains;
using test_support::message_of;

fs::path scratch() { return test_support::scratch_dir("batch"); }

void write(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

std::string read(const fs::path& path) {
  std::ifstream file(path, std::ios::binary);
  std::stringstream text;
  text << file.rdbuf();
  return text.str();
}

std::vector<std::string> names_of(const std::vector<Job>& jobs) {
  std::vector<std::string> names;
  for (const Job& job : jobs) names.push_back(job.name);
  return names;
}

TEST(BatchInputs, FoldersGlobsAndFilesNameTheJobsByTheirPathBelowTheRoot) {
  const fs::path dir = scratch();
  for (const char* file : {"amass/CMU/01/01_01_poses.npz", "amass/CMU/02/02_05_poses.npz", "amass/notes.txt",
                           "bvh/walk.bvh", "bvh/jump.BVH", "chars/Robot.glb", "chars/Robot.map.json", "chars/sub/Fox.gltf"}) {
    write(dir / file, "x");
  }
  const auto motions = find_input_files({(dir / "amass").string(), (dir / "bvh/*.bvh").string(), (dir / "bvh/jump.BVH").string()},
                                        kMotionExtensions, "motion");
  std::vector<std::string> names;
  for (const FoundFile& file : motions) names.push_back(file.name);
  EXPECT_EQ(names, (std::vector<std::string>{"CMU/01/01_01_poses", "CMU/02/02_05_poses", "walk", "jump"}));

  const auto characters = find_input_files({(dir / "chars").string()}, kCharacterExtensions, "character");
  ASSERT_EQ(characters.size(), 2u);
  JobDefaults defaults;
  const std::vector<Job> jobs = cross_product_jobs(motions, characters, defaults);
  ASSERT_EQ(jobs.size(), 8u);
  EXPECT_EQ(jobs[0].name, "Robot/CMU/01/01_01_poses");
  EXPECT_EQ(jobs[1].name, "sub/Fox/CMU/01/01_01_poses");
  // Robot.map.json beside Robot.glb is Robot's bone map; Fox has none.
  ASSERT_TRUE(jobs[0].request.map_path.has_value());
  EXPECT_EQ(fs::path(*jobs[0].request.map_path).filename(), "Robot.map.json");
  EXPECT_FALSE(jobs[1].request.map_path.has_value());
  EXPECT_NO_THROW(check_job_names(jobs));
}

TEST(BatchInputs, MissingPathsEmptyFoldersAndEmptyGlobsAreNamed) {
  const fs::path dir = scratch();
  fs::create_directories(dir / "empty");
  write(dir / "empty/readme.txt", "not a motion");
  EXPECT_TRUE(contains(message_of<io::InputError>([&] { find_input_files({(dir / "nope.bvh").string()}, kMotionExtensions, "motion"); }),
                       "nope.bvh: no such file or folder"));
  EXPECT_TRUE(contains(message_of<io::InputError>([&] { find_input_files({(dir / "empty").string()}, kMotionExtensions, "motion"); }),
                       "the folder holds no motion file"));
  EXPECT_TRUE(contains(message_of<io::InputError>([&] { find_input_files({(dir / "*.glb").string()}, kCharacterExtensions, "character"); }),
                       "the pattern matches no character file"));
}

TEST(BatchInputs, JobNamesThatCollideEscapeOrNestAreRefused) {
  Job a, b;
  a.name = "Robot/walk";
  b.name = "Robot/walk";
  a.source = b.source = "lists";
  EXPECT_TRUE(contains(message_of<std::invalid_argument>([&] { check_job_names({a, b}); }), "two jobs would write into Robot/walk"));
  b.name = "Robot/walk/fast";
  Job between = a;
  between.name = "Robot/walk-2";  // sorts between "Robot/walk" and "Robot/walk/fast"
  const std::string nested = message_of<std::invalid_argument>([&] { check_job_names({a, between, b}); });
  EXPECT_TRUE(contains(nested, "would hold job Robot/walk/fast (lists) in its folder")) << nested;
  b.name = "Robot/walker";
  EXPECT_NO_THROW(check_job_names({a, between, b}));
  for (const char* bad : {"../up", "/abs", "a/./b", ""}) {
    b.name = bad;
    EXPECT_THROW(check_job_names({a, b}), std::invalid_argument) << bad;
  }
}

TEST(BatchManifest, JsonAndCsvRowsResolvePathsAgainstTheManifestAndOverrideTheDefaults) {
  const fs::path dir = scratch();
  write(dir / "jobs.json", R"({"jobs": [
    {"motion": "m/walk.bvh", "character": "c/Robot.glb", "quality": "accurate", "fps": 60, "bvh_units": "cmu"},
    {"name": "custom/name", "motion": "/abs/jump.npz", "character": "c/Fox.glb", "outputs": ["glb", "trajectories"]},
    {"scene": "s/shot.json"}
  ]})");
  JobDefaults defaults;
  defaults.request.fps = 30;
  const std::vector<Job> jobs = read_manifest((dir / "jobs.json").string(), defaults);
  ASSERT_EQ(jobs.size(), 3u);
  EXPECT_EQ(names_of(jobs), (std::vector<std::string>{"Robot/walk", "custom/name", "shot"}));
  EXPECT_EQ(jobs[0].request.motion_path, (dir / "m/walk.bvh").string());
  EXPECT_EQ(jobs[0].request.quality, retarget::Quality::accurate);
  EXPECT_DOUBLE_EQ(jobs[0].request.fps, 60);
  ASSERT_TRUE(jobs[0].request.bvh_metres_per_unit.has_value());
  EXPECT_NEAR(*jobs[0].request.bvh_metres_per_unit, 0.056444, 1e-9);
  EXPECT_EQ(jobs[1].request.motion_path, "/abs/jump.npz");
  EXPECT_DOUBLE_EQ(jobs[1].request.fps, 30);
  EXPECT_EQ(job_outputs_text(jobs[1].outputs), "glb,trajectories");
  EXPECT_EQ(jobs[2].scene_path, (dir / "s/shot.json").string());

  write(dir / "jobs.csv", "motion,character,quality,name\r\nm/walk.bvh,c/Robot.glb,fast,\r\n\"m/a, b.bvh\",c/Robot.glb,,\"quoted \"\"name\"\"\"\r\n");
  const std::vector<Job> rows = read_manifest((dir / "jobs.csv").string(), defaults);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].name, "Robot/walk");
  EXPECT_EQ(rows[1].request.motion_path, (dir / "m/a, b.bvh").string());
  EXPECT_EQ(rows[1].name, "quoted \"name\"");
}

TEST(BatchManifest, ErrorsNameTheManifestTheRowAndTheColumn) {
  const fs::path dir = scratch();
  const auto error_of = [&](const std::string& file, const std::string& text) {
    write(dir / file, text);
    return message_of<io::InputError>([&] { read_manifest((dir / file).string(), JobDefaults{}); });
  };
  const std::string csv = (dir / "m.csv").string();
  EXPECT_EQ(error_of("m.csv", "motion,character,fps\na.bvh,b.glb,30\na.bvh,c.glb,fast\n"),
            csv + ": line 3, column fps: expected a frame rate above 0, got 'fast'");
  EXPECT_EQ(error_of("m.csv", "motion,character,colour\na.bvh,b.glb,red\n"),
            csv + ": line 1, column 3: unknown column 'colour' (columns: betas, bvh_units, character, fps, map, model, "
                  "motion, name, outputs, parts, quality, scene, source_map)");
  EXPECT_TRUE(contains(error_of("m.csv", "motion,character\na.bvh,b.glb\n\"unterminated,b.glb\n"), "line 3"));
  // A spreadsheet's UTF-8 byte-order mark is not part of the first column's name.
  write(dir / "bom.csv", "\xEF\xBB\xBFmotion,character\na.bvh,b.glb\n");
  EXPECT_EQ(read_manifest((dir / "bom.csv").string(), JobDefaults{}).size(), 1u);
  // A key given twice in one object is refused, naming its path (nlohmann would keep the last).
  EXPECT_TRUE(contains(error_of("m.json", R"({"jobs": [{"motion": "a.bvh", "character": "b.glb"}, {"motion": "a.bvh", "character": "b.glb", "motion": "c.bvh"}]})"),
                       "m.json: jobs[1].motion: the key \"motion\" is given twice in one object"));
  EXPECT_EQ(error_of("m.csv", "motion,character\na.bvh,b.glb\nb.bvh\n"),
            csv + ": line 3: 1 fields, the header has 2");
  EXPECT_EQ(error_of("m.csv", "motion,character,quality\na.bvh,,fast\n"),
            csv + ": line 2, column character: missing (a row names a motion and a character, or a scene)");
  const std::string json = (dir / "m.json").string();
  EXPECT_TRUE(contains(error_of("m.json", R"({"jobs": [{"motion": "a.bvh", "character": "b.glb"}, {"motion": "a.bvh", "character": "b.glb", "quality": "best"}]})"),
                       "jobs[1].quality: expected fast, balanced or accurate, got 'best'"));
  EXPECT_TRUE(contains(error_of("m.json", R"([{"motion": "a.bvh", "character": "b.glb", "fps": true}])"), "[0].fps: expected a string"));
  EXPECT_TRUE(contains(error_of("m.json", R"({"jobs": [{"scene": "s.json", "quality": "fast"}]})"),
                       "jobs[0].quality: a scene row takes its settings from the scene file"));
  EXPECT_TRUE(contains(error_of("m.json", R"({"jobs": [1, 2]})"), "jobs[0]"));
  EXPECT_TRUE(contains(error_of("m.yaml", "jobs: []"), "m.yaml"));
}

TEST(BatchCsv, QuotedFieldsLineBreaksAndLineNumbers) {
  const io::CsvTable table = io::parse_csv("a,b\n1,\"two\nlines\"\n\n3,\"x\"\"y\"", "t.csv");
  ASSERT_EQ(table.rows.size(), 2u);
  EXPECT_EQ(table.rows[0].line, 2);
  EXPECT_EQ(table.rows[0].cells[1], "two\nlines");
  EXPECT_EQ(table.rows[1].line, 5);
  EXPECT_EQ(table.rows[1].cells[1], "x\"y");
  EXPECT_EQ(message_of<io::InputError>([] { io::parse_csv("a,a\n", "t.csv"); }), "t.csv: line 1: column 'a' appears twice");
  EXPECT_TRUE(contains(message_of<io::InputError>([] { io::parse_csv("a\n\"x\"y\n", "t.csv"); }), "t.csv: line 2"));
}

TEST(BatchShard, SpecsAndSlurmArrays) {
  EXPECT_EQ(parse_shard("2/3").text(), "2/3");
  EXPECT_TRUE(parse_shard("1/1").whole());
  for (const char* bad : {"3/2", "0/0", "0/2", "1/0", "a/b", "2", "-1/2", "1/2/3", ""}) {
    EXPECT_THROW(parse_shard(bad), std::invalid_argument) << bad;
  }
  EXPECT_TRUE(contains(message_of<std::invalid_argument>([] { parse_shard("3/2"); }), "I must be 1 to N"));

  ::unsetenv("SLURM_ARRAY_TASK_ID");
  EXPECT_TRUE(contains(message_of<std::invalid_argument>([] { parse_shard("slurm"); }), "not in a Slurm job array"));
  ::setenv("SLURM_ARRAY_TASK_ID", "3", 1);
  ::setenv("SLURM_ARRAY_TASK_COUNT", "4", 1);
  ::setenv("SLURM_ARRAY_TASK_MIN", "1", 1);  // --array=1-4
  EXPECT_EQ(parse_shard("slurm").text(), "3/4");
  ::setenv("SLURM_ARRAY_TASK_MIN", "0", 1);  // --array=0-3
  EXPECT_EQ(parse_shard("slurm").text(), "4/4");
  ::setenv("SLURM_ARRAY_TASK_ID", "9", 1);
  EXPECT_THROW(parse_shard("slurm"), std::invalid_argument);
  for (const char* name : {"SLURM_ARRAY_TASK_ID", "SLURM_ARRAY_TASK_COUNT", "SLURM_ARRAY_TASK_MIN"}) ::unsetenv(name);
}

TEST(BatchJournal, RecordsSurviveATornLastLineAndAnotherBatchsFolderIsRefused) {
  const fs::path dir = scratch();
  const nlohmann::ordered_json settings = {{"quality", "fast"}};
  {
    Journal journal(dir.string(), "", settings, 3);
    journal.append({{"job", "a"}, {"status", "failed"}, {"error", "x"}});
    journal.append({{"job", "b"}, {"status", "done"}, {"key", "k"}});
    journal.append({{"job", "a"}, {"status", "done"}, {"key", "k2"}});
  }
  // A SIGKILL in the middle of a write leaves a line without its end.
  { std::ofstream(dir / "journal.jsonl", std::ios::app) << R"({"job": "c", "status": "do)"; }
  {
    Journal journal(dir.string(), "", settings, 3);
    ASSERT_EQ(journal.records().size(), 2u);
    EXPECT_EQ(journal.records().at("a")["status"], "done");  // the last record of a name wins
    EXPECT_EQ(journal.records().at("a")["key"], "k2");
    journal.append({{"job", "c"}, {"status", "done"}, {"key", "k3"}});
  }
  const JournalContents contents = read_journals(dir.string());
  EXPECT_EQ(contents.records.size(), 3u);
  EXPECT_EQ(contents.records.at("c")["key"], "k3");

  const std::string error = message_of<io::InputError>([&] { Journal(dir.string(), "2/2", {{"quality", "accurate"}}, 1); });
  EXPECT_TRUE(contains(error, "journal.jsonl")) << error;
  EXPECT_TRUE(contains(error, "quality")) << error;
  EXPECT_THROW(read_journals((dir / "none").string()), io::InputError);
}

TEST(BatchJournal, FileHashesFollowContentNotTime) {
  const fs::path dir = scratch();
  write(dir / "a.bvh", "HIERARCHY");
  write(dir / "b.bvh", "HIERARCHY");
  EXPECT_EQ(hash_file((dir / "a.bvh").string()), hash_file((dir / "b.bvh").string()));
  EXPECT_EQ(hash_file((dir / "a.bvh").string()), hash_text("HIERARCHY"));
  EXPECT_NE(hash_text("HIERARCHY"), hash_text("HIERARCHZ"));
  EXPECT_EQ(hash_text("x").size(), 16u);
  FileHasher hasher;
  const nlohmann::json stamp = hasher.stamp((dir / "a.bvh").string());
  EXPECT_EQ(stamp["size"], 9);
  write(dir / "a.bvh", "HIERARCHY 2");
  FileHasher fresh;
  fresh.remember((dir / "a.bvh").string(), stamp);  // stale: the size changed
  EXPECT_EQ(fresh.hash((dir / "a.bvh").string()), hash_text("HIERARCHY 2"));
  EXPECT_THROW(hash_file((dir / "missing").string()), io::InputError);
}

TEST(BatchReport, GatesFlagDoneJobsAndTheCsvHasAColumnPerLimb) {
  const fs::path dir = scratch();
  JournalContents contents;
  contents.headers.push_back({{"settings", {{"quality", "fast"}}}, {"shard", "1/1"}, {"planned_jobs", 4}});
  const nlohmann::json metrics = {{"bone_error_mean_deg", 1.5}, {"bone_error_max_deg", 4.0}, {"worst_limb_mean_deg", 2.5},
                                  {"limbs_mean_deg", {{"left_thigh", 2.5}, {"spine", 1.0}}},
                                  {"skate", 0.3},  {"source_skate", 0.07}, {"penetration_cm", 0.2},
                                  {"floating_cm", 1.2}, {"jitter", 30.0}, {"source_jitter", 20.0}};
  contents.records["R/walk"] = {{"job", "R/walk"}, {"status", "done"}, {"frames", 100}, {"seconds", 1.5}, {"metrics", metrics}};
  contents.records["R/jump"] = {{"job", "R/jump"}, {"status", "failed"}, {"error", "jump.bvh: line 9: truncated, \"x\""}};
  Gates gates;
  gates.max_skate = 0.25;
  gates.max_jitter_ratio = 1.3;
  gates.max_floating_cm = 2;
  EXPECT_EQ(gate_flags(metrics, gates), (std::vector<std::string>{"skate 0.3 > 0.25", "jitter ratio 1.5 > 1.3"}));
  EXPECT_TRUE(gate_flags(metrics, Gates{}).empty());

  write_batch_report(dir.string(), contents, gates);
  const nlohmann::json report = nlohmann::json::parse(read(dir / "report.json"));
  EXPECT_EQ(report["batch"]["jobs"], 2);
  EXPECT_EQ(report["batch"]["done"], 1);
  EXPECT_EQ(report["batch"]["failed"], 1);
  EXPECT_EQ(report["batch"]["flagged"], 1);
  EXPECT_EQ(report["batch"]["not_run"], 2);
  EXPECT_EQ(report["batch"]["frames"], 100);
  EXPECT_EQ(report["gates"]["max_skate"], 0.25);
  const std::string csv = read(dir / "report.csv");
  const io::CsvTable table = io::parse_csv(csv, "report.csv");  // quoting round-trips through the reader
  ASSERT_EQ(table.rows.size(), 2u);
  EXPECT_EQ(table.header.back(), "spine_mean_deg");
  EXPECT_EQ(table.rows[0].cells[0], "R/jump");
  EXPECT_EQ(table.rows[0].cells[*table.column("error")], "jump.bvh: line 9: truncated, \"x\"");
  EXPECT_EQ(table.rows[1].cells[*table.column("flags")], "skate 0.3 > 0.25; jitter ratio 1.5 > 1.3");
  EXPECT_EQ(table.rows[1].cells[*table.column("left_thigh_mean_deg")], "2.5");
  EXPECT_EQ(table.rows[1].cells[*table.column("frames")], "100");
}

TEST(BatchSlurm, TheScriptRunsTheSameBatchShardedByTheArray) {
  SlurmScriptOptions options;
  options.tasks = 6;
  options.cpus_per_task = 4;
  options.memory_mb = 8192;
  options.time_limit_minutes = 90;
  options.partition = "gpu";
  options.working_folder = "/data/project";
  options.log_folder = "/data/out";
  options.command = {"/opt/odyssey/bin/odyssey", "batch", "--motions", "it's.bvh", "--out", "out"};
  const std::string script = slurm_script(options);
  for (const char* line : {"#!/bin/bash\n", "#SBATCH --array=1-6\n", "#SBATCH --cpus-per-task=4\n", "#SBATCH --mem=8192M\n",
                           "#SBATCH --time=1:30:00\n", "#SBATCH --partition=gpu\n", "#SBATCH --chdir=/data/project\n",
                           "#SBATCH --output=/data/out/slurm-%A_%a.log\n",
                           "exec '/opt/odyssey/bin/odyssey' 'batch' '--motions' 'it'\\''s.bvh' '--out' 'out' --shard slurm "
                           "--jobs \"${SLURM_CPUS_PER_TASK:-4}\"\n"}) {
    EXPECT_TRUE(contains(script, line)) << line << "\n" << script;
  }
}

}  // namespace
}  // namespace odyssey::batch
