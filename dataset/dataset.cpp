#include "dataset/dataset.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>

#include "batch/job_runner.h"
#include "batch/report.h"
#include "dataset/draw.h"
#include "mocap_io/amass.h"
#include "mocap_io/bvh.h"
#include "mocap_io/input_error.h"
#include "mocap_io/output_file.h"
#include "scene_layouts/pipeline.h"
#include "scene_layouts/scene_file.h"

namespace odyssey::dataset {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

const char* kTaskKind = "dataset-sequence";

// A motion's length in seconds, read once per process.
double motion_seconds(const MotionAsset& motion) {
  static std::map<std::string, double> known;
  const auto found = known.find(motion.file);
  if (found != known.end()) return found->second;
  const std::string extension = fs::path(motion.file).extension().string();
  const double seconds = extension == ".npz" ? io::load_amass(motion.file).duration() : io::load_bvh(motion.file).duration();
  known.emplace(motion.file, seconds);
  return seconds;
}

// Every file the recipe's libraries name, for the key of its sequences.
std::vector<std::string> library_files(const Recipe& recipe) {
  std::vector<std::string> files;
  for (const auto& asset : recipe.characters) {
    files.push_back(asset.file);
    if (asset.map) files.push_back(*asset.map);
  }
  for (const auto& asset : recipe.motions) {
    files.push_back(asset.file);
    if (asset.model) files.push_back(*asset.model);
  }
  for (const auto& asset : recipe.animals) files.push_back(asset.file);
  for (const auto& asset : recipe.props) files.push_back(asset.file);
  for (const auto& asset : recipe.camera_tracks) {
    if (asset.colmap) {
      files.push_back((fs::path(asset.file) / "cameras.txt").string());
      files.push_back((fs::path(asset.file) / "images.txt").string());
    } else {
      files.push_back(asset.file);
    }
  }
  for (const auto& asset : recipe.layouts) files.push_back(asset.file);
  std::sort(files.begin(), files.end());
  files.erase(std::unique(files.begin(), files.end()), files.end());
  return files;
}

// What a sequence's outputs depend on: the recipe as written, the library's files by content, the
// odyssey build (the batch adds its version).
std::string library_digest(const Recipe& recipe) {
  batch::FileHasher hasher;
  std::string text;
  for (const std::string& file : library_files(recipe)) text += file + " " + hasher.hash(file) + "\n";
  return batch::hash_text(text);
}

// Why a run shot is not kept, or "".
std::string check_shot(const Recipe& recipe, const DrawnShot& drawn, const scene::SceneResult& result) {
  char line[256];
  for (std::size_t c = 0; c < result.streams.cameras.size(); ++c) {
    const scene::CameraStreamSummary& camera = result.streams.cameras[c];
    if (camera.valid_fraction < recipe.min_valid) {
      std::snprintf(line, sizeof line, "camera %s keeps %.1f%% of its point-frames in view (cameras.min_valid %.1f%%)",
                    camera.name.c_str(), 100 * camera.valid_fraction, 100 * recipe.min_valid);
      return line;
    }
    const int rides = drawn.ego_actors.at(c);
    if (rides >= 0) {
      double best = 0;
      for (std::size_t a = 0; a < camera.actor_visible_fraction.size(); ++a) {
        if (static_cast<int>(a) != rides) best = std::max(best, camera.actor_visible_fraction[a]);
      }
      if (best < recipe.ego_min_other_visible) {
        std::snprintf(line, sizeof line,
                      "ego camera %s sees at most %.1f%% of another actor's point-frames (cameras.ego_min_other_visible %.1f%%)",
                      camera.name.c_str(), 100 * best, 100 * recipe.ego_min_other_visible);
        return line;
      }
    }
  }
  return "";
}

class SequenceTask : public batch::JobTask {
 public:
  SequenceTask(std::shared_ptr<const Recipe> recipe, long index, std::string out, std::string digest)
      : recipe_(std::move(recipe)), index_(index), out_(std::move(out)), digest_(std::move(digest)) {}

  std::string kind() const override { return kTaskKind; }
  std::string key_text() const override { return recipe_->canonical + "\n" + std::to_string(index_) + "\n" + digest_; }
  std::vector<std::string> inputs() const override { return {}; }

