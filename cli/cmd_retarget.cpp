// odyssey retarget: a motion (BVH, or an AMASS-style SMPL-X / SMPL-H sequence) onto a rigged
// glTF character, written as an animated GLB with an optional JSON report.
//
// Steps: load the motion as a Clip and resample it to --fps; load the character; find both bone
// maps (preset or detection from names, a user map over it) and require humanoids; keep only the
// canonical joints of --parts on both maps; retarget (quality fast), refine for balanced and
// accurate; then write. Nothing is written before every step has succeeded, and the outputs are
// staged under temporary names beside their destinations and renamed together at the end, so a
// failure at any point leaves neither the GLB nor the report behind.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "cli/args.h"
#include "cli/commands.h"
#include "cli/motion_file.h"
#include "mocap_io/amass.h"
#include "mocap_io/body_model_file.h"
#include "mocap_io/bvh.h"
#include "mocap_io/gltf_character.h"
#include "mocap_io/gltf_export.h"
#include "mocap_io/input_error.h"
#include "retarget/bone_map.h"
#include "retarget/parts.h"
#include "retarget/refine.h"
#include "retarget/retarget.h"
#include "skeleton/body_clip.h"
#include "skeleton/pose_layout.h"
#include "skeleton/synthetic_body.h"

namespace odyssey::cli {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

// An output written under a temporary name beside its destination (same folder, so the rename
// cannot cross file systems) and renamed onto it by commit(); removed when never committed.
class StagedFile {
 public:
  explicit StagedFile(std::string target)
      : target_(std::move(target)), temp_(target_ + ".partial-" + std::to_string(::getpid())) {}
  ~StagedFile() {
    std::error_code ignored;
    if (!committed_) fs::remove(temp_, ignored);
  }
  StagedFile(const StagedFile&) = delete;
  StagedFile& operator=(const StagedFile&) = delete;

  const std::string& temp() const { return temp_; }

  void write_text(const std::string& text) const {
    std::ofstream out(temp_, std::ios::binary);
    out << text;
    out.close();
    if (!out) throw io::InputError(target_, "cannot write " + temp_);
  }

  void commit() {
    std::error_code error;
    fs::rename(temp_, target_, error);
    if (error) throw io::InputError(target_, "cannot rename " + temp_ + " into place: " + error.message());
    committed_ = true;
  }

