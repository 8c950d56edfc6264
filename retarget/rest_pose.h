// What a rig's rest pose is: T-pose or A-pose, told by how far the upper arms drop below
// horizontal at rest.
//
// The upper arm runs from the joint that plays the canonical shoulder (SMPL-X's `left_shoulder`,
// the upper-arm joint) to the one that plays the elbow (else the wrist), in the rig's rest world
// (Z up). Its drop is the angle between that direction and the horizontal plane, positive when
// the hand is lower than the shoulder: asin(-d_z / |d|). The kind comes from the mean drop of the
// arms that are mapped: below kTPoseMaxDropDeg a T-pose, from it up to kAPoseMaxDropDeg an A-pose
// (exporters' A-poses lower the arms by 30 to 50 degrees, T-poses by a few at most), lower than
// that unknown.
#pragma once

#include <optional>
#include <string>

#include "retarget/bone_map.h"
#include "skeleton/skeleton.h"

namespace odyssey::retarget {

inline constexpr double kTPoseMaxDropDeg = 20.0;
// Arms that hang lower than this (a quadruped's front legs, an I-pose) are neither T nor A.
inline constexpr double kAPoseMaxDropDeg = 70.0;

enum class RestPoseKind { t_pose, a_pose, unknown };
const char* rest_pose_kind_name(RestPoseKind kind);  // "T", "A", "unknown"

struct RestPoseInfo {
  RestPoseKind kind = RestPoseKind::unknown;
  std::optional<double> left_drop_deg, right_drop_deg;  // per arm, when its joints are mapped
  double drop_deg = 0.0;  // mean over the arms measured (0 when none)
  std::string reason;     // why the kind is unknown (no upper arm mapped, zero-length arm)
};

// Never throws for a valid skeleton and a map of its joints; an arm without a mapped shoulder,
// or with neither elbow nor wrist mapped, or of zero length, is not measured.
RestPoseInfo classify_rest_pose(const Skeleton& rig, const BoneMap& map);

}  // namespace odyssey::retarget