  Json run(const std::string& staging, scene::LoadCache& cache) const override {
    const Recipe& recipe = *recipe_;
    const AssetFacts facts{motion_seconds};
    std::vector<std::string> reasons;
    const fs::path root(staging);
    for (int attempt = 0; attempt <= recipe.max_redraws; ++attempt) {
      const DrawnShot drawn = draw_shot(recipe, index_, attempt, facts);
      const std::string text = drawn.scene.dump(2) + "\n";
      // Errors in the drawn scene name the file it becomes.
      const std::string scene_path = (fs::path(out_) / "scenes" / (drawn.name + ".json")).string();
      std::vector<std::string> placed;
      try {
        scene::SceneFile file = scene::parse_scene(text, scene_path);
        scene::set_outputs_in_folder(file.scene, (root / drawn.split).string(), file.outputs);
        file.scene.outputs.report = (root / "reports" / (drawn.name + ".json")).string();
        for (std::size_t c = 0; c < file.scene.outputs.previews.size(); ++c) {
          file.scene.outputs.previews[c] = (root / "previews" / (drawn.name + "_" + file.scene.cameras[c].name + ".png")).string();
        }
        file.scene.outputs.threads = 1;  // the batch is parallel across sequences
        for (const char* folder : {"reports", "previews", "scenes"}) fs::create_directories(root / folder);
        fs::create_directories(root / drawn.split);
        const scene::SceneResult result = scene::run_scene(file.scene, {}, &cache);
        for (const std::string& output : result.outputs) placed.push_back(fs::path(output).lexically_relative(root).generic_string());
        const std::string problem = check_shot(recipe, drawn, result);
        if (!problem.empty()) {
          for (const std::string& output : result.outputs) fs::remove_all(output);
          reasons.push_back("attempt " + std::to_string(attempt) + ": " + problem);
          continue;
        }
        io::write_file_atomically((root / "scenes" / (drawn.name + ".json")).string(), text);
        placed.insert(placed.begin(), "scenes/" + drawn.name + ".json");
        return record(drawn, result, placed, reasons, attempt, file.scene);
      } catch (const io::InputError& error) {
        // A broken asset fails this sequence, naming it; anything else is the draw's.
        const bool asset = std::any_of(drawn.assets.begin(), drawn.assets.end(), [&](const UsedAsset& used) {
          return fs::path(used.file).lexically_normal() == fs::path(error.file()).lexically_normal();
        });
        if (asset) throw;
        reasons.push_back("attempt " + std::to_string(attempt) + ": " + error.what());
      } catch (const std::invalid_argument& error) {
        reasons.push_back("attempt " + std::to_string(attempt) + ": " + error.what());
      }
      std::error_code ignored;
      for (const std::string& path : placed) fs::remove_all(root / path, ignored);
    }
    std::string why = "no acceptable draw in " + std::to_string(recipe.max_redraws + 1) + " attempts (max_redraws " +
                      std::to_string(recipe.max_redraws) + ")";
    for (const std::string& reason : reasons) why += "; " + reason;
    throw std::runtime_error(why);
  }

 private:
  Json record(const DrawnShot& drawn, const scene::SceneResult& result, const std::vector<std::string>& placed,
              const std::vector<std::string>& reasons, int attempt, const scene::Scene& scene) const {
    Json out;
    out["placed"] = placed;
    out["frames"] = result.frames;
    out["sequence"] = drawn.name;
    out["index"] = index_;
    out["split"] = drawn.split;
    out["scene_file"] = "scenes/" + drawn.name + ".json";
    out["seed"] = drawn.seed;
    out["fps"] = scene.fps;
    out["redraws"] = attempt;
    out["redraw_reasons"] = reasons;
    Json assets = Json::array();
    for (const UsedAsset& asset : drawn.assets) assets.push_back({{"kind", asset.kind}, {"path", asset.path}, {"licence", asset.licence}});
    out["assets"] = std::move(assets);
    out["actors"] = result.actors.size();
    out["points"] = result.streams.points;
    Json cameras = Json::array();
    for (std::size_t c = 0; c < result.streams.cameras.size(); ++c) {
      const scene::CameraStreamSummary& camera = result.streams.cameras[c];
      cameras.push_back({{"name", camera.name},
                         {"type", drawn.scene["cameras"][c]["type"]},
                         {"sequence", drawn.split + "/" + drawn.name + "_" + camera.name},
                         {"tracks", result.streams.points},
                         {"valid", camera.valid_fraction},
                         {"visible", camera.visible_fraction}});
    }
    out["cameras"] = std::move(cameras);
    Json metrics = Json::object();
    Json actors = Json::object();
    for (const scene::PlacedActor& actor : result.actors) {
      if (actor.retargeted) actors[actor.name] = batch::actor_metrics_json(*actor.retargeted);
    }
    metrics["actors"] = std::move(actors);
    out["metrics"] = std::move(metrics);
    return out;
  }

