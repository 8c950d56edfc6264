// Retargeting, quality `fast`, end to end: pair and align the rigs (rig.h), find the source's feet
// and contacts (contacts.h), transfer (transfer.h), measure (metrics.h), and report. A refinement
// stage (qualities `balanced`, `accurate`) starts from the RetargetResult: the transferred clip,
// the rig (segments, aligned rest, scale), the source's contacts and both rigs' feet, and
// replaces result.transfer.clip and result.report.result_metrics with its own.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "retarget/contacts.h"
#include "retarget/metrics.h"
#include "retarget/rig.h"
#include "retarget/transfer.h"
#include "skeleton/character.h"

namespace odyssey::retarget {

struct RetargetOptions {
  SourceRest source_rest = SourceRest::rest;
  AlignmentOptions alignment;
  ContactOptions contacts;
  MetricThresholds metric_thresholds;
};

struct RetargetTimings {  // seconds, wall clock
  double rig = 0;         // pairing, Ceres rest alignment, scale
  double contacts = 0;    // source feet and contacts, target feet
  double transfer = 0;
  double metrics = 0;
};

// What report.json holds (report_json); every name a person needs to check the result by hand.
struct RetargetReport {
  struct Pair {
    std::string canonical, source_joint, target_joint;
  };
  struct SegmentInfo {
    std::string bone;     // "left_hip->left_knee"
    std::string kind;     // "chain", "spine_continuation", "branch" or "degenerate" (rig.h)
    bool target_attached;
    double aligned_error_deg;
  };

  std::string quality = "fast";
  std::string source_name, target_name;
  int frames = 0;
  double fps = 0;
  RetargetOptions settings;
  std::string source_map_origin, target_map_origin;
  std::vector<Pair> pairs;                                          // the map used
  std::vector<std::pair<std::string, std::string>> target_followers;  // joint, canonical it moves with
  std::vector<std::string> source_only, target_only;  // canonical joints mapped on one rig only
  std::vector<std::string> unmapped_source, unmapped_target;  // rig joints with no role
  std::vector<SegmentInfo> segments;
  AlignmentSummary alignment;
  double source_height = 0, target_height = 0, scale = 1;
  double floor_offset = 0;
  // World -> levelled world of the source (contacts.h): its floor fitted from the stance heights
  // turned horizontal. Every comparison with the source (metrics included) is in the levelled world.
  Eigen::Quaterniond source_levelling = Eigen::Quaterniond::Identity();
  int planted_left = 0, planted_right = 0;  // source frames with the foot planted
  RetargetMetrics source_metrics, result_metrics;
  RetargetTimings timings;
};

struct RetargetResult {
  RetargetRig rig;
  Feet source_feet, target_feet;
  FootContacts contacts;
  TransferResult transfer;
  RetargetReport report;
};

// Throws std::invalid_argument (or io::InputError from the maps) with a message naming the
// problem: an unpaired pelvis, a clip on another skeleton, a non-finite value in a frame (naming
// the frame), a foot with no joints.
RetargetResult retarget_fast(const Clip& source, const BoneMap& source_map, const Character& target,
                             const BoneMap& target_map, const RetargetOptions& options = {},
                             const std::string& source_name = "source");

// The report as a JSON object, for the reports of actors, scenes and batches.
nlohmann::ordered_json report_json(const RetargetReport& report);

}  // namespace odyssey::retarget
