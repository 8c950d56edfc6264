#include "retarget/metrics.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "retarget/geometry.h"

namespace odyssey::retarget {

namespace {

struct Accumulator {
  double sum = 0, max = 0;
  long samples = 0;
  void add(double value) {
    sum += value;
    max = std::max(max, value);
    ++samples;
  }
  double mean() const { return samples ? sum / samples : 0.0; }
  DirectionError direction() const { return {mean(), max, samples}; }
};

// One frame of a clip in its levelled world (contacts.h), and its joints' positions scaled, in
// buffers reused from frame to frame.
struct FramePose {
  KinematicData<double> kinematics;
  std::vector<Eigen::Vector3d> position;

  FramePose(const Clip& clip, const Eigen::Quaterniond& levelling)
      : kinematics(clip.skeleton.kinematics()), position(clip.joint_count()) {
    kinematics.base.rotation = levelling.toRotationMatrix();
  }
  void pose(const Clip& clip, int frame, double scale) {
    clip.world_pose(frame, kinematics);
    for (std::size_t j = 0; j < position.size(); ++j) position[j] = scale * kinematics.world[j].translation;
  }
  const Eigen::Matrix3d& rotation(int joint) const { return kinematics.world[joint].rotation; }
};

// Skate, penetration/floating and jitter of one clip: streams the frames keeping the two before.
// The skate ratio is counted twice, against `scaled` thresholds (foot_skate_ratio) and against
// `gmd` thresholds (foot_skate_ratio_gmd), both in the units of the clip as measured (times
// `scale`).
void motion_metrics(const Clip& clip, double scale, const Feet& feet, const FootContacts& contacts,
                    const std::vector<int>& jitter_joints, const MetricThresholds& scaled, const MetricThresholds& gmd,
                    RetargetMetrics& metrics) {
  const int frames = clip.frame_count();
  FramePose before2(clip, feet.levelling), before(clip, feet.levelling), now(clip, feet.levelling);
  long skating = 0, skating_gmd = 0, skate_samples = 0, contact_samples = 0, tilt_samples = 0;
  double depth_sum = 0, height_sum = 0, tilt_sum = 0, jitter_sum = 0;
  long jitter_samples = 0;
  Feet scaled_feet = feet;
  for (Foot& foot : scaled_feet.sides) {
    for (double& height : foot.ground_heights) height *= scale;
    foot.toe_ground_height *= scale;
  }
  // Skate reads foot joints (ARCHITECTURE.md): a foot's toe stands in only for a missing ball of
  // the foot.
  Feet skate_feet = scaled_feet;
  for (Foot& foot : skate_feet.sides) foot.has_toe = foot.has_toe && foot.joints.size() == 1;
  // joints[0]'s world rotation times the scale, which carries a toe offset (contacts.h) to where
  // the scaled clip has it.
  const auto toe_frame = [scale](const Foot& foot, const FramePose& pose) -> Eigen::Matrix3d {
    return scale * pose.rotation(foot.joints[0]);
  };
  for (int f = 0; f < frames; ++f) {
    now.pose(clip, f, scale);
    for (int side = 0; side < 2; ++side) {
      const Foot& foot = scaled_feet[side];
      const Eigen::Matrix3d now_toe = toe_frame(foot, now);
      const double clearance = foot_clearance(foot, now.position, now_toe);
      if (contacts.planted[side][f]) {
        depth_sum += std::max(0.0, -clearance);
        height_sum += std::max(0.0, clearance);
        ++contact_samples;
        if (foot.point_count() >= 2) {
          const int front = foot.point_count() - 1;
          const Eigen::Vector3d chord = foot.point(front, now.position, now_toe) - now.position[foot.joints[0]];
          const double length = chord.norm();
          if (length > 0) {
            const auto pitch = [length](double rise) { return std::asin(std::clamp(rise / length, -1.0, 1.0)); };
            tilt_sum += std::abs(pitch(chord.z()) - pitch(foot.point_ground_height(front) - foot.ground_heights[0]));
            ++tilt_samples;
          }
        }
      }
      if (f > 0) {
        const Foot& joints = skate_feet[side];
        const Eigen::Matrix3d before_toe = toe_frame(joints, before);
        const int lowest = lowest_foot_point(joints, before.position, before_toe);
        const Eigen::Vector3d lowest_before = joints.point(lowest, before.position, before_toe);
        const double clearance_before = lowest_before.z() - joints.point_ground_height(lowest);
        const double clearance_now = foot_clearance(joints, now.position, now_toe);
        const Eigen::Vector3d step = joints.point(lowest, now.position, now_toe) - lowest_before;
        const double speed = step.head<2>().norm() * clip.fps;
        const auto skates = [&](const MetricThresholds& t) {
          return clearance_before < t.contact_height && clearance_now < t.contact_height && speed > t.skate_speed;
        };
        if (skates(scaled)) ++skating;
        if (skates(gmd)) ++skating_gmd;
        ++skate_samples;
      }
    }
    if (f > 1) {
      for (int j : jitter_joints) {
        jitter_sum += (now.position[j] - 2.0 * before.position[j] + before2.position[j]).norm() * clip.fps * clip.fps;
        ++jitter_samples;
      }
    }
    std::swap(before2, before);
    std::swap(before, now);
  }
  metrics.foot_skate_ratio = skate_samples ? static_cast<double>(skating) / skate_samples : 0.0;
  metrics.foot_skate_ratio_gmd = skate_samples ? static_cast<double>(skating_gmd) / skate_samples : 0.0;
  metrics.penetration_cm = contact_samples ? 100.0 * depth_sum / contact_samples : 0.0;
  metrics.floating_cm = contact_samples ? 100.0 * height_sum / contact_samples : 0.0;
  metrics.foot_tilt_deg = tilt_samples ? tilt_sum / tilt_samples * 180.0 / std::numbers::pi : 0.0;
  metrics.jitter = jitter_samples ? jitter_sum / jitter_samples : 0.0;
}

std::vector<int> paired_joints(const RetargetRig& rig, bool source) {
  std::vector<int> joints;
  for (int c : rig.paired) joints.push_back(source ? rig.source_joint(c) : rig.target_joint(c));
  return joints;
}

void check_frames(const Clip& clip, int joints, int frames, const char* what) {
  if (clip.joint_count() != joints) {
    throw std::invalid_argument(std::string(what) + " clip has " + std::to_string(clip.joint_count()) +
                                " joints, the rig's skeleton " + std::to_string(joints));
  }
  if (frames >= 0 && clip.frame_count() != frames) {
    throw std::invalid_argument(std::string(what) + " clip has " + std::to_string(clip.frame_count()) +
                                " frames, expected " + std::to_string(frames));
  }
}

MetricThresholds scaled_by(const MetricThresholds& thresholds, double scale) {
  return {thresholds.contact_height * scale, thresholds.skate_speed * scale};
}

}  // namespace

RetargetMetrics source_metrics(const RetargetRig& rig, const Clip& source, const Feet& feet, const FootContacts& contacts,
                               const MetricThresholds& thresholds) {
  check_frames(source, rig.source.joint_count(), contacts.frame_count(), "source");
  RetargetMetrics metrics;
  // Scaled by s, the thresholds at the source's own size: both figures are the GMD one.
  const MetricThresholds at_own_size = scaled_by(thresholds, rig.scale);
  motion_metrics(source, rig.scale, feet, contacts, paired_joints(rig, true), at_own_size, at_own_size, metrics);
  return metrics;
}

RetargetMetrics result_metrics(const RetargetRig& rig, const Clip& source, const Feet& source_feet, const Clip& result,
                               const Feet& target_feet, const FootContacts& contacts, const MetricThresholds& thresholds) {
  check_frames(source, rig.source.joint_count(), contacts.frame_count(), "source");
  check_frames(result, rig.target.joint_count(), contacts.frame_count(), "result");
  RetargetMetrics metrics;
  motion_metrics(result, 1.0, target_feet, contacts, paired_joints(rig, false), scaled_by(thresholds, rig.scale),
                 thresholds, metrics);

  // Direction and end-effector errors, frame by frame.
  struct Bone {
    const Segment* segment;
    Accumulator error;
  };
  std::vector<Bone> bones;
  for (const Segment& segment : rig.segments) {
    if (!segment.degenerate) bones.push_back({&segment, {}});
  }
  std::vector<int> effectors;
  for (int c : {canonical::head, canonical::left_wrist, canonical::right_wrist, canonical::left_ankle, canonical::right_ankle}) {
    if (rig.source_map.mapped(c) && rig.target_map.mapped(c)) effectors.push_back(c);
  }
  const int source_pelvis = rig.source_joint(canonical::pelvis);
  const int target_pelvis = rig.target_joint(canonical::pelvis);
  const auto paired = [&rig](int c) { return rig.source_map.mapped(c) && rig.target_map.mapped(c); };
  const bool hips = paired(canonical::left_hip) && paired(canonical::right_hip);
  // Lines from a paired joint to the neck (above): the torso from spine1, and from the pelvis.
  struct Line {
    int source_from = -1, source_to = -1, target_from = -1, target_to = -1;
    Accumulator error;
  };
  const int top = paired(canonical::neck) ? canonical::neck : canonical::head;  // a rig without a neck: its head
  const auto line_to_neck = [&](int from) {
    Line line;
    if (paired(from) && paired(top)) {
      line = {rig.source_joint(from), rig.source_joint(top), rig.target_joint(from), rig.target_joint(top), {}};
    }
    return line;
  };
  Line torso = line_to_neck(canonical::spine1), pelvis_to_neck = line_to_neck(canonical::pelvis);
  const std::vector<const Segment*> spine = spine_chain(rig);
  Accumulator spine_bend;
  FramePose source_pose(source, source_feet.levelling), target_pose(result, target_feet.levelling);
  Accumulator effector_error, hip_line;
  for (int f = 0; f < result.frame_count(); ++f) {
    source_pose.pose(source, f, rig.scale);
    target_pose.pose(result, f, 1.0);
    for (Bone& bone : bones) {
      const Segment& segment = *bone.segment;
      const Eigen::Vector3d source_direction = source_pose.position[segment.source_end] - source_pose.position[segment.source_start];
      const Eigen::Vector3d target_direction = target_pose.position[segment.target_end] - target_pose.position[segment.target_start];
      bone.error.add(angle_deg(source_direction, target_direction));
    }
    if (hips) {
      const auto line = [](const FramePose& pose, int left, int right) -> Eigen::Vector3d {
        return pose.position[left] - pose.position[right];
      };
      hip_line.add(angle_deg(line(source_pose, rig.source_joint(canonical::left_hip), rig.source_joint(canonical::right_hip)),
                             line(target_pose, rig.target_joint(canonical::left_hip), rig.target_joint(canonical::right_hip))));
    }
    if (!spine.empty()) {
      const Segment &first = *spine.front(), &last = *spine.back();
      const auto bend = [](const FramePose& pose, int a, int b, int c, int d) {
        return angle_deg(pose.position[b] - pose.position[a], pose.position[d] - pose.position[c]);
      };
      spine_bend.add(std::abs(bend(target_pose, first.target_start, first.target_end, last.target_start, last.target_end) -
                              bend(source_pose, first.source_start, first.source_end, last.source_start, last.source_end)));
    }
    for (Line* line : {&torso, &pelvis_to_neck}) {
      if (line->source_from < 0) continue;
      line->error.add(angle_deg(source_pose.position[line->source_to] - source_pose.position[line->source_from],
                                target_pose.position[line->target_to] - target_pose.position[line->target_from]));
    }
    for (int c : effectors) {
      const Eigen::Vector3d target_relative = target_pose.position[rig.target_joint(c)] - target_pose.position[target_pelvis];
      const Eigen::Vector3d source_relative = source_pose.position[rig.source_joint(c)] - source_pose.position[source_pelvis];
      effector_error.add((target_relative - source_relative).norm());
    }
  }
  metrics.hip_line = hip_line.direction();
  metrics.torso = torso.error.direction();
  metrics.pelvis_to_neck = pelvis_to_neck.error.direction();
  metrics.spine_bend = spine_bend.direction();
  metrics.end_effector_mean_m = effector_error.mean();
  metrics.end_effector_max_m = effector_error.max;

  Accumulator chain, branch, feet;
  std::vector<std::pair<std::string, Accumulator>> limbs;
  for (const Bone& bone : bones) {
    const Segment& segment = *bone.segment;
    const bool build = segment.branch && !segment.spine_continuation;
    Accumulator& total = build ? branch : segment.foot() ? feet : chain;
    total.sum += bone.error.sum;
    total.samples += bone.error.samples;
    total.max = std::max(total.max, bone.error.max);
    if (build) continue;
    metrics.bones.push_back({std::string(canonical_name(segment.canonical_start)) + "->" +
                                 std::string(canonical_name(segment.canonical_end)),
                             bone.error.direction()});
    if (segment.foot()) continue;
    const std::string limb(canonical_limb(segment.canonical_end));
    auto it = std::find_if(limbs.begin(), limbs.end(), [&](const auto& entry) { return entry.first == limb; });
    if (it == limbs.end()) it = limbs.insert(limbs.end(), {limb, Accumulator{}});
    it->second.sum += bone.error.sum;
    it->second.samples += bone.error.samples;
    it->second.max = std::max(it->second.max, bone.error.max);
  }
  metrics.bone_direction = chain.direction();
  metrics.branch_direction = branch.direction();
  metrics.foot_direction = feet.direction();
  for (const auto& [limb, accumulator] : limbs) metrics.limbs.push_back({limb, accumulator.direction()});
  return metrics;
}

}  // namespace odyssey::retarget
