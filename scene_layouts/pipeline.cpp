#include "scene_layouts/pipeline.h"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <variant>

#include "mocap_io/output_file.h"
#include "scene_layouts/pointodyssey.h"
#include "scene_layouts/preview.h"
#include "scene_layouts/sinks.h"

namespace odyssey::scene {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

bool any_path(const std::vector<std::string>& paths) {
  return std::any_of(paths.begin(), paths.end(), [](const std::string& p) { return !p.empty(); });
}

bool asked(const std::vector<std::string>& paths, std::size_t i) { return i < paths.size() && !paths[i].empty(); }

// The rest OBJ beside a point cache: the same path with .obj.
std::string obj_beside(const std::string& pc2) { return std::filesystem::path(pc2).replace_extension(".obj").string(); }

// Every file the scene reads: its own scene file, motions, characters, maps, body models, anime meshes, prop meshes,
// camera files.
std::vector<std::string> scene_inputs(const Scene& scene) {
  std::vector<std::string> inputs = {scene.file};
  for (const SceneActor& actor : scene.actors) {
    if (const auto* r = std::get_if<RetargetRequest>(&actor.source)) {
      inputs.insert(inputs.end(), {r->motion_path, r->character_path, r->map_path.value_or(""), r->source_map_path.value_or(""),
                                   r->model_path.value_or("")});
    } else if (const auto* a = std::get_if<AnimationRequest>(&actor.source)) {
      inputs.push_back(a->character_path);
    } else if (const auto* m = std::get_if<AnimeRequest>(&actor.source)) {
      inputs.push_back(m->path);
    }
  }
  for (const Prop& prop : scene.props) inputs.push_back(prop.path);
  if (scene.scatter) {
    for (const Prop& prop : scene.scatter->props) inputs.push_back(prop.path);
  }
  for (const SceneCamera& camera : scene.cameras) {
    if (const auto* file = std::get_if<FileRig>(&camera.rig)) inputs.push_back(file->path);
    if (const auto* imported = std::get_if<ImportedRig>(&camera.rig)) inputs.push_back(imported->path);
  }
  std::erase(inputs, std::string());
  return inputs;
}

// Every output path the scene names may be replaced (io::require_replaceable_output) and is not an
// input of the scene, checked before any work is done.
void require_replaceable_outputs(const Scene& scene) {
  const SceneOutputs& outputs = scene.outputs;
  const std::vector<std::string> inputs = scene_inputs(scene);
  const auto check = [&](const std::string& path, bool folder) {
    if (path.empty()) return;
    io::require_replaceable_output(path, folder);
    io::require_not_an_input(path, inputs);
  };
  for (const std::vector<std::string>* paths : {&outputs.trajectories, &outputs.camera_paths, &outputs.point_caches,
                                                &outputs.previews, &outputs.rest_objs, &outputs.actor_reports}) {
    for (const std::string& path : *paths) check(path, false);
  }
  for (const std::string& path : outputs.point_caches) {
    if (!path.empty() && outputs.rest_objs.empty()) check(obj_beside(path), false);
  }
  if (!outputs.prop_point_cache.empty()) check(obj_beside(outputs.prop_point_cache), false);
  for (const std::string* path : {&outputs.glb, &outputs.scene_glb, &outputs.report, &outputs.prop_point_cache}) check(*path, false);
  for (const std::string& path : outputs.sequences) check(path, true);
}

}  // namespace

bool tracks_points(const SceneOutputs& outputs) {
  return any_path(outputs.trajectories) || any_path(outputs.previews) || any_path(outputs.sequences);
}

