// Speed and memory of the streams renderers and annotators consume (scene_layouts/frame_loop.h, sinks.h),
// end to end from a retargeted clip to a file on disk:
//
//   trajectories  the frame loop (run_frame_loop) into a TrajectorySink, finished and committed:
//                 per frame forward kinematics, the points' corner vertices skinned, the whole mesh skinned and drawn
//                 into a 960x540 depth buffer, 5,000 points projected and depth-tested, every key
//                 written (stored npz, as odyssey trajectories writes by default);
//   point cache   the frame loop into a PointCacheSink, finished and committed (its rest OBJ
//                 included): the whole mesh skinned and written every frame.
// Characters: RiggedFigure (the bundled character) and the synthetic SMPL-X body as a character
// (10,475 vertices, 20,908 triangles, 55 joints). Motion: the CMU jump BVH retargeted (quality
// fast) onto the character, resampled to the frame count of the row; an orbiting camera of the
// default framing (radius 4 m, height 1.5 m, 10 s a turn, looking at 1 m up). One thread.
//
// Rates are wall clock, best of the repetitions (on a shared machine interference only slows a
// run down); files go to the system's temporary folder, so disk speed is part of the figure.
//
// Memory: each clip length runs again in a child process that builds the clip, resets its peak
// resident set to the current one (/proc/self/clear_refs), exports, and reports the resident set
// before and the peak during the export: the export's own growth is the difference. 1,000 and 20,000 frames show whether it stays flat. The clip itself (what the
// retargeting holds, J quaternions and a root translation a frame) grows with the frame count by
// design and is listed apart.
#include <benchmark/benchmark.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "bench/machine.h"
#include "mocap_io/bvh.h"
#include "mocap_io/gltf_character.h"
#include "mocap_io/point_cache.h"
#include "mocap_io/trajectory_file.h"
#include "retarget/bone_map.h"
#include "retarget/parts.h"
#include "retarget/retarget.h"
#include "scene_layouts/camera_rigs.h"
#include "scene_layouts/frame_loop.h"
#include "scene_layouts/pipeline.h"
#include "scene_layouts/sinks.h"
#include "skinning/body_character.h"
#include "skinning/sampling.h"
#include "synthetic/synthetic_body.h"

