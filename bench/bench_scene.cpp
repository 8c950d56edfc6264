// Whole-process speed and peak memory of `odyssey scene` on a shot the size of the dataset's: four
// actors (the CMU jump retargeted at balanced onto four characters, slowed to fill the shot),
// 20,000 tracked points (4,000 on each actor, 4,000 on the props), three 960x540 cameras (static,
// orbit, ego on the first actor's head), a ground and four boxes; trajectories, camera paths and
// the report written. Three shots: the shared characters (a few thousand vertices), the same with
// characters as dense as a dataset's (the shared ones subdivided to 36,000-41,000 vertices), and the
// dense one written as PointOdyssey sequences with depth, normals and masks (one folder per
// camera, every frame's three images encoded). Each row is one run of the release binary as a user types it, timed wall
// clock, with the child's peak resident set from wait4; rows at two lengths show whether memory
// stays flat as the clip grows. Prints a table. Arguments: the frame counts (default 500 2000);
// ODYSSEY_BENCH_KEEP=1 keeps the scene files, logs and outputs.
#include <unistd.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "bench/machine.h"
#include "bench/timed_process.h"
#include "mocap_io/gltf_subdivide.h"

namespace {

namespace fs = std::filesystem;
using odyssey::bench::run_timed;

const std::string kShared = ODYSSEY_SHARED_DIR;

// One row of the table: the shot's characters and what it writes.
struct Shot {
  std::string label;
  std::array<std::string, 4> characters;  // paths
  std::string outputs;                    // extra keys of the scene's outputs
};

std::string scene_json(int frames, const Shot& shot) {
  const std::string jump = kShared + "/assets/mocap/cmu_jump_cgspeed.bvh";
  const auto& characters = shot.characters;
  // Each starts 2.5 m out on a diagonal and faces away from the centre, so the four jump apart.
  const double xs[] = {-1.8, 1.8, 1.8, -1.8}, ys[] = {-1.8, -1.8, 1.8, 1.8}, yaws[] = {225, 315, 45, 135};
  // The jump lasts 22.9 s; slowed so that it covers the shot.
  const double speed = 22.9 / (frames / 30.0);
  std::string actors;
  for (int a = 0; a < 4; ++a) {
    actors += std::string(a ? ",\n" : "") + "    {\"name\": \"actor" + std::to_string(a) + "\", \"motion\": \"" + jump +
              "\", \"bvh_units\": \"cmu\", \"character\": \"" + characters[a] +
              "\", \"quality\": \"balanced\", \"placement\": {\"x\": " + std::to_string(xs[a]) + ", \"y\": " +
              std::to_string(ys[a]) + ", \"yaw\": " + std::to_string(yaws[a]) + "}, \"speed\": " + std::to_string(speed) +
              ", \"points\": 4000}";
  }
  return "{\n  \"version\": 1, \"fps\": 30, \"seconds\": " + std::to_string((frames - 1) / 30.0) + ", \"seed\": 3,\n"
         "  \"actors\": [\n" + actors + "\n  ],\n"
         "  \"props\": [{\"type\": \"ground\", \"size\": [50, 50]},\n"
         "    {\"type\": \"box\", \"size\": [1, 1, 0.8], \"position\": [0, 0, 0]},\n"
         "    {\"type\": \"box\", \"size\": [2, 0.5, 1.2], \"position\": [0, 14, 0]},\n"
         "    {\"type\": \"box\", \"size\": [0.5, 2, 1.2], \"position\": [14, 0, 0]},\n"
         "    {\"type\": \"box\", \"size\": [0.5, 0.5, 2], \"position\": [-14, -3, 0]}],\n"
         "  \"cameras\": [{\"name\": \"static\", \"type\": \"static\", \"position\": [0, -20, 4], \"target\": [0, 0, 0.9]},\n"
         "    {\"name\": \"orbit\", \"type\": \"orbit\", \"target\": [0, 0, 0.9], \"radius\": 18, \"height_m\": 3},\n"
         "    {\"name\": \"ego\", \"type\": \"ego\", \"actor\": 0}],\n"
         "  \"outputs\": {\"trajectories\": true, \"camera_paths\": true, \"report\": true, \"prop_points\": 4000, \"threads\": 2" +
         shot.outputs + "}\n}\n";
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<int> lengths = {500, 2000};
  if (argc > 1) {
    lengths.clear();
    for (int i = 1; i < argc; ++i) lengths.push_back(std::stoi(argv[i]));
  }
  const fs::path dir = fs::temp_directory_path() / ("odyssey_bench_scene_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  // Dense characters, as a dataset's are: the shared ones subdivided (RiggedFigure 4 levels,
  // 35,815 vertices; CesiumMan 2 levels, 41,154), written once as inputs of the runs.
  const std::string characters = kShared + "/assets/characters/";
  const std::string dense_figure = (dir / "RiggedFigure_x4.glb").string(), dense_cesium = (dir / "CesiumMan_x2.glb").string();
  const odyssey::io::SubdividedGltf figure = odyssey::io::write_subdivided_glb(characters + "RiggedFigure.glb", dense_figure, 4);
  const odyssey::io::SubdividedGltf cesium = odyssey::io::write_subdivided_glb(characters + "CesiumMan.glb", dense_cesium, 2);
  const std::vector<Shot> shots = {
      {"4 actors, tracks", {characters + "RiggedFigure.glb", characters + "CesiumMan.glb", characters + "RobotExpressive.glb",
                            characters + "RiggedFigure.glb"}, ""},
      {"4 dense actors, tracks", {dense_figure, dense_cesium, dense_cesium, dense_figure}, ""},
      {"4 dense actors, PointOdyssey layout, depth + normals + masks", {dense_figure, dense_cesium, dense_cesium, dense_figure},
       ", \"layout\": \"pointodyssey\", \"depth\": true, \"normals\": true, \"masks\": true"}};
  std::printf("| shot | frames | points | cameras | wall s | camera-frames/s | point-frames/s per camera | peak memory (MiB) |\n"
              "|---|---:|---:|---:|---:|---:|---:|---:|\n");
  for (std::size_t s = 0; s < shots.size(); ++s) {
    for (const int frames : lengths) {
      const std::string name = std::to_string(s) + "_" + std::to_string(frames);
      const fs::path file = dir / ("shot_" + name + ".json"), log = dir / ("log_" + name + ".txt"), out = dir / ("out_" + name);
      std::ofstream(file) << scene_json(frames, shots[s]);
      const auto result = run_timed(std::string(ODYSSEY_CLI) + " scene " + file.string() + " --out " + out.string() +
                                    " --quiet > " + log.string() + " 2>&1");
      if (result.exit_code != 0) {
        std::printf("| %s | %d | failed: see %s |\n", shots[s].label.c_str(), frames, log.c_str());
        continue;
      }
      if (!std::getenv("ODYSSEY_BENCH_KEEP")) {
        fs::remove(file);
        fs::remove(log);
        fs::remove_all(out);
      }
      std::printf("| %s | %d | 20,000 | 3 | %.1f | %.0f | %.2f M | %.0f |\n", shots[s].label.c_str(), frames, result.seconds,
                  3 * frames / result.seconds, 20000.0 * frames / result.seconds / 1e6, result.peak_mib);
      std::fflush(stdout);
    }
  }
  if (!std::getenv("ODYSSEY_BENCH_KEEP")) {
    fs::remove(dense_figure);
    fs::remove(dense_cesium);
  }
  std::error_code ignored;
  fs::remove(dir, ignored);  // only when empty: a failed run's scene and log stay for a look
  std::printf("\nmachine: %s, %u threads; 960x540; the scene's threads: 2; dense characters: %zu and %zu vertices; "
              "retargeting (balanced), skinning, visibility, maps and writing included\n",
              odyssey::bench::cpu_model().c_str(), std::thread::hardware_concurrency(), figure.vertices_after,
              cesium.vertices_after);
  return 0;
}
