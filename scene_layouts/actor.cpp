#include "scene_layouts/actor.h"

#include <sys/stat.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "mocap_io/input_file.h"
#include "mocap_io/amass.h"
#include "mocap_io/body_model_file.h"
#include "mocap_io/bvh.h"
#include "mocap_io/gltf_character.h"
#include "mocap_io/input_error.h"
#include "mocap_io/motion_file.h"
#include "retarget/quality.h"
#include "skeleton/body_clip.h"
#include "skeleton/pose_layout.h"
#include "synthetic/synthetic_body.h"

namespace odyssey::scene {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

struct Motion {
  Clip clip;
  std::string description, format, body_model;
  std::optional<BetasFit> betas;  // AMASS
  std::optional<io::BvhFrameGuess> bvh_frame;  // BVH
};

Motion load_motion(const RetargetRequest& request, LoadCache* cache) {
  const std::string& path = request.motion_path;
  Motion motion;
  const io::MotionFileKind kind = io::detect_motion_file(path);
  if (kind == io::MotionFileKind::Bvh) {
    if (request.model_path) throw io::InputError(path, "a body model is for AMASS sequences; this is a BVH file");
    io::LoadedBvh bvh = io::load_bvh_inferring_frame(path, request.bvh_metres_per_unit);
    motion.clip = std::move(bvh.clip);
    motion.bvh_frame = bvh.frame;
    motion.format = "bvh";
    motion.description = "BVH";
  } else if (kind == io::MotionFileKind::Amass) {
    if (request.bvh_metres_per_unit) throw io::InputError(path, "a BVH unit is for BVH files; this is an AMASS sequence");
    BodySequence sequence = io::load_amass_file(path).sequence;
    if (sequence.frame_count() < 1) throw io::InputError(path, "the sequence has no frames");
    std::shared_ptr<const BodyModel> loaded;
    if (cache) {
      loaded = cache->body_model(request.model_path);
    } else if (request.model_path) {
      loaded = std::make_shared<const BodyModel>(io::load_body_model(*request.model_path));
    } else {
      loaded = std::make_shared<const BodyModel>(make_synthetic_body(0).model);
    }
    const BodyModel& model = *loaded;
    motion.body_model = request.model_path ? *request.model_path : "synthetic SMPL-X body (seed 0)";
    const std::string sequence_kind = body_model_kind_name(sequence.kind);
    sequence = sequence_for_model(sequence, model.kind);
    try {
      motion.betas = fit_betas(model, sequence.betas, request.betas);
    } catch (const std::invalid_argument& error) {
      throw io::InputError(path, std::string(error.what()) + " (model " + motion.body_model + ")");
    }
    sequence.betas = motion.betas->betas;
    try {
      motion.clip = clip_from_body_sequence(model, sequence);
    } catch (const std::invalid_argument& error) {
      throw io::InputError(path, error.what());
    }
    motion.format = "amass";
    motion.description = "AMASS " + sequence_kind + " on the " + motion.body_model;
  } else {
    throw io::InputError(path, "not a motion: expected a BVH file or an AMASS-style npz sequence (poses or root_orient)");
  }
  char counts[128];
  std::snprintf(counts, sizeof counts, ", %d joints, %d frames at %.6g fps", motion.clip.joint_count(),
                motion.clip.frame_count(), motion.clip.fps);
  motion.description += counts;
  return motion;
}

// Rig joints that had a role (mapped or following) in `full` and have none in `restricted`.
std::vector<int> left_out_by_parts(const Skeleton& skeleton, const retarget::BoneMap& full,
                                   const retarget::BoneMap& restricted) {
  const std::vector<int> before = retarget::unmapped_joints(skeleton, full);
  std::vector<int> left_out;
  for (int j : retarget::unmapped_joints(skeleton, restricted)) {
    if (!std::binary_search(before.begin(), before.end(), j)) left_out.push_back(j);
  }
  return left_out;
}

std::vector<std::string> names_of(const Skeleton& skeleton, const std::vector<int>& joints) {
  std::vector<std::string> names;
  for (int j : joints) names.push_back(skeleton.name(j));
  return names;
}

}  // namespace

RetargetRequest retarget_request(std::string motion_path, std::string character_path, retarget::Quality quality) {
  RetargetRequest request;
  request.motion_path = std::move(motion_path);
  request.character_path = std::move(character_path);
  request.quality = quality;
  request.refine_options = retarget::default_refine_options(quality);
  return request;
}

