#include "retarget/retarget.h"

#include <algorithm>
#include <chrono>
#include <numbers>
#include <nlohmann/json.hpp>

namespace odyssey::retarget {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

nlohmann::ordered_json direction_json(const DirectionError& error) {
  return {{"mean", error.mean_deg}, {"max", error.max_deg}, {"samples", error.samples}};
}

nlohmann::ordered_json metrics_json(const RetargetMetrics& metrics, bool comparative) {
  nlohmann::ordered_json json;
  if (comparative) {
    json["bone_direction_deg"] = direction_json(metrics.bone_direction);
    nlohmann::ordered_json limbs = nlohmann::ordered_json::object();
    for (const auto& limb : metrics.limbs) limbs[limb.name] = direction_json(limb.error);
    json["limb_direction_deg"] = limbs;
    nlohmann::ordered_json bones = nlohmann::ordered_json::object();
    for (const auto& bone : metrics.bones) bones[bone.name] = direction_json(bone.error);
    json["bone_direction_deg_per_bone"] = bones;
    json["branch_direction_deg"] = direction_json(metrics.branch_direction);
    json["foot_direction_deg"] = direction_json(metrics.foot_direction);
    json["hip_line_deg"] = direction_json(metrics.hip_line);
    json["torso_deg"] = direction_json(metrics.torso);
    json["pelvis_to_neck_deg"] = direction_json(metrics.pelvis_to_neck);
    json["spine_bend_deg"] = direction_json(metrics.spine_bend);
    json["end_effector_m"] = {{"mean", metrics.end_effector_mean_m}, {"max", metrics.end_effector_max_m}};
  }
  json["foot_skate_ratio"] = metrics.foot_skate_ratio;
  json["foot_skate_ratio_gmd"] = metrics.foot_skate_ratio_gmd;
  json["penetration_cm"] = metrics.penetration_cm;
  json["floating_cm"] = metrics.floating_cm;
  json["foot_tilt_deg"] = metrics.foot_tilt_deg;
  json["jitter_m_per_s2"] = metrics.jitter;
  return json;
}

}  // namespace

RetargetResult retarget_fast(const Clip& source, const BoneMap& source_map, const Character& target,
                             const BoneMap& target_map, const RetargetOptions& options, const std::string& source_name) {
  RetargetResult result;
  RetargetReport& report = result.report;

  try {
    source.validate();
  } catch (const std::invalid_argument& error) {
    throw std::invalid_argument("source clip '" + source_name + "': " + error.what());
  }
  auto start = Clock::now();
  result.rig = build_retarget_rig(source, source_map, target.skeleton, target_map, options.source_rest, options.alignment);
  report.timings.rig = seconds_since(start);
  const RetargetRig& rig = result.rig;

  start = Clock::now();
  result.source_feet = source_feet(source, source_map, options.contacts);
  result.target_feet = target_feet(target, target_map);
  result.contacts = detect_contacts(source, result.source_feet, options.contacts);
  report.timings.contacts = seconds_since(start);

  start = Clock::now();
  result.transfer = FastTransfer(rig, result.target_feet).run(source, result.source_feet, result.contacts);
  report.timings.transfer = seconds_since(start);

  start = Clock::now();
  report.source_metrics = source_metrics(rig, source, result.source_feet, result.contacts, options.metric_thresholds);
  report.result_metrics =
      result_metrics(rig, source, result.source_feet, result.transfer.clip, result.target_feet, result.contacts,
                     options.metric_thresholds);
  report.timings.metrics = seconds_since(start);

  report.source_name = source_name;
  report.target_name = target.name;
  report.frames = source.frame_count();
  report.fps = source.fps;
  report.settings = options;
  report.source_map_origin = source_map.origin;
  report.target_map_origin = target_map.origin;
  for (int c : rig.paired) {
    report.pairs.push_back({std::string(canonical_name(c)), rig.source.name(rig.source_joint(c)), rig.target.name(rig.target_joint(c))});
  }
  for (int c = 0; c < kCanonicalJointCount; ++c) {
    if (source_map.mapped(c) && !target_map.mapped(c)) report.source_only.emplace_back(canonical_name(c));
    if (!source_map.mapped(c) && target_map.mapped(c)) report.target_only.emplace_back(canonical_name(c));
  }
  for (const BoneMap::Follower& follower : target_map.followers) {
    report.target_followers.push_back({rig.target.name(follower.joint), std::string(canonical_name(follower.canonical))});
  }
  for (int j : unmapped_joints(rig.source, source_map)) report.unmapped_source.push_back(rig.source.name(j));
  for (int j : unmapped_joints(rig.target, target_map)) report.unmapped_target.push_back(rig.target.name(j));
  for (const Segment& segment : rig.segments) {
    report.segments.push_back({std::string(canonical_name(segment.canonical_start)) + "->" + std::string(canonical_name(segment.canonical_end)),
                               segment.degenerate ? "degenerate" : (segment.spine_continuation ? "spine_continuation" : (segment.branch ? "branch" : "chain")), segment.target_attached,
                               segment.aligned_error_deg});
  }
  report.alignment = rig.alignment;
  report.source_height = rig.source_height;
  report.target_height = rig.target_height;
  report.scale = rig.scale;
  report.floor_offset = result.transfer.floor_offset;
  report.source_levelling = result.source_feet.levelling;
  report.planted_left = static_cast<int>(std::count(result.contacts.planted[0].begin(), result.contacts.planted[0].end(), 1));
  report.planted_right = static_cast<int>(std::count(result.contacts.planted[1].begin(), result.contacts.planted[1].end(), 1));
  return result;
}