namespace {

using namespace odyssey;
namespace fs = std::filesystem;

const std::string kJump = std::string(ODYSSEY_SHARED_DIR) + "/assets/mocap/cmu_jump_cgspeed.bvh";
const std::string kFigure = std::string(ODYSSEY_SHARED_DIR) + "/assets/characters/RiggedFigure.glb";
constexpr int kPoints = 5000;

struct Subject {
  std::string name;
  Character character;
  std::vector<skinning::SurfacePoint> points;
  retarget::BoneMap target_map;
  std::size_t vertices = 0;
};

Subject load_subject(const std::string& name) {
  Subject subject;
  subject.name = name;
  subject.character = name == "RiggedFigure" ? io::load_character(kFigure)
                                             : skinning::body_character(make_synthetic_body(0).model);
  subject.target_map = retarget::restrict_bone_map(
      retarget::humanoid_bone_map(subject.character.skeleton, name, ""), retarget::Parts::body);
  skinning::SamplingOptions sampling;
  sampling.count = kPoints;
  sampling.seed = 1;
  subject.points = skinning::sample_surface_points(subject.character, sampling);
  for (const CharacterMesh& mesh : subject.character.meshes) subject.vertices += mesh.positions.size();
  return subject;
}

// The CMU jump retargeted onto the character with `frames` frames over its 22.9 s.
Clip jump_clip(const Subject& subject, int frames) {
  const Clip bvh = io::load_bvh(kJump, io::BvhOptions{io::kCmuMetresPerUnit});
  const Clip source = bvh.resampled((frames - 1) / bvh.duration());
  const retarget::BoneMap source_map =
      retarget::restrict_bone_map(retarget::humanoid_bone_map(source.skeleton, kJump, ""), retarget::Parts::body);
  return retarget::retarget_fast(source, source_map, subject.character, subject.target_map, {}, kJump).transfer.clip;
}

CameraPath orbit(const Clip& clip) {
  return scene::orbit_camera_path(clip.frame_count(), clip.fps, intrinsics_from_hfov(960, 540, 80),
                                  scene::OrbitCameraOptions{});
}

std::string scratch(const std::string& name) {
  return (fs::temp_directory_path() / ("odyssey_bench_" + std::to_string(::getpid()) + "_" + name)).string();
}

// Runs the frame loop stage on one actor into one sink and finishes it: what every command and
// scene does after prepare_shot.
double run_once(const Subject& subject, const scene::TimedClip& clip, const CameraPath* camera, scene::StreamSink& sink) {
  scene::StreamActor actor;
  actor.name = subject.name;
  actor.character = &subject.character;
  actor.clip = &clip;
  std::vector<scene::StreamCamera> cameras;
  if (camera) {
    actor.points = subject.points;
    cameras.push_back({"orbit", camera, -1, true});
  } else {
    actor.mesh_every_frame = true;
  }
  scene::StreamSink* sinks[] = {&sink};
  const auto start = std::chrono::steady_clock::now();
  scene::run_frame_loop(std::span(&actor, 1), nullptr, cameras, sinks);
  sink.finish(scene::SceneResult{});
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

double export_trajectories_once(const Subject& subject, const scene::TimedClip& clip, const CameraPath& camera) {
  const std::string path = scratch(subject.name + ".npz");
  const auto start = std::chrono::steady_clock::now();
  scene::StreamActor actor;
  actor.character = &subject.character;
  actor.points = subject.points;
  io::StagedOutputs staged;
  scene::TrajectorySink sink(0, path, scene::trajectory_file_header(std::span(&actor, 1), nullptr, clip.frame_count(), clip.fps()),
                             false, staged);
  run_once(subject, clip, &camera, sink);
  staged.commit();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  fs::remove(path);
  return seconds;
}

double export_point_cache_once(const Subject& subject, const scene::TimedClip& clip) {
  const std::string path = scratch(subject.name + ".pc2"), obj_path = scratch(subject.name + ".obj");
  const auto start = std::chrono::steady_clock::now();
  io::StagedOutputs staged;
  scene::PointCacheSink sink(0, subject.character, subject.name, clip.frame_count(), path, obj_path, staged);
  run_once(subject, clip, nullptr, sink);
  staged.commit();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  fs::remove(path);
  fs::remove(obj_path);
  return seconds;
}

struct Rate {
  double best_seconds = 1e300;
  double frames = 0, per_frame_items = 0;  // items: points or vertices
};
std::map<std::string, Rate> rates;

// A line of /proc/self/status ("VmHWM", "VmRSS"), MiB.
double status_mib(const std::string& key) {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.starts_with(key + ":")) return std::stod(line.substr(key.size() + 1)) / 1024.0;
  }
  return -1;
}

// Resets the peak resident set to the current one (Linux: "5" to clear_refs), so that VmHWM
// afterwards is the peak of what runs next.
bool reset_peak_rss() {
  std::ofstream clear("/proc/self/clear_refs");
  clear << "5";
  clear.close();
  return static_cast<bool>(clear);
}

struct MemoryRow {
  std::string subject, stream;
  int frames = 0;
  double before_mib = 0, after_mib = 0, clip_mib = 0;
};