std::vector<std::unique_ptr<StreamSink>> open_sinks(const Scene& scene, const Shot& shot, io::StagedOutputs& staged) {
  const SceneOutputs& outputs = scene.outputs;
  std::vector<std::unique_ptr<StreamSink>> sinks;
  for (std::size_t c = 0; c < shot.cameras.size(); ++c) {
    if (asked(outputs.previews, c)) sinks.push_back(std::make_unique<ContactSheetSink>(static_cast<int>(c), shot.frames, outputs.previews[c], staged));
  }
  if (outputs.dense.any() && !any_path(outputs.sequences)) {
    throw std::invalid_argument("scene outputs: depth, normals and masks are written into sequence folders (layout pointodyssey)");
  }
  if (any_path(outputs.trajectories) || any_path(outputs.sequences)) {
    const std::vector<StreamActor> actors = stream_actors(shot);
    const io::TrajectoryFileHeader header = trajectory_file_header(actors, stream_props(shot), shot.frames, shot.fps);
    if (header.points == 0) throw std::invalid_argument("scene: trajectories asked for, but no points to track");
    for (std::size_t c = 0; c < shot.cameras.size(); ++c) {
      if (!asked(outputs.trajectories, c)) continue;
      sinks.push_back(std::make_unique<TrajectorySink>(static_cast<int>(c), outputs.trajectories[c], header, outputs.compress, staged));
    }
    const std::vector<Instance> instances = shot_instances(shot);
    for (std::size_t c = 0; c < shot.cameras.size(); ++c) {
      if (!asked(outputs.sequences, c)) continue;
      sinks.push_back(std::make_unique<PointOdysseySink>(static_cast<int>(c), outputs.sequences[c], header, outputs.dense, instances,
                                                          staged, std::max(outputs.threads, 1)));
    }
  }
  for (std::size_t a = 0; a < shot.actors.size(); ++a) {
    if (!asked(outputs.point_caches, a)) continue;
    const std::string obj = asked(outputs.rest_objs, a) ? outputs.rest_objs[a] : obj_beside(outputs.point_caches[a]);
    const ActorMotion& motion = *shot.actors[a].motion;
    sinks.push_back(std::make_unique<PointCacheSink>(static_cast<int>(a), motion.character, motion.source_path, shot.frames,
                                                     outputs.point_caches[a], obj, staged));
  }
  if (!outputs.prop_point_cache.empty()) {
    if (shot.props.names.empty()) throw std::invalid_argument("scene outputs: a props point cache asked for, but the scene has no props");
    sinks.push_back(std::make_unique<PointCacheSink>(-1, shot.props.character, scene.file, shot.frames, outputs.prop_point_cache,
                                                     obj_beside(outputs.prop_point_cache), staged));
  }
  for (std::size_t c = 0; c < shot.cameras.size(); ++c) {
    if (asked(outputs.camera_paths, c)) sinks.push_back(std::make_unique<CameraPathSink>(static_cast<int>(c), outputs.camera_paths[c], staged));
  }
  if (!outputs.glb.empty()) sinks.push_back(std::make_unique<CharacterGlbSink>(outputs.glb, staged));
  if (!outputs.scene_glb.empty()) sinks.push_back(std::make_unique<SceneGlbSink>(outputs.scene_glb, staged));
  if (!outputs.report.empty()) sinks.push_back(std::make_unique<SceneReportSink>(outputs.report, staged));
  for (std::size_t a = 0; a < shot.actors.size(); ++a) {
    if (asked(outputs.actor_reports, a)) {
      sinks.push_back(std::make_unique<ActorReportSink>(static_cast<int>(a), outputs.actor_reports[a], outputs.glb, staged));
    }
  }
  return sinks;
}

SceneResult run_sinks(Shot shot, const Scene& scene, std::span<const std::unique_ptr<StreamSink>> sinks,
                      const ProgressCallback& progress, Clock::time_point started) {
  SceneResult result;
  static_cast<Shot&>(result) = std::move(shot);
  result.seconds.retarget = result.retarget_seconds;
  const SceneOutputs& outputs = scene.outputs;
  const bool tracking = tracks_points(outputs);
  if (!tracking) {
    result.skipped.push_back("tracked points, visibility and occluder rasterising: no trajectories or previews asked for");
  }
  for (const auto& sink : sinks) {
    for (std::string& file : sink->files()) result.outputs.push_back(std::move(file));
  }

  // The frame loop runs when some output takes frames: points tracked, or a mesh every frame.
  const auto start = Clock::now();
  std::vector<bool> mesh_every_frame(result.actors.size());
  for (std::size_t a = 0; a < result.actors.size(); ++a) mesh_every_frame[a] = asked(outputs.point_caches, a);
  const bool meshes = std::find(mesh_every_frame.begin(), mesh_every_frame.end(), true) != mesh_every_frame.end() ||
                      !outputs.prop_point_cache.empty();
  if (tracking || meshes) {
    std::vector<bool> tracks(result.cameras.size());
    for (std::size_t c = 0; c < tracks.size(); ++c) {
      tracks[c] = asked(outputs.trajectories, c) || asked(outputs.previews, c) || asked(outputs.sequences, c);
    }
    const std::vector<StreamActor> actors = stream_actors(result, mesh_every_frame);
    const std::vector<StreamCamera> cameras = stream_cameras(result, tracks);
    StreamOptions options;
    options.chunk_frames = outputs.chunk_frames;
    options.threads = outputs.threads;
    options.prop_vertices = !outputs.prop_point_cache.empty();
    std::vector<StreamSink*> pointers;
    for (const auto& sink : sinks) pointers.push_back(sink.get());
    const auto on_chunk = [&](int done, int total) {
      if (progress) progress(ProgressEvent{"export", std::to_string(done) + " of " + std::to_string(total) + " frames", nullptr, done, total});
    };
    result.streams = run_frame_loop(actors, stream_props(result), cameras, pointers, options, on_chunk);
    for (std::size_t a = 0; a < result.actors.size(); ++a) {
      const long skipped = result.frames - result.streams.actor_mesh_frames[a];
      if (tracking && skipped > 0) {
        result.skipped.push_back("actor '" + result.actors[a].name + "': mesh not skinned in " + std::to_string(skipped) +
                                 " of " + std::to_string(result.frames) +
                                 " frames (no camera could see it, no point cache asked)");
      }
    }
  }
  // Reports list every output with the total time, so they finish after the others.
  for (const auto& sink : sinks) {
    if (!sink->is_report()) sink->finish(result);
  }
  result.seconds.streams = seconds_since(start);
  result.seconds.total = seconds_since(started);
  for (const auto& sink : sinks) {
    if (sink->is_report()) sink->finish(result);
  }
  return result;
}

