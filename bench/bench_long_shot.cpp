// Whole-process peak memory of `odyssey scene` as the shot grows, for each actor source, so that
// what an actor costs is seen to follow its source's data and not the shot's length: one actor
// and one static camera tracking 10 points, trajectories and the report written, at 10^4, 10^5 and
// 10^6 frames (30 fps: 5.6 min to 9.3 h).
//
//   motion     the CMU walk (2.8 s) retargeted onto RiggedFigure at fast quality, slowed to fill
//              the shot (speed = clip length / shot length, at least the scene's 0.001, so from
//              2,833 s on it holds its last pose);
//   animation  the Fox's walk cycle (0.7 s of keys), looped for the shot;
//   anime      a pulsing sphere (770 vertices, 30 frames written by the benchmark), looped.
//
// Each row is one run of the release binary as a user types it, timed wall clock, with the child's
// peak resident set from wait4. "per frame" is the peak's growth over the 10^4-frame run divided by
// the frames added. Prints a table. Arguments: the frame counts (default 10000 100000 1000000);
// ODYSSEY_BENCH_KEEP=1 keeps the scene files, logs and outputs.
#include <unistd.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>
#include <thread>
#include <vector>

#include "bench/machine.h"
#include "bench/timed_process.h"
#include "mocap_io/anime_file.h"
#include "skeleton/mesh_animation.h"

