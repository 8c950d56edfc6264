// Whole-process speed and peak memory of `odyssey batch` as a user runs it overnight: generated
// AMASS-style SMPL-X walks of varied length (2 to 12 s at 60 fps, seeded) and the synthetic body
// model, onto three shared characters (RiggedFigure, CesiumMan, RobotExpressive) at `balanced`,
// 30 fps out, with the GLB and the report written per job, --jobs = the core count. Rows:
//
//   batch     the whole library: jobs, output frames, wall time, frames/s of the whole batch,
//             the peak resident set of the largest process (wait4), and what all of AMASS
//             (4.3 M frames at 30 fps) onto one character would take at that rate;
//   overhead  the same characters with 0.5 s clips, one worker: wall time per job, less what its
//             frames cost at the whole batch's per-worker rate, is the per-job overhead (loading
//             the clip, writing and syncing the files, the journal);
//   loop      those short jobs as a shell loop of `odyssey retarget`, one process per job, which
//             reloads the body model and the character every time: what the batch saves.
//
// Arguments: the clip count (default 300). ODYSSEY_BENCH_KEEP=1 keeps the inputs and outputs.
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "bench/machine.h"
#include "bench/timed_process.h"
#include "mocap_io/amass.h"
#include "mocap_io/body_model_writer.h"
#include "synthetic/synthetic_body.h"
#include "synthetic/synthetic_walk.h"

namespace {

namespace fs = std::filesystem;
using odyssey::bench::run_timed;

const std::string kShared = ODYSSEY_SHARED_DIR;
const char* const kCharacters[] = {"RiggedFigure.glb", "CesiumMan.glb", "RobotExpressive.glb"};
constexpr double kAmassFrames = 4.3e6;

// `count` walks named clip_NNN.npz into `folder`, lengths from `seconds` (seeded).
void write_clips(const fs::path& folder, int count, std::uniform_real_distribution<double> seconds, unsigned seed) {
  fs::create_directories(folder);
  std::mt19937 random(seed);
  for (int i = 0; i < count; ++i) {
    const int frames = static_cast<int>(seconds(random) * 60);
    char name[32];
    std::snprintf(name, sizeof name, "clip_%03d.npz", i);
    odyssey::io::write_amass((folder / name).string(), odyssey::synthetic_walk(frames, 60, odyssey::BodyModelKind::SMPLX, seed + i));
  }
}

long report_frames(const fs::path& out) {
  std::ifstream file(out / "report.json");
  return nlohmann::json::parse(file)["batch"]["frames"].get<long>();
}

}  // namespace

int main(int argc, char** argv) {
  const int clips = argc > 1 ? std::stoi(argv[1]) : 300;
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  const fs::path dir = fs::temp_directory_path() / ("odyssey_bench_batch_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path model = dir / "model.npz";
  odyssey::io::write_body_model(model.string(), odyssey::make_synthetic_body(0));
  write_clips(dir / "library", clips, std::uniform_real_distribution<double>(2, 12), 100);
  const int short_clips = 20;
  write_clips(dir / "short", short_clips, std::uniform_real_distribution<double>(0.5, 0.5), 900);
  std::string characters;
  for (const char* character : kCharacters) characters += " " + kShared + "/assets/characters/" + character;
  const std::string settings = " --model " + model.string() + " --quality balanced --fps 30 --outputs glb,report --quiet";

  std::printf("| run | jobs | frames | workers | wall s | frames/s | per job | peak memory (MiB) |\n"
              "|---|---:|---:|---:|---:|---:|---:|---:|\n");
  const auto batch = [&](const char* what, const fs::path& motions, const std::string& out, unsigned workers, long jobs) {
    const auto result = run_timed(std::string(ODYSSEY_CLI) + " batch --motions " + motions.string() + " --characters" + characters +
                           " --out " + (dir / out).string() + settings + " --jobs " + std::to_string(workers) + " > " +
                           (dir / (out + ".log")).string() + " 2>&1");
    if (result.exit_code != 0) {
      std::printf("| %s | failed (exit %d): see %s |\n", what, result.exit_code, (dir / (out + ".log")).c_str());
      std::exit(1);
    }
    const long frames = report_frames(dir / out);
    std::printf("| %s | %ld | %ld | %u | %.1f | %.0f | %.0f ms | %.0f |\n", what, jobs, frames, workers, result.seconds,
                frames / result.seconds, 1000 * result.seconds * workers / jobs, result.peak_mib);
    std::fflush(stdout);
    return std::make_pair(result, frames);
  };
  const long library_jobs = 3L * clips;
  const auto [whole, whole_frames] = batch("batch: library", dir / "library", "library_out", cores, library_jobs);
  const double per_worker_rate = whole_frames / whole.seconds / cores;
  const auto [small, small_frames] = batch("batch: 0.5 s clips", dir / "short", "short_out", 1, 3L * short_clips);

  // The same short jobs, one odyssey retarget process each.
  std::string loop = "set -e; for c in" + characters + "; do for m in " + (dir / "short").string() + "/*.npz; do " + ODYSSEY_CLI +
                     " retarget --motion \"$m\" --character \"$c\" --model " + model.string() +
                     " --quality balanced --fps 30 --out " + (dir / "loop.glb").string() + " > /dev/null; done; done";
  const auto looped = run_timed(loop + " > " + (dir / "loop.log").string() + " 2>&1");
  if (looped.exit_code != 0) {
    std::printf("| loop | failed: see %s |\n", (dir / "loop.log").c_str());
    return 1;
  }
  std::printf("| loop of odyssey retarget: 0.5 s clips | %d | %ld | 1 | %.1f | %.0f | %.0f ms | %.0f |\n", 3 * short_clips,
              small_frames, looped.seconds, small_frames / looped.seconds, 1000 * looped.seconds / (3 * short_clips),
              looped.peak_mib);

  const double small_job_s = small.seconds / (3.0 * short_clips);
  const double overhead_s = small_job_s - (static_cast<double>(small_frames) / (3.0 * short_clips)) / per_worker_rate;
  std::printf("\nwhole batch: %.0f frames/s on %u cores; all of AMASS (%.1f M frames at 30 fps) onto one character: %.0f min\n",
              whole_frames / whole.seconds, cores, kAmassFrames / 1e6, kAmassFrames / (whole_frames / whole.seconds) / 60);
  std::printf("per-job overhead, one worker: %.0f ms (a 0.5 s job takes %.0f ms, its 15 frames %.0f ms at %.0f frames/s per worker)\n",
              1000 * overhead_s, 1000 * small_job_s, 1000 * (small_job_s - overhead_s), per_worker_rate);
  std::printf("machine: %s, %u threads; AMASS-style SMPL-X walks at 60 fps onto 3 characters, balanced, 30 fps out, GLB and report per job\n",
              odyssey::bench::cpu_model().c_str(), cores);
  if (!std::getenv("ODYSSEY_BENCH_KEEP")) fs::remove_all(dir);
  return 0;
}