SceneResult run_scene(const Scene& scene, const ProgressCallback& progress, LoadCache* cache) {
  const auto started = Clock::now();
  require_replaceable_outputs(scene);
  PrepareOptions options;
  options.sample_points = tracks_points(scene.outputs);
  Shot shot = prepare_shot(scene, options, progress, cache);
  io::StagedOutputs staged;
  const std::vector<std::unique_ptr<StreamSink>> sinks = open_sinks(scene, shot, staged);
  SceneResult result = run_sinks(std::move(shot), scene, sinks, progress, started);
  staged.commit();
  return result;
}

nlohmann::ordered_json scene_report_json(const SceneResult& result) {
  nlohmann::ordered_json json;
  json["scene"] = result.name;
  json["fps"] = result.fps;
  json["frames"] = result.frames;
  json["seed"] = result.seed;
  json["actors"] = nlohmann::ordered_json::array();
  for (std::size_t a = 0; a < result.actors.size(); ++a) {
    const PlacedActor& actor = result.actors[a];
    nlohmann::ordered_json entry;
    entry["name"] = actor.name;
    entry["id"] = a;
    entry["placement"] = {{"x", actor.x}, {"y", actor.y}, {"yaw_deg", actor.yaw_deg}};
    entry["start_s"] = actor.start_s;
    entry["points"] = actor.points;
    if (a < result.streams.actor_mesh_frames.size()) entry["mesh_frames_skinned"] = result.streams.actor_mesh_frames[a];
    // A motion's entry keeps its key "retarget"; the other sources report under "source".
    entry[actor.retargeted ? "retarget" : "source"] = actor_motion_report_json(*actor.motion);
    json["actors"].push_back(entry);
  }
  json["props"] = nlohmann::ordered_json::array();
  for (std::size_t p = 0; p < result.props.names.size(); ++p) {
    nlohmann::ordered_json entry = {{"name", result.props.names[p]}, {"id", -1 - static_cast<int>(p)}};
    if (p < result.prop_reports.size() && result.prop_reports[p]) {
      // What the simulation did (physics/rigid_scene.h, PropReport): metres, m/s, frames.
      const physics::PropReport& r = *result.prop_reports[p];
      entry["dynamic"] = {{"path_length_m", r.path_length},
                          {"top_speed_m_s", r.top_speed},
                          {"contact_frames", r.contact_frames},
                          {"contact_events", r.contact_events},
                          {"deepest_penetration_m", r.deepest_penetration},
                          {"deepest_prop_overlap_m", r.deepest_prop_overlap}};
    }
    json["props"].push_back(entry);
  }
  json["cameras"] = nlohmann::ordered_json::array();
  for (std::size_t c = 0; c < result.cameras.size(); ++c) {
    const CameraPath& path = result.cameras[c].path;
    nlohmann::ordered_json entry = {{"name", result.cameras[c].name},
                                    {"kind", path.kind},
                                    {"width", path.intrinsics.at(0).width},
                                    {"height", path.intrinsics.at(0).height},
                                    {"hfov_deg", path.intrinsics.at(0).horizontal_fov_deg()}};
    if (c < result.streams.cameras.size()) {
      const CameraStreamSummary& s = result.streams.cameras[c];
      entry["point_frames"] = {{"valid", s.valid_fraction},
                               {"visible", s.visible_fraction},
                               {"occluded_by_actor", s.occluded_by_actor_fraction},
                               {"occluded_by_prop", s.occluded_by_prop_fraction}};
      entry["actor_frames_culled"] = s.actor_frames_culled;
    }
    json["cameras"].push_back(entry);
  }
  json["points"] = result.streams.points;
  json["skipped"] = result.skipped;
  json["notes"] = result.notes;
  json["outputs"] = result.outputs;
  json["timings_s"] = {{"retarget", result.seconds.retarget},
                       {"physics", result.physics_seconds},
                       {"streams", result.seconds.streams},
                       {"total", result.seconds.total}};
  return json;
}

}  // namespace odyssey::scene