namespace {

namespace fs = std::filesystem;
using odyssey::bench::run_timed;

const std::string kData = ODYSSEY_DATA_DIR;

// A sphere of radius 0.4 m (Y up, resting on y = 0) whose radius pulses by 10% once a second: 30
// frames at 30 fps.
void write_pulsing_sphere(const fs::path& path) {
  constexpr int kRings = 24, kSegments = 32, kFrames = 30;
  std::vector<Eigen::Vector3d> directions = {{0, 1, 0}};
  for (int r = 1; r < kRings; ++r) {
    const double polar = std::numbers::pi * r / kRings;
    for (int k = 0; k < kSegments; ++k) {
      const double azimuth = 2 * std::numbers::pi * k / kSegments;
      directions.emplace_back(std::sin(polar) * std::cos(azimuth), std::cos(polar), std::sin(polar) * std::sin(azimuth));
    }
  }
  directions.emplace_back(0, -1, 0);
  const auto ring = [](int r, int k) { return std::uint32_t(1 + (r - 1) * kSegments + k % kSegments); };
  const std::uint32_t south = std::uint32_t(directions.size() - 1);
  std::vector<std::uint32_t> triangles;
  for (int k = 0; k < kSegments; ++k) {
    triangles.insert(triangles.end(), {0, ring(1, k + 1), ring(1, k)});
    for (int r = 1; r + 1 < kRings; ++r) {
      triangles.insert(triangles.end(), {ring(r, k), ring(r, k + 1), ring(r + 1, k + 1), ring(r, k), ring(r + 1, k + 1), ring(r + 1, k)});
    }
    triangles.insert(triangles.end(), {south, ring(kRings - 1, k), ring(kRings - 1, k + 1)});
  }
  odyssey::MeshAnimation animation;
  animation.vertex_count = directions.size();
  for (int f = 0; f < kFrames; ++f) {
    const double radius = 0.4 * (1 + 0.1 * std::sin(2 * std::numbers::pi * f / kFrames));
    for (const Eigen::Vector3d& u : directions) {
      const Eigen::Vector3d p = Eigen::Vector3d(0, 0.44, 0) + radius * u;
      animation.positions.insert(animation.positions.end(), {float(p.x()), float(p.y()), float(p.z())});
    }
  }
  odyssey::io::write_anime_file(path.string(), animation, triangles);
}

std::string actor_json(const std::string& source, double seconds, const fs::path& anime) {
  char text[512];
  if (source == "motion") {
    const double walk_seconds = 2.8333;  // the CMU walk: 86 frames at 30 fps
    std::snprintf(text, sizeof text,
                  "{\"name\": \"walker\", \"motion\": \"%s/mocap/cmu_walk_cgspeed.bvh\", \"bvh_units\": \"cmu\", "
                  "\"character\": \"%s/characters/RiggedFigure.glb\", \"quality\": \"fast\", \"speed\": %.9g, \"points\": 10}",
                  kData.c_str(), kData.c_str(), std::max(0.001, walk_seconds / seconds));
  } else if (source == "animation") {
    std::snprintf(text, sizeof text,
                  "{\"name\": \"fox\", \"character\": \"%s/characters/Fox.glb\", \"animation\": \"Walk\", \"seconds\": %.9g, "
                  "\"scale\": 0.01, \"points\": 10}",
                  kData.c_str(), seconds);
  } else {
    std::snprintf(text, sizeof text, "{\"name\": \"sphere\", \"anime\": \"%s\", \"seconds\": %.9g, \"points\": 10}", anime.c_str(),
                  seconds);
  }
  return text;
}

std::string scene_json(const std::string& source, int frames, const fs::path& anime) {
  const double seconds = (frames - 1) / 30.0;
  char head[128];
  std::snprintf(head, sizeof head, "{\"version\": 1, \"fps\": 30, \"seconds\": %.9g, \"seed\": 1,\n", seconds);
  return std::string(head) + " \"actors\": [" + actor_json(source, seconds, anime) +
         "],\n"
         " \"cameras\": [{\"name\": \"wide\", \"type\": \"static\", \"position\": [0, -6, 1.5], \"target\": [0, 0, 0.6], "
         "\"width\": 320, \"height\": 180}],\n"
         " \"outputs\": {\"trajectories\": true, \"report\": true}}\n";
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<int> lengths = {10000, 100000, 1000000};
  if (argc > 1) {
    lengths.clear();
    for (int i = 1; i < argc; ++i) lengths.push_back(std::stoi(argv[i]));
  }
  const fs::path dir = fs::temp_directory_path() / ("odyssey_bench_long_shot_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path anime = dir / "pulsing_sphere.anime";
  write_pulsing_sphere(anime);
  std::printf("| actor source | frames | shot length | wall s | frames/s | peak memory (MiB) | per frame over the first row |\n"
              "|---|---:|---:|---:|---:|---:|---:|\n");
  for (const std::string source : {"motion", "animation", "anime"}) {
    double first_peak = 0;
    int first_frames = 0;
    for (const int frames : lengths) {
      const std::string name = source + "_" + std::to_string(frames);
      const fs::path file = dir / ("shot_" + name + ".json"), log = dir / ("log_" + name + ".txt"), out = dir / ("out_" + name);
      std::ofstream(file) << scene_json(source, frames, anime);
      const auto result = run_timed(std::string(ODYSSEY_CLI) + " scene " + file.string() + " --out " + out.string() +
                                    " --quiet > " + log.string() + " 2>&1");
      if (result.exit_code != 0) {
        std::printf("| %s | %d | failed: see %s |\n", source.c_str(), frames, log.c_str());
        continue;
      }
      if (!std::getenv("ODYSSEY_BENCH_KEEP")) {
        fs::remove(file);
        fs::remove(log);
        fs::remove_all(out);
      }
      char growth[64] = "";
      if (first_frames == 0) {
        first_peak = result.peak_mib;
        first_frames = frames;
      } else {
        std::snprintf(growth, sizeof growth, "%.0f bytes", (result.peak_mib - first_peak) * 1048576.0 / (frames - first_frames));
      }
      std::printf("| %s | %d | %.1f min | %.1f | %.0f | %.0f | %s |\n", source.c_str(), frames, (frames - 1) / 30.0 / 60,
                  result.seconds, frames / result.seconds, result.peak_mib, growth);
      std::fflush(stdout);
    }
  }
  if (!std::getenv("ODYSSEY_BENCH_KEEP")) fs::remove(anime);
  std::error_code ignored;
  fs::remove(dir, ignored);  // only when empty: a failed run's scene and log stay for a look
  std::printf("\nmachine: %s, %u threads; one actor, one static 320x180 camera tracking 10 points; trajectories and "
              "the report written\n",
              odyssey::bench::cpu_model().c_str(), std::thread::hardware_concurrency());
  return 0;
}