namespace {

// The file's size and modification time, or nothing when it cannot be read (the loader then
// reports the problem).
std::optional<std::pair<std::uintmax_t, std::int64_t>> file_stamp(const std::string& path) {
  struct stat status {};
  if (::stat(path.c_str(), &status) != 0) return std::nullopt;
  return std::make_pair(static_cast<std::uintmax_t>(status.st_size),
                        static_cast<std::int64_t>(status.st_mtim.tv_sec) * 1000000000 + status.st_mtim.tv_nsec);
}

template <class T, class Load>
std::shared_ptr<const T> cached(std::map<std::string, LoadCache::Entry<T>>& entries, const std::string& key,
                                const std::string& path, Load&& load) {
  const auto stamp = path.empty() ? std::make_optional(std::make_pair(std::uintmax_t{0}, std::int64_t{0})) : file_stamp(path);
  auto found = entries.find(key);
  if (stamp && found != entries.end() && found->second.size == stamp->first && found->second.mtime_ns == stamp->second) {
    return found->second.value;
  }
  auto value = std::make_shared<const T>(load());
  if (stamp) entries[key] = {stamp->first, stamp->second, value};
  return value;
}

}  // namespace

std::shared_ptr<const Character> LoadCache::character(const std::string& path) {
  return cached(characters_, path, path, [&] { return io::load_character(path); });
}

std::shared_ptr<const BodyModel> LoadCache::body_model(const std::optional<std::string>& path) {
  if (!path) return cached(body_models_, "", "", [] { return make_synthetic_body(0).model; });
  return cached(body_models_, *path, *path, [&] { return io::load_body_model(*path); });
}

RetargetedActor retarget_actor(const RetargetRequest& request, const ProgressCallback& progress, LoadCache* cache) {
  RetargetedActor actor;
  actor.request = request;
  const auto report = [&](const char* stage, std::string message) {
    if (progress) progress(ProgressEvent{stage, std::move(message), &actor, 0, 0});
  };

  auto start = Clock::now();
  Motion motion = load_motion(request, cache);
  actor.source_fps = motion.clip.fps;
  // The clip at the output rate stays within the frame cap, checked before it is allocated.
  io::require_frames_within_cap(request.motion_path, motion.clip.frame_count(), motion.clip.fps, request.fps);
  actor.source = motion.clip.resampled(request.fps);
  actor.motion_format = motion.format;
  actor.motion_description = motion.description;
  actor.body_model = motion.body_model;
  actor.betas = motion.betas;
  actor.bvh_frame = motion.bvh_frame;
  actor.seconds.load_motion = seconds_since(start);
  char line[512];
  std::snprintf(line, sizeof line, "%s: %s, resampled to %d frames at %.6g fps", request.motion_path.c_str(),
                motion.description.c_str(), actor.source.frame_count(), actor.source.fps);
  report("load_motion", line);
  if (actor.bvh_frame) {
    report("bvh_units", actor.bvh_frame->description());
    if (!actor.bvh_frame->plausible) report("warning", actor.bvh_frame->warning(request.motion_path));
  }
  if (actor.betas) {
    report("betas", actor.betas->summary());
    if (actor.betas->dropped > 0) report("warning", request.motion_path + ": " + actor.betas->warning());
  }

  start = Clock::now();
  actor.character = cache ? *cache->character(request.character_path) : io::load_character(request.character_path);
  actor.seconds.load_character = seconds_since(start);
  std::snprintf(line, sizeof line, "%s: %d joints, %zu mesh%s", request.character_path.c_str(),
                actor.character.skeleton.joint_count(), actor.character.meshes.size(),
                actor.character.meshes.size() == 1 ? "" : "es");
  report("load_character", line);

  start = Clock::now();
  actor.full_source_map =
      retarget::humanoid_bone_map(actor.source.skeleton, request.motion_path, request.source_map_path.value_or(""));
  actor.full_target_map =
      retarget::humanoid_bone_map(actor.character, request.character_path, request.map_path.value_or(""));
  actor.source_map = retarget::restrict_bone_map(actor.full_source_map, request.parts);
  actor.target_map = retarget::restrict_bone_map(actor.full_target_map, request.parts);
  actor.seconds.bone_maps = seconds_since(start);
  actor.source_left_out = left_out_by_parts(actor.source.skeleton, actor.full_source_map, actor.source_map);
  actor.target_left_out = left_out_by_parts(actor.character.skeleton, actor.full_target_map, actor.target_map);
  report("bone_maps", "source: " + actor.source_map.origin + "; target: " + actor.target_map.origin +
                          "; parts: " + retarget::parts_name(request.parts));

  retarget::Retargeting retargeting =
      retarget::retarget(actor.source, actor.source_map, actor.character, actor.target_map, request.quality, request.options,
                         request.refine_options, request.motion_path);
  actor.result = std::move(retargeting.result);
  actor.refined = std::move(retargeting.refined);
  actor.seconds.retarget_fast = retargeting.fast_seconds;
  report("retarget", std::string("quality ") + retarget::quality_name(request.quality) + ", " +
                         std::to_string(actor.result.report.frames) + " frames");
  return actor;
}

