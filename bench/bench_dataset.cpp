// Whole-process speed and peak memory of `odyssey dataset` making full-size sequences, as a user
// runs it: a recipe over the shared characters (RiggedFigure, CesiumMan, RobotExpressive) and
// generated AMASS-style SMPL-X walks long enough for the shot (75 to 90 s at 60 fps, seeded; the
// synthetic body model), 2,000 frames at 30 fps per shot, 3 or 4 people together, 3 cameras
// (static, orbit, swoop, a RealEstate10K track or a head camera), 5,000 points per person and
// 1,000 on the props (about 18,700 tracks per camera), six scattered props kicked about, depth,
// normals and masks at 960x540, fast retargeting, --jobs = the core count. Rows:
//
//   dataset   the measured run: sequences, shot frames, camera-frames, tracks per camera
//             sequence, wall time, camera-frames/s, the largest process's peak resident set;
//   pointodyssey  what PointOdyssey's size (104 sequences, 216,000 frames) would take at that
//             rate on this machine, and on a Slurm cluster of 8 and 32 such nodes (one shard each).
//
// Arguments: the sequence count (default 8) and the frames per shot (default 2000).
// ODYSSEY_BENCH_KEEP=1 keeps the inputs and outputs.
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "bench/machine.h"
#include "bench/timed_process.h"
#include "mocap_io/amass.h"
#include "synthetic/synthetic_walk.h"

namespace {

namespace fs = std::filesystem;

const std::string kShared = ODYSSEY_SHARED_DIR;
constexpr double kPointOdysseySequences = 104, kPointOdysseyFrames = 216000;

std::string recipe_json(const fs::path& clips, int frames) {
  const std::string assets = kShared + "/assets";
  nlohmann::ordered_json recipe = {
      {"version", 1},
      {"name", "bench"},
      {"seed", 1},
      {"libraries",
       {{"characters", {assets + "/characters/RiggedFigure.glb", assets + "/characters/CesiumMan.glb", assets + "/characters/RobotExpressive.glb"}},
        {"motions", {clips.string()}},
        {"props", {{{"path", assets + "/props/kenney_brick.glb"}, {"scale", {0.2, 0.4}}}}},
        {"camera_tracks", {assets + "/cameras/realestate10k"}}}},
      {"shots",
       {{"fps", 30}, {"seconds", (frames - 1) / 30.0}, {"actors", {3, 4}}, {"arrangement", {{"together", 1}}},
        {"together_radius", {1.5, 2.5}}, {"quality", {{"fast", 1}}}}},
      {"cameras", {{"count", 3}, {"kinds", {{"static", 1}, {"orbit", 1}, {"swoop", 1}, {"track", 1}, {"ego", 1}}}}},
      {"props", {{"scatter", 6}, {"force_rate", 0.1}}},
      {"points", {{"per_actor", 5000}, {"props", 1000}}},
      {"outputs", {{"depth", true}, {"normals", true}, {"masks", true}}},
      {"splits", {{"train", 1}}}};
  return recipe.dump(2);
}

}  // namespace

int main(int argc, char** argv) {
  const int sequences = argc > 1 ? std::atoi(argv[1]) : 8;
  const int frames = argc > 2 ? std::atoi(argv[2]) : 2000;
  if (sequences < 1 || frames < 31) {
    std::fprintf(stderr, "usage: bench_dataset [SEQUENCES (8)] [FRAMES per shot (2000), at least 31]\n");
    return 2;
  }
  const fs::path dir = fs::temp_directory_path() / ("odyssey_bench_dataset_" + std::to_string(::getpid()));
  const fs::path clips = dir / "clips", out = dir / "out";
  fs::create_directories(clips);
  // Walks 15 to 30 s longer than the shot: the drawn start leaves room on each.
  for (int i = 0; i < 12; ++i) {
    const int clip_frames = static_cast<int>((frames / 30.0 + 15 + i * 15.0 / 11) * 60);
    char name[32];
    std::snprintf(name, sizeof name, "walk_%02d.npz", i);
    odyssey::io::write_amass((clips / name).string(),
                             odyssey::synthetic_walk(clip_frames, 60, odyssey::BodyModelKind::SMPLX, 100 + static_cast<unsigned>(i)));
  }
  std::ofstream(dir / "recipe.json") << recipe_json(clips, frames);
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  const std::string command = std::string(ODYSSEY_CLI) + " dataset " + (dir / "recipe.json").string() + " --out " + out.string() +
                              " --count " + std::to_string(sequences) + " --jobs " + std::to_string(cores) + " --quiet > " +
                              (dir / "log.txt").string() + " 2>&1";
  const odyssey::bench::TimedProcess run = odyssey::bench::run_timed(command);
  if (run.exit_code != 0) {
    std::fprintf(stderr, "odyssey dataset failed (exit %d); see %s\n", run.exit_code, (dir / "log.txt").c_str());
    return 1;
  }
  const nlohmann::json report = nlohmann::json::parse(std::ifstream(out / "dataset.json"));
  long shot_frames = 0, camera_frames = 0, tracks = 0, camera_sequences = 0, redraws = 0;
  for (const auto& sequence : report["sequences"]) {
    shot_frames += sequence["frames"].get<long>();
    redraws += sequence["redraws"].get<long>();
    for (const auto& camera : sequence["cameras"]) {
      camera_frames += sequence["frames"].get<long>();
      tracks += camera["tracks"].get<long>();
      ++camera_sequences;
    }
  }
  const double seconds_per_frame = run.seconds / static_cast<double>(shot_frames);
  const double pointodyssey_s = seconds_per_frame * kPointOdysseyFrames;

  double load[3] = {0, 0, 0};
  ::getloadavg(load, 3);
  std::printf("machine: %s, %u threads; load average at the end %.2f\n", odyssey::bench::cpu_model().c_str(), cores, load[0]);
  std::printf("| what | size | wall | rate | peak memory |\n|---|---|---|---|---|\n");
  std::printf("| dataset, %u workers | %zu sequences (%ld redraws), %ld shot frames, %ld camera sequences of %ld tracks on average, "
              "960x540 depth, normals, masks | %.0f s (%.0f s a sequence) | %.1f camera-frames/s | %.0f MiB |\n",
              cores, report["sequences"].size(), redraws, shot_frames, camera_sequences, tracks / std::max(1L, camera_sequences),
              run.seconds, run.seconds / static_cast<double>(report["sequences"].size()), static_cast<double>(camera_frames) / run.seconds,
              run.peak_mib);
  std::printf("| PointOdyssey's size at this rate | %.0f sequences, %.0f shot frames, 3 cameras each | %.1f h on this machine; "
              "%.1f h on 8 such nodes; %.1f h on 32 | | |\n",
              kPointOdysseySequences, kPointOdysseyFrames, pointodyssey_s / 3600, pointodyssey_s / 3600 / 8, pointodyssey_s / 3600 / 32);
  if (!std::getenv("ODYSSEY_BENCH_KEEP")) fs::remove_all(dir);
  return 0;
}