nlohmann::ordered_json report_json(const RetargetReport& report) {
  nlohmann::ordered_json json;
  json["quality"] = report.quality;
  const Eigen::Quaterniond& level = report.source_levelling;
  json["source"] = {{"name", report.source_name}, {"frames", report.frames}, {"fps", report.fps},
                    {"map", report.source_map_origin}, {"height_m", report.source_height},
                    {"levelling", {{"tilt_deg", level.angularDistance(Eigen::Quaterniond::Identity()) * 180 / std::numbers::pi},
                                   {"quaternion_wxyz", {level.w(), level.x(), level.y(), level.z()}}}}};
  json["target"] = {{"name", report.target_name}, {"map", report.target_map_origin}, {"height_m", report.target_height}};
  json["scale"] = report.scale;
  json["floor_offset_m"] = report.floor_offset;
  const RetargetOptions& settings = report.settings;
  json["settings"] = {{"source_rest", source_rest_name(settings.source_rest)},
                      {"alignment_regularisation", settings.alignment.regularisation},
                      {"alignment_max_iterations", settings.alignment.max_iterations},
                      {"contact_max_height_m", settings.contacts.max_height},
                      {"contact_max_speed_m_per_s", settings.contacts.max_speed},
                      {"metric_contact_height_m", settings.metric_thresholds.contact_height},
                      {"metric_skate_speed_m_per_s", settings.metric_thresholds.skate_speed}};
  nlohmann::ordered_json pairs = nlohmann::ordered_json::array();
  for (const auto& pair : report.pairs) pairs.push_back({{"canonical", pair.canonical}, {"source", pair.source_joint}, {"target", pair.target_joint}});
  json["map"] = pairs;
  nlohmann::ordered_json followers = nlohmann::ordered_json::array();
  for (const auto& [joint, canonical] : report.target_followers) followers.push_back({{"joint", joint}, {"moves_with", canonical}});
  json["target_followers"] = followers;
  json["mapped_on_one_side_only"] = {{"source", report.source_only}, {"target", report.target_only}};
  json["unmapped_joints"] = {{"source", report.unmapped_source}, {"target", report.unmapped_target}};
  const AlignmentSummary& alignment = report.alignment;
  json["alignment"] = {{"mean_residual_deg", alignment.mean_residual_deg}, {"max_residual_deg", alignment.max_residual_deg},
                       {"fitted_terms", alignment.fitted_terms}, {"unknowns", alignment.unknowns},
                       {"iterations", alignment.iterations}, {"seconds", alignment.seconds}, {"solver", alignment.solver_report}};
  nlohmann::ordered_json segments = nlohmann::ordered_json::array();
  for (const auto& segment : report.segments) {
    segments.push_back({{"bone", segment.bone}, {"kind", segment.kind}, {"target_attached", segment.target_attached},
                        {"aligned_error_deg", segment.aligned_error_deg}});
  }
  json["segments"] = segments;
  json["contacts"] = {{"planted_frames_left", report.planted_left}, {"planted_frames_right", report.planted_right}};
  json["metrics"] = {{"source", metrics_json(report.source_metrics, false)}, {"result", metrics_json(report.result_metrics, true)}};
  json["timings_s"] = {{"rig", report.timings.rig}, {"contacts", report.timings.contacts},
                       {"transfer", report.timings.transfer}, {"metrics", report.timings.metrics}};
  return json;
}

}  // namespace odyssey::retarget
