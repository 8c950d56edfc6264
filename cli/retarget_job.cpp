#include "cli/retarget_job.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "cli/motion_file.h"
#include "mocap_io/amass.h"
#include "mocap_io/body_model_file.h"
#include "mocap_io/bvh.h"
#include "mocap_io/gltf_character.h"
#include "mocap_io/input_error.h"
#include "skeleton/body_clip.h"
#include "skeleton/pose_layout.h"
#include "skeleton/synthetic_body.h"

namespace odyssey::cli {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

// The refinement weights by the names --weights and the report use.
struct WeightName {
  const char* name;
  double retarget::RefineWeights::*weight;
};
constexpr WeightName kWeightNames[] = {
    {"bone_direction", &retarget::RefineWeights::bone_direction},
    {"end_effector", &retarget::RefineWeights::end_effector},
    {"foot_contact", &retarget::RefineWeights::foot_contact},
    {"floor", &retarget::RefineWeights::floor},
    {"pose", &retarget::RefineWeights::pose},
    {"pelvis", &retarget::RefineWeights::pelvis},
    {"smoothness", &retarget::RefineWeights::smoothness},
    {"pelvis_smoothness", &retarget::RefineWeights::pelvis_smoothness},
};

// "foot_contact=50,pose=0.1" over the quality's defaults.
void apply_weights(const std::string& text, retarget::RefineWeights& weights) {
  std::size_t at = 0;
  while (at <= text.size()) {
    const std::size_t comma = std::min(text.find(',', at), text.size());
    const std::string item = text.substr(at, comma - at);
    const std::size_t equals = item.find('=');
    if (equals == std::string::npos) throw UsageError("--weights expects NAME=VALUE items, got '" + item + "'");
    const std::string name = item.substr(0, equals);
    const auto known = std::find_if(std::begin(kWeightNames), std::end(kWeightNames),
                                    [&](const WeightName& entry) { return name == entry.name; });
    if (known == std::end(kWeightNames)) {
      std::string names;
      for (const WeightName& entry : kWeightNames) names += std::string(names.empty() ? "" : ", ") + entry.name;
      throw UsageError("--weights: unknown weight '" + name + "' (weights: " + names + ")");
    }
    double value = 0;
    std::size_t used = 0;
    try {
      value = std::stod(item.substr(equals + 1), &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != item.size() - equals - 1 || !(value >= 0) || !std::isfinite(value)) {
      throw UsageError("--weights: " + name + " expects a finite number >= 0, got '" + item.substr(equals + 1) + "'");
    }
    weights.*(known->weight) = value;
    at = comma + 1;
  }
}

struct Motion {
  Clip clip;
  std::string description;  // "BVH, 31 joints, 344 frames at 120 fps"
  std::string format;
  std::string body_model;
};

Motion load_motion(const RetargetSettings& settings) {
  const std::string& path = settings.motion_path;
  Motion motion;
  const MotionFileKind kind = detect_motion_file(path);
  if (kind == MotionFileKind::Bvh) {
    if (settings.model_path) throw UsageError("--model is for AMASS sequences; " + path + " is a BVH file");
    motion.clip = io::load_bvh(path, io::BvhOptions{settings.bvh_metres_per_unit});
    motion.format = "bvh";
    motion.description = "BVH";
  } else if (kind == MotionFileKind::Amass) {
    if (settings.bvh_units_given) throw UsageError("--bvh-units is for BVH files; " + path + " is an AMASS sequence");
    BodySequence sequence = io::load_amass_file(path).sequence;
    if (sequence.frame_count() < 1) throw io::InputError(path, "the sequence has no frames");
    BodyModel model;
    if (settings.model_path) {
      model = io::load_body_model(*settings.model_path);
      motion.body_model = *settings.model_path;
    } else {
      model = make_synthetic_body(0).model;
      motion.body_model = "synthetic SMPL-X body (seed 0)";
    }
    const std::string sequence_kind = body_model_kind_name(sequence.kind);
    sequence = sequence_for_model(sequence, model.kind);
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

std::string joined_names(const Skeleton& skeleton, const std::vector<int>& joints) {
  if (joints.empty()) return "none";
  std::string text;
  for (int j : joints) text += (text.empty() ? "" : ", ") + skeleton.name(j);
  return text;
}

std::string joined(const std::vector<std::string>& names) {
  if (names.empty()) return "none";
  std::string text;
  for (const std::string& name : names) text += (text.empty() ? "" : ", ") + name;
  return text;
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

// The map used, printed before the retargeting starts so that it is on screen when that fails.
void print_maps(const Skeleton& source, const retarget::BoneMap& full_source_map, const retarget::BoneMap& source_map,
                const std::vector<int>& source_left_out, const Skeleton& target, const retarget::BoneMap& full_target_map,
                const retarget::BoneMap& target_map, const std::vector<int>& target_left_out, retarget::Parts parts) {
  std::printf("maps       source: %s; target: %s; parts: %s\n", source_map.origin.c_str(), target_map.origin.c_str(),
              retarget::parts_name(parts));
  std::printf("map used (canonical: source -> target):\n");
  std::vector<std::string> source_only, target_only;
  for (int c = 0; c < retarget::kCanonicalJointCount; ++c) {
    const std::string canonical(retarget::canonical_name(c));
    if (source_map.mapped(c) && target_map.mapped(c)) {
      std::printf("  %-18s %s -> %s\n", canonical.c_str(), source.name(source_map.joints[c]).c_str(),
                  target.name(target_map.joints[c]).c_str());
    } else if (source_map.mapped(c)) {
      source_only.push_back(canonical + " (" + source.name(source_map.joints[c]) + ")");
    } else if (target_map.mapped(c)) {
      target_only.push_back(canonical + " (" + target.name(target_map.joints[c]) + ")");
    }
  }
  for (const retarget::BoneMap::Follower& follower : target_map.followers) {
    std::printf("  %-18s target %s moves rigidly with it\n", std::string(retarget::canonical_name(follower.canonical)).c_str(),
                target.name(follower.joint).c_str());
  }
  std::printf("mapped on the source only (drive nothing): %s\n", joined(source_only).c_str());
  std::printf("mapped on the target only (keep their rest rotation): %s\n", joined(target_only).c_str());
  std::printf("unmapped source joints: %s\n", joined_names(source, retarget::unmapped_joints(source, full_source_map)).c_str());
  std::printf("unmapped target joints (keep their rest rotation): %s\n",
              joined_names(target, retarget::unmapped_joints(target, full_target_map)).c_str());
  if (!source_left_out.empty() || !target_left_out.empty()) {
    std::printf("left out by --parts %s (target joints keep their rest rotation): source: %s; target: %s\n",
                retarget::parts_name(parts), joined_names(source, source_left_out).c_str(),
                joined_names(target, target_left_out).c_str());
  }
}

void print_metrics(const retarget::RetargetReport& report) {
  const retarget::RetargetMetrics& result = report.result_metrics;
  const retarget::RetargetMetrics& source = report.source_metrics;
  std::printf("metrics (%s; the scaled source in brackets):\n", report.quality.c_str());
  std::printf("  bone direction error   mean %.3f deg, max %.3f deg over %ld bone-frames\n", result.bone_direction.mean_deg,
              result.bone_direction.max_deg, result.bone_direction.samples);
  for (const auto& limb : result.limbs) {
    std::printf("    %-20s mean %.3f deg, max %.3f deg\n", limb.name.c_str(), limb.error.mean_deg, limb.error.max_deg);
  }
  std::printf("  branch directions      mean %.3f deg, max %.3f deg (the rigs' builds: hip width, shoulder slope)\n",
              result.branch_direction.mean_deg, result.branch_direction.max_deg);
  std::printf("  end-effector error     mean %.4f m, max %.4f m\n", result.end_effector_mean_m, result.end_effector_max_m);
  std::printf("  foot skate ratio       %.4f (%.4f)\n", result.foot_skate_ratio, source.foot_skate_ratio);
  std::printf("  penetration            %.3f cm (%.3f)\n", result.penetration_cm, source.penetration_cm);
  std::printf("  floating               %.3f cm (%.3f)\n", result.floating_cm, source.floating_cm);
  std::printf("  jitter                 %.3f m/s^2 (%.3f)\n", result.jitter, source.jitter);
}

}  // namespace

void add_retarget_options(Args& args) {
  args.option("motion", "FILE", "BVH file or AMASS-style npz sequence (required)")
      .option("character", "FILE", "rigged humanoid character, .glb or .gltf (required)")
      .option("quality", "Q",
              "fast (rotation transfer, no solver), balanced (Ceres refinement per frame: bone directions, "
              "end effectors, foot contacts) or accurate (refinement over temporal windows, smoother)",
              "fast")
      .option("parts", "PARTS",
              "what is solved: body (fingers and face keep their rest pose), body+hands, or all (also jaw and "
              "eyes where both maps have them)",
              "body")
      .option("threads", "N", "threads for the refinement's independent windows (balanced, accurate) and for skinning", "1")
      .option("fps", "FPS", "resample the motion to this frame rate before retargeting", "30")
      .option("map", "FILE", "JSON bone map for the character, applied over the preset or detected map (default: none)")
      .option("source-map", "FILE", "JSON bone map for the motion's skeleton, applied likewise (default: none)")
      .option("model", "FILE",
              "SMPL-X / SMPL-H / SMPL body model npz for an AMASS motion (default: the synthetic SMPL-X body, seed 0)")
      .option("source-rest", "POSE",
              "source pose aligned onto the character's rest pose: rest (the skeleton's rest pose) or first-frame "
              "(the clip's first frame; CMU BVH files open with a T-pose there)",
              "rest")
      .option("weights", "LIST",
              "refinement weights over the quality's defaults, NAME=VALUE separated by commas; names: "
              "bone_direction, end_effector, foot_contact, floor, pose, pelvis, smoothness, pelvis_smoothness "
              "(defaults and units: README, retargeting conventions)");
  add_bvh_units_option(args);
}

RetargetSettings retarget_settings(const Args& args) {
  RetargetSettings settings;
  settings.motion_path = args.get("motion");
  settings.character_path = args.get("character");
  settings.map_path = args.get_optional("map");
  settings.source_map_path = args.get_optional("source-map");
  settings.model_path = args.get_optional("model");
  const auto quality = retarget::parse_quality(args.get("quality"));
  if (!quality) throw UsageError("--quality expects fast, balanced or accurate, got '" + args.get("quality") + "'");
  settings.quality = *quality;
  const auto parts = retarget::parse_parts(args.get("parts"));
  if (!parts) throw UsageError("--parts expects body, body+hands or all, got '" + args.get("parts") + "'");
  settings.parts = *parts;
  settings.fps = args.get_double("fps");
  if (!(settings.fps > 0) || !std::isfinite(settings.fps)) throw UsageError("--fps must be positive");
  settings.refine_options = retarget::default_refine_options(settings.quality);
  const long long threads = args.get_int("threads");
  if (threads < 1 || threads > 1024) throw UsageError("--threads expects 1 to 1024, got " + std::to_string(threads));
  settings.refine_options.threads = static_cast<int>(threads);
  if (const auto weights = args.get_optional("weights")) apply_weights(*weights, settings.refine_options.weights);
  const std::string source_rest = args.get("source-rest");
  if (source_rest == "rest") {
    settings.options.source_rest = retarget::SourceRest::rest;
  } else if (source_rest == "first-frame") {
    settings.options.source_rest = retarget::SourceRest::first_frame;
  } else {
    throw UsageError("--source-rest expects rest or first-frame, got '" + source_rest + "'");
  }
  settings.bvh_units_given = args.has("bvh-units");
  settings.bvh_metres_per_unit = bvh_metres_per_unit(args);
  return settings;
}

RetargetJob run_retarget_job(const RetargetSettings& settings) {
  RetargetJob job;
  job.settings = settings;

  auto start = Clock::now();
  Motion motion = load_motion(settings);
  job.source_fps = motion.clip.fps;
  job.source = motion.clip.resampled(settings.fps);
  job.motion_format = motion.format;
  job.body_model = motion.body_model;
  job.seconds.load_motion = seconds_since(start);
  std::printf("motion     %s: %s, resampled to %d frames at %.6g fps\n", settings.motion_path.c_str(),
              motion.description.c_str(), job.source.frame_count(), job.source.fps);
  std::fflush(stdout);

  start = Clock::now();
  job.character = io::load_character(settings.character_path);
  job.seconds.load_character = seconds_since(start);
  std::printf("character  %s: %d joints, %zu mesh%s\n", settings.character_path.c_str(),
              job.character.skeleton.joint_count(), job.character.meshes.size(),
              job.character.meshes.size() == 1 ? "" : "es");
  std::fflush(stdout);

  start = Clock::now();
  job.full_source_map =
      retarget::humanoid_bone_map(job.source.skeleton, settings.motion_path, settings.source_map_path.value_or(""));
  job.full_target_map =
      retarget::humanoid_bone_map(job.character.skeleton, settings.character_path, settings.map_path.value_or(""));
  job.source_map = retarget::restrict_bone_map(job.full_source_map, settings.parts);
  job.target_map = retarget::restrict_bone_map(job.full_target_map, settings.parts);
  job.seconds.bone_maps = seconds_since(start);
  job.source_left_out = left_out_by_parts(job.source.skeleton, job.full_source_map, job.source_map);
  job.target_left_out = left_out_by_parts(job.character.skeleton, job.full_target_map, job.target_map);
  print_maps(job.source.skeleton, job.full_source_map, job.source_map, job.source_left_out, job.character.skeleton,
             job.full_target_map, job.target_map, job.target_left_out, settings.parts);
  std::fflush(stdout);

  start = Clock::now();
  job.result = retarget::retarget_fast(job.source, job.source_map, job.character, job.target_map, settings.options,
                                       settings.motion_path);
  job.seconds.retarget_fast = seconds_since(start);
  if (settings.quality != retarget::Quality::fast) {
    job.refined = retarget::refine(job.result, job.source, settings.refine_options);
  }
  const retarget::RetargetReport& report = job.result.report;
  std::printf("scale      %.6g (target %.4f m / source %.4f m, paired joints' height span), floor offset %.4f m\n",
              report.scale, report.target_height, report.source_height, report.floor_offset);
  std::printf("alignment  mean residual %.4f deg, max %.4f deg over %d terms\n", report.alignment.mean_residual_deg,
              report.alignment.max_residual_deg, report.alignment.fitted_terms);
  std::printf("contacts   left foot planted in %d frames, right in %d, of %d\n", report.planted_left,
              report.planted_right, report.frames);
  print_metrics(report);
  std::fflush(stdout);
  return job;
}

nlohmann::ordered_json retarget_job_report(const RetargetJob& job) {
  const RetargetSettings& settings = job.settings;
  // report_json holds what the retargeting knows; the job adds what only it knows (the files, the
  // command-line settings, the parts left out).
  nlohmann::ordered_json json = nlohmann::ordered_json::parse(retarget::report_json(job.result.report));
  json["inputs"] = {{"motion", settings.motion_path},
                    {"motion_format", job.motion_format},
                    {"motion_fps", job.source_fps},
                    {"character", settings.character_path}};
  if (job.motion_format == "bvh") json["inputs"]["bvh_metres_per_unit"] = settings.bvh_metres_per_unit;
  if (job.motion_format == "amass") json["inputs"]["body_model"] = job.body_model;
  json["settings"]["parts"] = retarget::parts_name(settings.parts);
  json["settings"]["fps"] = settings.fps;
  json["settings"]["map_file"] = settings.map_path ? nlohmann::ordered_json(*settings.map_path) : nlohmann::ordered_json();
  json["settings"]["source_map_file"] =
      settings.source_map_path ? nlohmann::ordered_json(*settings.source_map_path) : nlohmann::ordered_json();
  if (job.refined) {
    const retarget::RefineOptions& options = settings.refine_options;
    nlohmann::ordered_json weights;
    for (const WeightName& entry : kWeightNames) weights[entry.name] = options.weights.*(entry.weight);
    json["settings"]["refine"] = {{"weights", weights},
                                  {"contact_blend_seconds", options.contact_blend_seconds},
                                  {"window_frames", options.window_frames},
                                  {"window_margin", options.window_margin},
                                  {"max_iterations", options.max_iterations},
                                  {"window_iterations", options.window_iterations},
                                  {"smoothness_limit", options.smoothness_limit},
                                  {"pelvis_smoothness_limit", options.pelvis_smoothness_limit},
                                  {"warm_start", options.warm_start},
                                  {"fit_stride", options.fit_stride},
                                  {"threads", options.threads}};
    const retarget::RefineSummary& refined = *job.refined;
    json["refine"] = {{"seconds", refined.seconds},         {"solve_seconds", refined.solve_seconds},
                      {"frames", refined.frames},           {"windows", refined.windows},
                      {"iterations", refined.iterations},   {"unknown_joints", refined.unknown_joints},
                      {"stride_factor", refined.stride}};
  }
  json["left_out_by_parts"] = {{"source", names_of(job.source.skeleton, job.source_left_out)},
                               {"target", names_of(job.character.skeleton, job.target_left_out)}};
  json["timings_s"]["command"] = {{"load_motion", job.seconds.load_motion},
                                  {"load_character", job.seconds.load_character},
                                  {"bone_maps", job.seconds.bone_maps},
                                  {"retarget_fast", job.seconds.retarget_fast},
                                  {"refine", job.refined ? job.refined->seconds : 0.0}};
  return json;
}

std::string retarget_job_timings(const RetargetJob& job) {
  const retarget::RetargetTimings& timings = job.result.report.timings;
  const int frames = job.result.report.frames;
  char text[512];
  int used = std::snprintf(text, sizeof text,
                           "load motion %.3f s, character %.3f s, maps %.3f s, rig %.3f s, contacts %.3f s, transfer "
                           "%.3f s (%.0f frames/s), metrics %.3f s",
                           job.seconds.load_motion, job.seconds.load_character, job.seconds.bone_maps, timings.rig,
                           timings.contacts, timings.transfer, timings.transfer > 0 ? frames / timings.transfer : 0.0,
                           timings.metrics);
  if (job.refined && used > 0 && used < static_cast<int>(sizeof text)) {
    std::snprintf(text + used, sizeof text - used,
                  ", refine %.3f s (solvers %.3f s, %.0f frames/s, %d windows, %ld iterations, threads: %d)",
                  job.refined->seconds, job.refined->solve_seconds,
                  job.refined->seconds > 0 ? frames / job.refined->seconds : 0.0, job.refined->windows,
                  job.refined->iterations, job.settings.refine_options.threads);
  }
  return text;
}

}  // namespace odyssey::cli