// Runs one export in a child: builds the clip, notes the peak, exports, notes the peak again.
MemoryRow measure_memory(const std::string& subject_name, const std::string& stream, int frames) {
  int pipe_fds[2];
  if (pipe(pipe_fds) != 0) return {};
  const pid_t child = fork();
  if (child == 0) {
    close(pipe_fds[0]);
    const Subject subject = load_subject(subject_name);
    const scene::TimedClip clip(jump_clip(subject, frames));
    const CameraPath camera = orbit(clip.source());
    const bool reset = reset_peak_rss();
    double values[3] = {status_mib(reset ? "VmRSS" : "VmHWM"), 0,
                        (clip.source().rotations.size() * sizeof(Eigen::Quaterniond) +
                         clip.source().translations.size() * sizeof(Eigen::Vector3d)) / 1048576.0};
    if (stream == "trajectories") {
      export_trajectories_once(subject, clip, camera);
    } else {
      export_point_cache_once(subject, clip);
    }
    values[1] = status_mib("VmHWM");
    const ssize_t written = write(pipe_fds[1], values, sizeof values);
    _exit(written == sizeof values ? 0 : 1);
  }
  close(pipe_fds[1]);
  double values[3] = {0, 0, 0};
  const ssize_t got = read(pipe_fds[0], values, sizeof values);
  close(pipe_fds[0]);
  int status = 0;
  waitpid(child, &status, 0);
  MemoryRow row{subject_name, stream, frames};
  if (got == sizeof values && WIFEXITED(status) && WEXITSTATUS(status) == 0) {
    row.before_mib = values[0];
    row.after_mib = values[1];
    row.clip_mib = values[2];
  }
  return row;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<char*> arguments = {argv[0]};
  std::string repetitions = "--benchmark_repetitions=3", aggregates = "--benchmark_display_aggregates_only=true";
  arguments.push_back(repetitions.data());
  arguments.push_back(aggregates.data());
  for (int i = 1; i < argc; ++i) arguments.push_back(argv[i]);
  int count = static_cast<int>(arguments.size());
  benchmark::Initialize(&count, arguments.data());
  if (benchmark::ReportUnrecognizedArguments(count, arguments.data())) return 1;

  std::vector<Subject> subjects;
  for (const char* name : {"RiggedFigure", "SMPL-X body"}) subjects.push_back(load_subject(name));
  std::vector<scene::TimedClip> clips;
  for (const Subject& subject : subjects) clips.emplace_back(jump_clip(subject, 1000));
  std::vector<CameraPath> cameras;
  for (const scene::TimedClip& clip : clips) cameras.push_back(orbit(clip.source()));

  for (std::size_t s = 0; s < subjects.size(); ++s) {
    const Subject* subject = &subjects[s];
    const scene::TimedClip* clip = &clips[s];
    const CameraPath* camera = &cameras[s];
    const std::string trajectories = subject->name + "/trajectories", cache = subject->name + "/point cache";
    rates[trajectories] = {1e300, double(clip->frame_count()), double(kPoints)};
    rates[cache] = {1e300, double(clip->frame_count()), double(subject->vertices)};
    benchmark::RegisterBenchmark(trajectories.c_str(), [=](benchmark::State& state) {
      for (auto _ : state) {
        const double seconds = export_trajectories_once(*subject, *clip, *camera);
        state.SetIterationTime(seconds);
        rates[trajectories].best_seconds = std::min(rates[trajectories].best_seconds, seconds);
      }
    })->UseManualTime()->Unit(benchmark::kMillisecond)->Iterations(1);
    benchmark::RegisterBenchmark(cache.c_str(), [=](benchmark::State& state) {
      for (auto _ : state) {
        const double seconds = export_point_cache_once(*subject, *clip);
        state.SetIterationTime(seconds);
        rates[cache].best_seconds = std::min(rates[cache].best_seconds, seconds);
      }
    })->UseManualTime()->Unit(benchmark::kMillisecond)->Iterations(1);
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();

  std::printf("\n| stream | character | frames | frames/s | items/s (points or vertices) |\n|---|---|---:|---:|---:|\n");
  for (const auto& [name, rate] : rates) {
    if (rate.best_seconds > 1e299) continue;
    const std::size_t slash = name.find('/');
    std::printf("| %s | %s | %.0f | %.0f | %.3g |\n", name.substr(slash + 1).c_str(), name.substr(0, slash).c_str(),
                rate.frames, rate.frames / rate.best_seconds, rate.frames * rate.per_frame_items / rate.best_seconds);
  }

  std::printf("\n| stream | character | frames | resident with the clip built (MiB) | peak during the export (MiB) | "
              "export adds (MiB) | the clip itself (MiB) |\n|---|---|---:|---:|---:|---:|---:|\n");
  for (const char* stream : {"trajectories", "point cache"}) {
    for (const Subject& subject : subjects) {
      for (const int frames : {1000, 20000}) {
        const MemoryRow row = measure_memory(subject.name, stream, frames);
        std::printf("| %s | %s | %d | %.1f | %.1f | %.1f | %.1f |\n", stream, subject.name.c_str(), frames, row.before_mib,
                    row.after_mib, row.after_mib - row.before_mib, row.clip_mib);
        std::fflush(stdout);
      }
    }
  }
  std::printf("\nmachine: %s, %u cores, one thread\n", odyssey::bench::cpu_model().c_str(),
              std::thread::hardware_concurrency());
  return 0;
}