 private:
  std::string target_, temp_;
  bool committed_ = false;
};

struct Motion {
  Clip clip;
  std::string description;  // "BVH, 31 joints, 344 frames at 120 fps"
  std::string format;       // "bvh" or "amass"
  std::string body_model;   // AMASS: the model file, or the synthetic body's description
};

Motion load_motion(const Args& args, const std::string& path) {
  Motion motion;
  const MotionFileKind kind = detect_motion_file(path);
  if (kind == MotionFileKind::Bvh) {
    if (args.has("model")) throw UsageError("--model is for AMASS sequences; " + path + " is a BVH file");
    motion.clip = io::load_bvh(path, io::BvhOptions{bvh_metres_per_unit(args)});
    motion.format = "bvh";
    motion.description = "BVH";
  } else if (kind == MotionFileKind::Amass) {
    if (args.has("bvh-units")) throw UsageError("--bvh-units is for BVH files; " + path + " is an AMASS sequence");
    BodySequence sequence = io::load_amass_file(path).sequence;
    if (sequence.frame_count() < 1) throw io::InputError(path, "the sequence has no frames");
    BodyModel model;
    if (const auto model_path = args.get_optional("model")) {
      model = io::load_body_model(*model_path);
      motion.body_model = *model_path;
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

int run_retarget(const std::vector<std::string>& arguments) {
  Args args("retarget",
            "Retarget a motion onto a rigged glTF/GLB character and write an animated GLB: the character's\n"
            "meshes, skins and materials with one animation (a rotation channel per joint, translation on\n"
            "the root and on joints placed by position, LINEAR, continuous quaternion signs).\n"
            "\n"
            "The motion is a BVH file (source bone map: the CMU preset when it fits, else detected from\n"
            "joint names) or an AMASS-style SMPL-X / SMPL-H / SMPL npz sequence, posed on the body model\n"
            "given by --model, or, without --model, on the synthetic SMPL-X body (odyssey make-body --seed 0).\n"
            "The target bone map is a preset that fits the character or detected from its joint names;\n"
            "--map and --source-map take JSON maps ({\"joints\": {\"left_knee\": \"Knee.L\", ...}}, null\n"
            "unmaps) applied over what was found. A character that is not a humanoid (a four-legged Fox, a\n"
            "skinned cylinder) is an error naming the file and the joints missing, exit code 1.\n"
            "\n"
            "The height scale makes the motion's skeleton as tall as the character's (report: scale), so a\n"
            "BVH length unit changes only where foot contacts are found (5 cm above the fitted floor, slower\n"
            "than 0.5 m/s, at the performer's size): give --bvh-units cmu for the CMU conversions.\n"
            "\n"
            "Prints the map used, every unmapped joint, the height scale, metrics and timings. On any error\n"
            "nothing is written: the GLB and the report are renamed into place only when both are complete.");
  args.option("motion", "FILE", "BVH file or AMASS-style npz sequence (required)")
      .option("character", "FILE", "rigged humanoid character, .glb or .gltf (required)")
      .option("out", "FILE", "output animated GLB (required)")
      .option("quality", "Q",
              "fast (rotation transfer, no solver), balanced (Ceres refinement per frame: bone directions, "
              "end effectors, foot contacts) or accurate (refinement over temporal windows, smoother)",
              "fast")
      .option("parts", "PARTS",
              "what is solved: body (fingers and face keep their rest pose), body+hands, or all (also jaw and "
              "eyes where both maps have them)",
              "body")
      .option("threads", "N", "threads for the refinement's independent windows (balanced, accurate)", "1")
      .option("fps", "FPS", "resample the motion to this frame rate before retargeting", "30")
      .option("map", "FILE", "JSON bone map for the character, applied over the preset or detected map (default: none)")
      .option("source-map", "FILE", "JSON bone map for the motion's skeleton, applied likewise (default: none)")
      .option("model", "FILE",
              "SMPL-X / SMPL-H / SMPL body model npz for an AMASS motion (default: the synthetic SMPL-X body, seed 0)")
      .option("source-rest", "POSE",
              "source pose aligned onto the character's rest pose: rest (the skeleton's rest pose) or first-frame "
              "(the clip's first frame; CMU BVH files open with a T-pose there)",
              "rest")
      .option("report", "FILE",
              "write a JSON report: inputs, settings, the map used, unmapped joints, scale, alignment, contacts, "
              "metrics of the source and the result, timings (default: none)");
  add_bvh_units_option(args);
  if (!args.parse(arguments)) return 0;

  const auto total_start = Clock::now();
  const std::string motion_path = args.get("motion");
  const std::string character_path = args.get("character");
  const std::string out_path = args.get("out");
  const std::optional<std::string> report_path = args.get_optional("report");
  const std::optional<std::string> map_path = args.get_optional("map");
  const std::optional<std::string> source_map_path = args.get_optional("source-map");
  const auto quality = retarget::parse_quality(args.get("quality"));
  if (!quality) throw UsageError("--quality expects fast, balanced or accurate, got '" + args.get("quality") + "'");
  const auto parts = retarget::parse_parts(args.get("parts"));
  if (!parts) throw UsageError("--parts expects body, body+hands or all, got '" + args.get("parts") + "'");
  const double fps = args.get_double("fps");
  if (!(fps > 0)) throw UsageError("--fps must be positive");
  retarget::RefineOptions refine_options = retarget::default_refine_options(*quality);
  const long long threads = args.get_int("threads");
  if (threads < 1 || threads > 1024) throw UsageError("--threads expects 1 to 1024, got " + std::to_string(threads));
  refine_options.threads = static_cast<int>(threads);
  retarget::RetargetOptions options;
  const std::string source_rest = args.get("source-rest");
  if (source_rest == "rest") {
    options.source_rest = retarget::SourceRest::rest;
  } else if (source_rest == "first-frame") {
    options.source_rest = retarget::SourceRest::first_frame;
  } else {
    throw UsageError("--source-rest expects rest or first-frame, got '" + source_rest + "'");
  }
  if (report_path && fs::absolute(*report_path) == fs::absolute(out_path)) {
    throw UsageError("--report and --out name the same file");
  }

  auto start = Clock::now();
  Motion motion = load_motion(args, motion_path);
  const double source_fps = motion.clip.fps;
  motion.clip = motion.clip.resampled(fps);
  const Clip& source = motion.clip;
  const double load_motion_seconds = seconds_since(start);
  std::printf("motion     %s: %s, resampled to %d frames at %.6g fps\n", motion_path.c_str(), motion.description.c_str(),
              source.frame_count(), source.fps);
  // Progress goes out before each step that can fail, so that in a batch log the error line
  // (stderr, printed by main) follows the step it belongs to.
  std::fflush(stdout);

  start = Clock::now();
  const Character character = io::load_character(character_path);
  const double load_character_seconds = seconds_since(start);
  std::printf("character  %s: %d joints, %zu mesh%s\n", character_path.c_str(), character.skeleton.joint_count(),
              character.meshes.size(), character.meshes.size() == 1 ? "" : "es");
  std::fflush(stdout);

  start = Clock::now();
  const retarget::BoneMap full_source_map =
      retarget::humanoid_bone_map(source.skeleton, motion_path, source_map_path.value_or(""));
  const retarget::BoneMap full_target_map =
      retarget::humanoid_bone_map(character.skeleton, character_path, map_path.value_or(""));
  const retarget::BoneMap source_map = retarget::restrict_bone_map(full_source_map, *parts);
  const retarget::BoneMap target_map = retarget::restrict_bone_map(full_target_map, *parts);
  const double maps_seconds = seconds_since(start);
  const std::vector<int> source_left_out = left_out_by_parts(source.skeleton, full_source_map, source_map);
  const std::vector<int> target_left_out = left_out_by_parts(character.skeleton, full_target_map, target_map);
  print_maps(source.skeleton, full_source_map, source_map, source_left_out, character.skeleton, full_target_map, target_map,
             target_left_out, *parts);
  std::fflush(stdout);

  start = Clock::now();
  retarget::RetargetResult result = retarget::retarget_fast(source, source_map, character, target_map, options, motion_path);
  const double fast_seconds = seconds_since(start);
  std::optional<retarget::RefineSummary> refined;
  if (*quality != retarget::Quality::fast) refined = retarget::refine(result, source, refine_options);
  const retarget::RetargetReport& report = result.report;
  std::printf("scale      %.6g (target %.4f m / source %.4f m, paired joints' height span), floor offset %.4f m\n",
              report.scale, report.target_height, report.source_height, report.floor_offset);
  std::printf("alignment  mean residual %.4f deg, max %.4f deg over %d terms\n", report.alignment.mean_residual_deg,
              report.alignment.max_residual_deg, report.alignment.fitted_terms);
  std::printf("contacts   left foot planted in %d frames, right in %d, of %d\n", report.planted_left, report.planted_right,
              report.frames);
  print_metrics(report);
  std::fflush(stdout);

  start = Clock::now();
  StagedFile glb(out_path);
  io::GlbExportOptions export_options;
  export_options.animation_name = fs::path(motion_path).stem().string();
  io::write_animated_glb(character_path, character, result.transfer.clip, glb.temp(), export_options);
  const double write_seconds = seconds_since(start);
  const double total_seconds = seconds_since(total_start);

  // Both outputs are complete under their temporary names before either is renamed into place.
  std::optional<StagedFile> report_file;
  if (report_path) {
    // report_json holds what the retargeting knows; the command adds what only it knows (the
    // files, the command-line settings, the parts left out, its own timings).
    nlohmann::ordered_json json = nlohmann::ordered_json::parse(retarget::report_json(report));
    json["inputs"] = {{"motion", motion_path},
                      {"motion_format", motion.format},
                      {"motion_fps", source_fps},
                      {"character", character_path},
                      {"output", out_path}};
    if (motion.format == "bvh") json["inputs"]["bvh_metres_per_unit"] = bvh_metres_per_unit(args);
    if (motion.format == "amass") json["inputs"]["body_model"] = motion.body_model;
    json["settings"]["parts"] = retarget::parts_name(*parts);
    json["settings"]["fps"] = fps;
    json["settings"]["map_file"] = map_path ? nlohmann::ordered_json(*map_path) : nlohmann::ordered_json();
    json["settings"]["source_map_file"] = source_map_path ? nlohmann::ordered_json(*source_map_path) : nlohmann::ordered_json();
    if (refined) {
      // The weights are refine.h's defaults for the quality (default_refine_options); the
      // command chooses only the threads.
      json["settings"]["refine_threads"] = refine_options.threads;
      json["refine"] = {{"seconds", refined->seconds},         {"solve_seconds", refined->solve_seconds},
                        {"frames", refined->frames},           {"windows", refined->windows},
                        {"iterations", refined->iterations},   {"unknown_joints", refined->unknown_joints},
                        {"stride_factor", refined->stride}};
    }
    json["left_out_by_parts"] = {{"source", names_of(source.skeleton, source_left_out)},
                                 {"target", names_of(character.skeleton, target_left_out)}};
    json["timings_s"]["command"] = {{"load_motion", load_motion_seconds}, {"load_character", load_character_seconds},
                                    {"bone_maps", maps_seconds},          {"retarget_fast", fast_seconds},
                                    {"refine", refined ? refined->seconds : 0.0}, {"write_glb", write_seconds},
                                    {"total", total_seconds}};
    report_file.emplace(*report_path);
    report_file->write_text(json.dump(2) + "\n");
    report_file->commit();
  }
  try {
    glb.commit();
  } catch (const io::InputError&) {
    std::error_code ignored;
    if (report_path) fs::remove(*report_path, ignored);
    throw;
  }

  const retarget::RetargetTimings& timings = report.timings;
  std::printf("timings    load motion %.3f s, character %.3f s, maps %.3f s, rig %.3f s, contacts %.3f s, transfer %.3f s "
              "(%.0f frames/s), metrics %.3f s",
              load_motion_seconds, load_character_seconds, maps_seconds, timings.rig, timings.contacts, timings.transfer,
              timings.transfer > 0 ? report.frames / timings.transfer : 0.0, timings.metrics);
  if (refined) {
    std::printf(", refine %.3f s (solvers %.3f s, %.0f frames/s, %d windows, %ld iterations, threads: %d)", refined->seconds,
                refined->solve_seconds, refined->seconds > 0 ? report.frames / refined->seconds : 0.0, refined->windows,
                refined->iterations, refine_options.threads);
  }
  std::printf(", write %.3f s; total %.3f s\n", write_seconds, total_seconds);
  std::printf("wrote      %s (%d frames at %.6g fps, quality %s)%s%s\n", out_path.c_str(), result.transfer.clip.frame_count(),
              result.transfer.clip.fps, retarget::quality_name(*quality), report_path ? ", " : "",
              report_path ? report_path->c_str() : "");
  return 0;
}

}  // namespace odyssey::cli