  std::shared_ptr<const Recipe> recipe_;
  long index_;
  std::string out_, digest_;
};

}  // namespace

nlohmann::ordered_json dataset_settings(const Recipe& recipe) {
  return {{"dataset", recipe.name}, {"recipe", batch::hash_text(recipe.canonical)}};
}

std::vector<batch::Job> dataset_jobs(const Recipe& recipe, long count, const std::string& out) {
  const auto shared = std::make_shared<const Recipe>(recipe);
  const std::string digest = library_digest(recipe);
  std::vector<batch::Job> jobs;
  for (long i = 0; i < count; ++i) {
    batch::Job job;
    job.name = sequence_name(recipe, i);
    job.task = std::make_shared<SequenceTask>(shared, i, out, digest);
    job.source = recipe.file;
    jobs.push_back(std::move(job));
  }
  return jobs;
}

DatasetSummary run_dataset(const Recipe& recipe, const DatasetOptions& options, const batch::BatchProgressCallback& progress) {
  const long count = options.count > 0 ? options.count : recipe.count;
  batch::BatchOptions batch_options = options.batch;
  batch_options.settings = dataset_settings(recipe);
  batch::BatchSummary ran = batch::run_batch(dataset_jobs(recipe, count, batch_options.out), batch_options, progress);
  DatasetSummary summary;
  summary.counts = ran.counts;
  if (batch_options.shard.whole()) {
    summary.reports.push_back(write_dataset_report(batch_options.out, batch::read_journals(batch_options.out)));
  }
  for (std::string& report : ran.reports) summary.reports.push_back(std::move(report));
  return summary;
}

std::string write_dataset_report(const std::string& folder, const batch::JournalContents& contents) {
  struct Totals {
    long shots = 0, sequences = 0, frames = 0, tracks = 0;
    double point_frames = 0, valid_point_frames = 0, visible_point_frames = 0;
  };
  std::map<std::string, Totals> splits;
  Json sequences = Json::array(), failed = Json::array();
  for (const auto& [name, record] : contents.records) {
    if (record.value("kind", "") != kTaskKind) continue;
    if (record.value("status", "") != "done") {
      failed.push_back({{"sequence", name}, {"error", record.value("error", "")}});
      continue;
    }
    Json entry;
    for (const char* key : {"sequence", "index", "split", "scene_file", "seed", "fps", "frames", "actors", "points", "cameras",
                            "redraws", "redraw_reasons", "assets", "seconds"}) {
      if (record.contains(key)) entry[key] = record[key];
    }
    sequences.push_back(std::move(entry));
    Totals& totals = splits[record.value("split", "")];
    ++totals.shots;
    const long frames = record.value("frames", 0L);
    for (const nlohmann::json& camera : record.value("cameras", nlohmann::json::array())) {
      const long tracks = camera.value("tracks", 0L);
      ++totals.sequences;
      totals.frames += frames;
      totals.tracks += tracks;
      const double point_frames = static_cast<double>(tracks) * static_cast<double>(frames);
      totals.point_frames += point_frames;
      totals.valid_point_frames += camera.value("valid", 0.0) * point_frames;
      totals.visible_point_frames += camera.value("visible", 0.0) * point_frames;
    }
  }
  Json split_table = Json::object();
  for (const auto& [split, totals] : splits) {
    split_table[split] = {{"shots", totals.shots},
                          {"sequences", totals.sequences},
                          {"frames", totals.frames},
                          {"tracks", totals.tracks},
                          {"point_annotations", static_cast<long long>(totals.point_frames)},
                          {"average_track_span_frames", totals.tracks > 0 ? totals.valid_point_frames / static_cast<double>(totals.tracks) : 0.0},
                          {"visible_share", totals.point_frames > 0 ? totals.visible_point_frames / totals.point_frames : 0.0}};
  }
  Json report;
  report["dataset"] = contents.headers.empty() ? Json() : Json(contents.headers[0].value("settings", nlohmann::json()));
  long planned = 0;
  for (const nlohmann::json& header : contents.headers) planned += header.value("planned_jobs", 0L);
  report["planned_sequences"] = planned;
  report["done"] = sequences.size();
  report["failed"] = failed.size();
  report["splits"] = std::move(split_table);
  report["sequences"] = std::move(sequences);
  report["failures"] = std::move(failed);
  const std::string path = (fs::path(folder) / "dataset.json").string();
  io::write_file_atomically(path, report.dump(2) + "\n");
  return path;
}

}  // namespace odyssey::dataset
