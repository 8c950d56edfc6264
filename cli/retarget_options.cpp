#include "cli/retarget_options.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "cli/motion_file.h"

namespace odyssey::cli {
namespace {

// "foot_contact=50,pose=0.1" over the quality's defaults.
// "bone_direction, end_effector, ...": the weights' names as refine.h lists them.
std::string weight_names() {
  std::string names;
  for (const retarget::RefineWeightName& entry : retarget::refine_weight_names()) {
    names += std::string(names.empty() ? "" : ", ") + entry.name;
  }
  return names;
}

void apply_weights(const std::string& text, retarget::RefineWeights& weights) {
  std::size_t at = 0;
  while (at <= text.size()) {
    const std::size_t comma = std::min(text.find(',', at), text.size());
    const std::string item = text.substr(at, comma - at);
    const std::size_t equals = item.find('=');
    if (equals == std::string::npos) throw UsageError("--weights expects NAME=VALUE items, got '" + item + "'");
    const std::string name = item.substr(0, equals);
    double* weight = retarget::refine_weight(weights, name);
    if (!weight) throw UsageError("--weights: unknown weight '" + name + "' (weights: " + weight_names() + ")");
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
    *weight = value;
    at = comma + 1;
  }
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

void print_maps(const scene::RetargetedActor& actor) {
  const Skeleton& source = actor.source.skeleton;
  const Skeleton& target = actor.character.skeleton;
  const retarget::BoneMap& source_map = actor.source_map;
  const retarget::BoneMap& target_map = actor.target_map;
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
  std::printf("unmapped source joints: %s\n",
              joined_names(source, retarget::unmapped_joints(source, actor.full_source_map)).c_str());
  std::printf("unmapped target joints (keep their rest rotation): %s\n",
              joined_names(target, retarget::unmapped_joints(target, actor.full_target_map)).c_str());
  if (!actor.source_left_out.empty() || !actor.target_left_out.empty()) {
    std::printf("left out by --parts %s (target joints keep their rest rotation): source: %s; target: %s\n",
                retarget::parts_name(actor.request.parts), joined_names(source, actor.source_left_out).c_str(),
                joined_names(target, actor.target_left_out).c_str());
  }
}

void print_result(const retarget::RetargetReport& report) {
  std::printf("scale      %.6g (target %.4f m / source %.4f m, paired joints' height span), floor offset %.4f m\n",
              report.scale, report.target_height, report.source_height, report.floor_offset);
  std::printf("alignment  mean residual %.4f deg, max %.4f deg over %d terms\n", report.alignment.mean_residual_deg,
              report.alignment.max_residual_deg, report.alignment.fitted_terms);
  std::printf("contacts   left foot planted in %d frames, right in %d, of %d\n", report.planted_left,
              report.planted_right, report.frames);
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
  if (result.foot_direction.samples > 0) {
    std::printf("  feet                   mean %.3f deg, max %.3f deg (pitched to the floor: where the rigs put the ball joint)\n",
                result.foot_direction.mean_deg, result.foot_direction.max_deg);
  }
  if (result.hip_line.samples > 0) {
    std::printf("  hip line               mean %.3f deg, max %.3f deg (the pelvis's roll and turn)\n", result.hip_line.mean_deg,
                result.hip_line.max_deg);
  }
  std::printf("  end-effector error     mean %.4f m, max %.4f m\n", result.end_effector_mean_m, result.end_effector_max_m);
  std::printf("  foot skate ratio       %.4f (%.4f), thresholds scaled by the scale; GMD's fixed 5 cm, 0.5 m/s: %.4f\n",
              result.foot_skate_ratio, source.foot_skate_ratio, result.foot_skate_ratio_gmd);
  std::printf("  penetration            %.3f cm (%.3f)\n", result.penetration_cm, source.penetration_cm);
  std::printf("  floating               %.3f cm (%.3f)\n", result.floating_cm, source.floating_cm);
  std::printf("  foot tilt in contact   %.2f deg (%.2f)\n", result.foot_tilt_deg, source.foot_tilt_deg);
  std::printf("  jitter                 %.3f m/s^2 (%.3f)\n", result.jitter, source.jitter);
}

}  // namespace

void add_retarget_options(Args& args) {
  args.option("motion", "FILE", "BVH file or AMASS-style npz sequence (required)")
      .option("character", "FILE", "rigged humanoid character, .glb or .gltf (required)");
  add_retarget_settings(args);
}

void add_retarget_settings(Args& args) {
  args.option("quality", "Q",
              "fast (rotation transfer, no solver), balanced (Ceres refinement per frame: bone directions, "
              "end effectors, foot contacts) or accurate (then the legs and root of the whole clip as one space-time problem, smoother)",
              "fast")
      .option("parts", "PARTS",
              "what is solved: body (fingers and face keep their rest pose), body+hands, or all (also jaw and "
              "eyes where both maps have them)",
              "body")
      .option("threads", "N", "threads for the refinement's frame-by-frame windows (balanced, and accurate's first pass) and for skinning", "1")
      .option("fps", "FPS", "resample the motion to this frame rate before retargeting", "30")
      .option("map", "FILE", "JSON bone map for the character, applied over the preset or detected map, or auto-structure: "
              "the map found from the skeleton's structure alone (default: none)")
      .option("source-map", "FILE", "JSON bone map for the motion's skeleton, applied likewise, or auto-structure (default: none)")
      .option("model", "FILE",
              "SMPL-X / SMPL-H / SMPL body model npz for an AMASS motion (default: the synthetic SMPL-X body, seed 0)")
      .option("source-rest", "POSE",
              "source pose aligned onto the character's rest pose: rest (the skeleton's rest pose) or first-frame "
              "(the clip's first frame; CMU BVH files open with a T-pose there)",
              "rest")
      .option("weights", "LIST",
              "refinement weights over the quality's defaults, NAME=VALUE separated by commas; names: " + weight_names() +
                  " (defaults and units: docs/retargeting.md)")
      .option("contact-lift", "M|off",
              "let a planted foot joint rise with the performer's once the performer's is more than M metres above "
              "its ground (at the performer's size; the legs bend less at toe-off, the foot leaves the floor earlier; "
              "docs/retargeting.md); off holds it on the floor through the contact (default: 0.03)");
  add_bvh_units_option(args);
  add_betas_option(args);
}

scene::RetargetRequest retarget_request_from(const Args& args) {
  return retarget_settings_from(args, args.get("motion"), args.get("character"));
}

scene::RetargetRequest retarget_settings_from(const Args& args, const std::string& motion, const std::string& character) {
  const auto quality = retarget::parse_quality(args.get("quality"));
  if (!quality) throw UsageError("--quality expects fast, balanced or accurate, got '" + args.get("quality") + "'");
  scene::RetargetRequest request = scene::retarget_request(motion, character, *quality);
  request.map_path = args.get_optional("map");
  request.source_map_path = args.get_optional("source-map");
  request.model_path = args.get_optional("model");
  request.betas = betas_policy(args);
  const auto parts = retarget::parse_parts(args.get("parts"));
  if (!parts) throw UsageError("--parts expects body, body+hands or all, got '" + args.get("parts") + "'");
  request.parts = *parts;
  request.fps = args.get_double("fps");
  if (!(request.fps > 0) || !std::isfinite(request.fps)) throw UsageError("--fps must be positive");
  const long long threads = args.get_int("threads");
  if (threads < 1 || threads > 1024) throw UsageError("--threads expects 1 to 1024, got " + std::to_string(threads));
  request.refine_options.threads = static_cast<int>(threads);
  // Fast runs no refinement: its settings would be taken and silently do nothing.
  for (const char* refinement : {"weights", "contact-lift"}) {
    if (*quality == retarget::Quality::fast && args.has(refinement)) {
      throw UsageError(std::string("--") + refinement + " sets the refinement, which --quality fast does not run "
                       "(use balanced or accurate)");
    }
  }
  if (const auto weights = args.get_optional("weights")) apply_weights(*weights, request.refine_options.weights);
  if (args.has("contact-lift")) {
    if (args.get("contact-lift") == "off") {
      request.refine_options.contact_lift.reset();
    } else {
      const double lift = args.get_double("contact-lift");
      if (!(lift >= 0) || !std::isfinite(lift)) throw UsageError("--contact-lift expects metres >= 0 or off");
      request.refine_options.contact_lift = lift;
    }
  }
  const std::string source_rest = args.get("source-rest");
  if (source_rest == "rest") {
    request.options.source_rest = retarget::SourceRest::rest;
  } else if (source_rest == "first-frame") {
    request.options.source_rest = retarget::SourceRest::first_frame;
  } else {
    throw UsageError("--source-rest expects rest or first-frame, got '" + source_rest + "'");
  }
  request.bvh_metres_per_unit = bvh_metres_per_unit(args);
  if (motion.empty()) return request;
  const bool bvh = std::filesystem::path(request.motion_path).extension() == ".bvh";
  if (request.model_path && bvh) throw UsageError("--model is for AMASS sequences; " + request.motion_path + " is a BVH file");
  if (args.has("betas") && bvh) throw UsageError("--betas is for AMASS sequences; " + request.motion_path + " is a BVH file");
  if (request.bvh_metres_per_unit && !bvh) {
    throw UsageError("--bvh-units is for BVH files; " + request.motion_path + " is not one");
  }
  return request;
}

void print_progress(const scene::ProgressEvent& event) {
  if (event.stage == "export") return;  // the commands print their own closing line of the frames
  if (event.stage == "warning") {
    std::fflush(stdout);
    std::fprintf(stderr, "warning: %s\n", event.message.c_str());
    std::fflush(stderr);
    return;
  }
  static const std::pair<const char*, const char*> kLabels[] = {
      {"load_motion", "motion"}, {"bvh_units", "units"}, {"load_character", "character"}, {"bone_maps", "maps"}};
  const char* label = event.stage.c_str();
  for (const auto& [stage, name] : kLabels) {
    if (event.stage == stage) label = name;
  }
  if (event.stage == "retarget" && event.actor) {
    print_result(event.actor->result.report);
  } else {
    std::printf("%-10s %s\n", label, event.message.c_str());
  }
  if (event.stage == "bone_maps" && event.actor) print_maps(*event.actor);
  std::fflush(stdout);
}

}  // namespace odyssey::cli
