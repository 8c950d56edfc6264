#include "retarget/rest_pose.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <vector>

#include "retarget/canonical.h"

namespace odyssey::retarget {

const char* rest_pose_kind_name(RestPoseKind kind) {
  switch (kind) {
    case RestPoseKind::t_pose: return "T";
    case RestPoseKind::a_pose: return "A";
    case RestPoseKind::unknown: return "unknown";
  }
  return "unknown";
}

namespace {

// Drop below horizontal of the arm from canonical `shoulder` to `elbow` (else `wrist`), degrees.
std::optional<double> arm_drop_deg(const std::vector<RigidTransform<double>>& world, const BoneMap& map, int shoulder,
                                   int elbow, int wrist) {
  if (!map.mapped(shoulder)) return std::nullopt;
  const int end = map.mapped(elbow) ? map.joints[elbow] : map.mapped(wrist) ? map.joints[wrist] : -1;
  if (end < 0) return std::nullopt;
  const Eigen::Vector3d d = world[end].translation - world[map.joints[shoulder]].translation;
  const double length = d.norm();
  if (!(length > 1e-9)) return std::nullopt;
  return std::asin(std::clamp(-d.z() / length, -1.0, 1.0)) * 180.0 / std::numbers::pi;
}

}  // namespace

RestPoseInfo classify_rest_pose(const Skeleton& rig, const BoneMap& map) {
  const std::vector<RigidTransform<double>> world = rig.rest_world();
  RestPoseInfo info;
  info.left_drop_deg =
      arm_drop_deg(world, map, canonical::left_shoulder, canonical::left_elbow, canonical::left_wrist);
  info.right_drop_deg =
      arm_drop_deg(world, map, canonical::right_shoulder, canonical::right_elbow, canonical::right_wrist);
  int measured = 0;
  double total = 0.0;
  for (const std::optional<double>& drop : {info.left_drop_deg, info.right_drop_deg}) {
    if (!drop) continue;
    total += *drop;
    ++measured;
  }
  if (measured == 0) {
    info.reason = "no upper arm mapped (a shoulder with its elbow or wrist)";
    return info;
  }
  info.drop_deg = total / measured;
  if (info.drop_deg > kAPoseMaxDropDeg) {
    char text[96];
    std::snprintf(text, sizeof text, "upper arms %.1f deg below horizontal: neither T nor A", info.drop_deg);
    info.reason = text;
    return info;
  }
  info.kind = info.drop_deg < kTPoseMaxDropDeg ? RestPoseKind::t_pose : RestPoseKind::a_pose;
  return info;
}

}  // namespace odyssey::retarget
