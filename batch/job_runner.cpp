#include "batch/job_runner.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <new>
#include <string_view>
#include <vector>

#include "batch/journal.h"
#include "scene_layouts/pipeline.h"
#include "scene_layouts/scene_file.h"

namespace odyssey::batch {
namespace fs = std::filesystem;
namespace {

void sync_path(const fs::path& path, int flags) {
  const int fd = ::open(path.c_str(), flags | O_CLOEXEC);
  if (fd < 0) throw std::runtime_error("cannot open " + path.string() + " to sync it");
  const int status = ::fsync(fd);
  ::close(fd);
  if (status != 0) throw std::runtime_error("cannot sync " + path.string());
}

// Every file of the folder on disk, then the folder's entries.
std::vector<std::string> sync_folder(const fs::path& folder) {
  std::vector<std::string> files;
  for (const auto& entry : fs::recursive_directory_iterator(folder)) {
    if (entry.is_regular_file()) {
      sync_path(entry.path(), O_RDONLY);
      files.push_back(entry.path().lexically_relative(folder).generic_string());
    } else if (entry.is_directory()) {
      sync_path(entry.path(), O_RDONLY | O_DIRECTORY);
    }
  }
  sync_path(folder, O_RDONLY | O_DIRECTORY);
  std::sort(files.begin(), files.end());
  return files;
}

// Fault injection for the tests of worker isolation: ODYSSEY_BATCH_FAULT=KIND:TEXT[,KIND:TEXT...]
// makes a job whose name contains TEXT abort (crash), never finish (hang) or allocate without end
// (oom), inside the job as a real fault would be.
void inject_fault(const Job& job) {
  const char* faults = std::getenv("ODYSSEY_BATCH_FAULT");
  if (!faults) return;
  std::string kind;
  for (std::string_view rest = faults; !rest.empty();) {
    const std::string_view fault = rest.substr(0, rest.find(','));
    rest.remove_prefix(std::min(rest.size(), fault.size() + 1));
    const std::size_t colon = fault.find(':');
    if (colon != std::string_view::npos && job.name.find(fault.substr(colon + 1)) != std::string::npos) {
      kind = fault.substr(0, colon);
    }
  }
  if (kind == "crash") std::abort();
  if (kind == "hang") {
    for (;;) ::pause();
  }
  if (kind == "oom") {
    std::vector<std::unique_ptr<char[]>> blocks;
    for (;;) {
      blocks.emplace_back(new char[64 << 20]);
      std::memset(blocks.back().get(), 1, 64 << 20);
    }
  }
}

// The one-actor scene of a retarget job, writing the files `outputs` asks for into `folder`.
scene::Scene retarget_scene(const Job& job, const fs::path& folder) {
  scene::Scene shot;
  shot.name = job.name;
  shot.fps = job.request.fps;
  scene::SceneActor actor;
  actor.name = "actor";
  scene::RetargetRequest request = job.request;
  request.refine_options.threads = 1;  // the batch is parallel across jobs
  actor.source = std::move(request);
  shot.actors.push_back(std::move(actor));
  scene::SceneCamera camera;
  camera.name = "camera";
  shot.cameras.push_back(camera);
  scene::SceneOutputs& outputs = shot.outputs;
  const auto file = [&](const char* name) { return (folder / name).string(); };
  if (job.outputs.glb) outputs.glb = file("animation.glb");
  if (job.outputs.report) outputs.actor_reports = {file("retarget.json")};
  if (job.outputs.trajectories) {
    outputs.trajectories = {file("trajectories.npz")};
    outputs.camera_paths = {file("camera.json")};
  }
  if (job.outputs.point_cache) {
    outputs.point_caches = {file("point_cache.pc2")};
    outputs.rest_objs = {file("point_cache.obj")};
  }
  if (job.outputs.preview) outputs.previews = {file("preview.png")};
  return shot;
}

// Moves the finished staging folder onto the job's folder: an old folder there is renamed away
// first, so at every moment the job's folder is whole (old or new) or absent.
void move_into_place(const fs::path& staged, const fs::path& target) {
  fs::create_directories(target.parent_path());
  const fs::path old = staged.string() + ".old";
  std::error_code error;
  fs::remove_all(old, error);
  if (fs::exists(target)) fs::rename(target, old);
  fs::rename(staged, target);
  sync_path(target.parent_path(), O_RDONLY | O_DIRECTORY);
  fs::remove_all(old, error);
}

// A task's outputs: each placed path moved from the staging folder onto DIR (move_into_place), then
// the paths its previous run placed that this one did not are removed.
void place_task_outputs(const fs::path& staged, const fs::path& out, const std::vector<std::string>& placed,
                        const std::vector<std::string>& previously_placed) {
  for (const std::string& path : placed) {
    const fs::path relative(path);
    if (path.empty() || relative.is_absolute() || relative.lexically_normal() != relative ||
        relative.lexically_normal().string().starts_with("..")) {
      throw std::runtime_error("a job placed '" + path + "', which is not a relative path inside the output folder");
    }
    if (!fs::exists(staged / relative)) throw std::runtime_error("a job placed '" + path + "' but did not write it");
    move_into_place(staged / relative, out / relative);
  }
  std::error_code error;
  for (const std::string& path : previously_placed) {
    if (std::find(placed.begin(), placed.end(), path) == placed.end() && !fs::path(path).is_absolute() &&
        !path.starts_with("..")) {
      fs::remove_all(out / path, error);
    }
  }
}

}  // namespace

nlohmann::ordered_json actor_metrics_json(const scene::RetargetedActor& actor) {
  const retarget::RetargetReport& report = actor.result.report;
  const retarget::RetargetMetrics& result = report.result_metrics;
  const retarget::RetargetMetrics& source = report.source_metrics;
  nlohmann::ordered_json limbs = nlohmann::ordered_json::object();
  double worst = 0;
  for (const retarget::NamedDirectionError& limb : result.limbs) {
    limbs[limb.name] = limb.error.mean_deg;
    worst = std::max(worst, limb.error.mean_deg);
  }
  return {{"bone_error_mean_deg", result.bone_direction.mean_deg},
          {"bone_error_max_deg", result.bone_direction.max_deg},
          {"worst_limb_mean_deg", worst},
          {"limbs_mean_deg", limbs},
          {"skate", result.foot_skate_ratio},
          {"source_skate", source.foot_skate_ratio},
          {"skate_gmd", result.foot_skate_ratio_gmd},
          {"penetration_cm", result.penetration_cm},
          {"floating_cm", result.floating_cm},
          {"jitter", result.jitter},
          {"source_jitter", source.jitter}};
}

nlohmann::ordered_json run_job(const Job& job, const std::string& out, const std::string& staging,
                               scene::LoadCache& cache) {
  const auto start = std::chrono::steady_clock::now();
  nlohmann::ordered_json record;
  const fs::path folder = fs::path(staging) / hash_text(job.name);
  try {
    std::error_code error;
    fs::remove_all(folder, error);
    fs::create_directories(folder);
    inject_fault(job);
    if (job.task) {
      record = job.task->run(folder.string(), cache);
      const std::vector<std::string> placed = record.at("placed").get<std::vector<std::string>>();
      sync_folder(folder);
      record["outputs"] = placed;  // the placed paths, not every file under them (a sequence holds thousands)
      place_task_outputs(folder, fs::path(out), placed, job.previously_placed);
      nlohmann::ordered_json finished{{"status", "done"}};
      for (auto& [key, value] : record.items()) finished[key] = value;
      record = std::move(finished);
      fs::remove_all(folder, error);
      record["seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      return record;
    }
    scene::SceneResult result;
    if (job.scene_path.empty()) {
      result = scene::run_scene(retarget_scene(job, folder), {}, &cache);
    } else {
      scene::SceneFile file = scene::read_scene_file(job.scene_path);
      scene::set_outputs_in_folder(file.scene, folder.string(), file.outputs);
      file.scene.outputs.threads = 1;
      result = scene::run_scene(file.scene, {}, &cache);
    }
    const std::vector<std::string> files = sync_folder(folder);
    move_into_place(folder, fs::path(out) / "jobs" / job.name);
    record["status"] = "done";
    if (job.scene_path.empty()) {
      record["frames"] = result.actors.at(0).retargeted->clip().frame_count();
      record["metrics"] = actor_metrics_json(*result.actors.at(0).retargeted);
    } else {
      record["frames"] = result.frames;
      nlohmann::ordered_json actors = nlohmann::ordered_json::object();
      for (const scene::PlacedActor& actor : result.actors) {
        // An actor playing its own animation or an .anime mesh has no retargeting to measure.
        if (actor.retargeted) actors[actor.name] = actor_metrics_json(*actor.retargeted);
      }
      record["metrics"] = {{"actors", actors}};
    }
    record["outputs"] = files;
  } catch (const std::bad_alloc&) {
    record["status"] = "failed";
    record["error"] = "out of memory";
  } catch (const std::exception& error) {
    record["status"] = "failed";
    record["error"] = error.what();
  }
  if (record["status"] == "failed") {
    std::error_code error;
    fs::remove_all(folder, error);
  }
  record["seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return record;
}

}  // namespace odyssey::batch