nlohmann::ordered_json refine_settings_json(const retarget::RefineOptions& options) {
  nlohmann::ordered_json weights;
  for (const retarget::RefineWeightName& entry : retarget::refine_weight_names()) {
    weights[entry.name] = options.weights.*(entry.weight);
  }
  return {{"weights", weights},
          {"contact_blend_seconds", options.contact_blend_seconds},
          {"contact_lift_m", options.contact_lift ? nlohmann::ordered_json(*options.contact_lift) : nlohmann::ordered_json()},
          {"window_frames", options.window_frames},
          {"span_frames", options.span_frames},
          {"span_lookahead", options.span_lookahead},
          {"max_iterations", options.max_iterations},
          {"span_iterations", options.span_iterations},
          {"smoothness_limit", options.smoothness_limit},
          {"pelvis_smoothness_limit", options.pelvis_smoothness_limit},
          {"warm_start", options.warm_start},
          {"fit_stride", options.fit_stride}};
}

nlohmann::ordered_json actor_report_json(const RetargetedActor& actor) {
  const RetargetRequest& request = actor.request;
  nlohmann::ordered_json json = retarget::report_json(actor.result.report);
  json["inputs"] = {{"motion", request.motion_path},
                    {"motion_format", actor.motion_format},
                    {"motion_fps", actor.source_fps},
                    {"character", request.character_path}};
  if (actor.bvh_frame) {
    const io::BvhFrameGuess& frame = *actor.bvh_frame;
    json["inputs"]["bvh_metres_per_unit"] = frame.metres_per_unit;
    json["inputs"]["bvh_units"] = {{"unit", frame.unit},
                                   {"inferred", frame.unit_inferred},
                                   {"up", frame.up == io::BvhUp::y ? "y" : "z"},
                                   {"measured_on", frame.measured_on},
                                   {"height_units", frame.height_units},
                                   {"height_m", frame.height_m()},
                                   {"plausible", frame.plausible},
                                   {"description", frame.description()}};
  }
  if (actor.motion_format == "amass") json["inputs"]["body_model"] = actor.body_model;
  if (actor.betas) {
    const BetasFit& betas = *actor.betas;
    json["inputs"]["betas"] = {{"policy", betas_policy_name(betas.policy)},
                               {"file_count", betas.file_count},
                               {"model_count", betas.model_count},
                               {"dropped", betas.dropped},
                               {"largest_dropped_magnitude", betas.largest_dropped},
                               {"padded", betas.padded}};
  }
  json["settings"]["parts"] = retarget::parts_name(request.parts);
  json["settings"]["fps"] = request.fps;
  json["settings"]["map_file"] = request.map_path ? nlohmann::ordered_json(*request.map_path) : nlohmann::ordered_json();
  json["settings"]["source_map_file"] =
      request.source_map_path ? nlohmann::ordered_json(*request.source_map_path) : nlohmann::ordered_json();
  if (actor.refined) {
    json["settings"]["refine"] = refine_settings_json(request.refine_options);
    json["settings"]["refine"]["threads"] = request.refine_options.threads;
    const retarget::RefineSummary& refined = *actor.refined;
    json["refine"] = {{"seconds", refined.seconds},         {"solve_seconds", refined.solve_seconds},
                      {"frames", refined.frames},           {"windows", refined.windows}, {"spans", refined.spans},
                      {"iterations", refined.iterations},   {"unknown_joints", refined.unknown_joints},
                      {"stride_factor", refined.stride}};
  }
  json["left_out_by_parts"] = {{"source", names_of(actor.source.skeleton, actor.source_left_out)},
                               {"target", names_of(actor.character.skeleton, actor.target_left_out)}};
  json["timings_s"]["command"] = {{"load_motion", actor.seconds.load_motion},
                                  {"load_character", actor.seconds.load_character},
                                  {"bone_maps", actor.seconds.bone_maps},
                                  {"retarget_fast", actor.seconds.retarget_fast},
                                  {"refine", actor.refined ? actor.refined->seconds : 0.0}};
  return json;
}

std::string actor_timings(const RetargetedActor& actor) {
  const retarget::RetargetTimings& timings = actor.result.report.timings;
  const int frames = actor.result.report.frames;
  char text[512];
  int used = std::snprintf(text, sizeof text,
                           "load motion %.3f s, character %.3f s, maps %.3f s, rig %.3f s, contacts %.3f s, transfer "
                           "%.3f s (%.0f frames/s), metrics %.3f s",
                           actor.seconds.load_motion, actor.seconds.load_character, actor.seconds.bone_maps, timings.rig,
                           timings.contacts, timings.transfer, timings.transfer > 0 ? frames / timings.transfer : 0.0,
                           timings.metrics);
  if (actor.refined && used > 0 && used < static_cast<int>(sizeof text)) {
    std::snprintf(text + used, sizeof text - used,
                  ", refine %.3f s (solvers %.3f s, %.0f frames/s, %d windows, %d spans, %ld iterations, threads: %d)",
                  actor.refined->seconds, actor.refined->solve_seconds,
                  actor.refined->seconds > 0 ? frames / actor.refined->seconds : 0.0, actor.refined->windows,
                  actor.refined->spans, actor.refined->iterations, actor.request.refine_options.threads);
  }
  return text;
}

}  // namespace odyssey::scene
