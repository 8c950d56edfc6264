// The quality metrics of a retargeted clip: one definition (ARCHITECTURE.md, "Metrics"), used by
// tests, benchmarks and reports. Lengths in metres unless a name says otherwise; the scaled source
// is the source clip with every length multiplied by the rig's scale s.
//
// Bone direction error, degrees: per chain bone (rig.h: a non-degenerate segment whose start
// joint starts no other) or spine continuation (rig.h: chest -> neck) and frame, the angle between
// the source direction p_S(S(c)) - p_S(S(a)) and the target direction p_T(T(c)) - p_T(T(a)), the
// line a viewer sees, a detached segment's (a foot joint that is not the knee's child) included.
// Mean and max over every (bone, frame), per limb (canonical_limb of the bone's end), and per
// bone. The other segments of a branch joint (the pelvis with its hips and spine, the chest's
// clavicles or shoulders, a wrist's fingers) have no single bone direction: the angles between
// them are the rig's build (hip width, shoulder slope), which no rotation can change. They are
// reported apart, as `branch_direction`, with the same definition. So are the feet (ankle -> ball
// of the foot), as `foot_direction`, and per bone: the transfer pitches a foot so that its sole
// meets the floor as the performer's does (transfer.h), and rigs put the ball joint in different
// places on the sole, so the segment's angle to the performer's is the two feet's builds as much as
// the motion.
// Hip line error, degrees: per frame, the angle between the source's right hip -> left hip line
// and the target's, when both hips are paired. No limb starts at the pelvis, so this is where
// the pelvis's roll and turn show (the rest alignment fits this lateral pair, rig.h).
// Torso error, degrees: per frame, the angle between the source's line from the spine's base joint
// (spine1) to the neck (the head on a rig without a neck) and the target's: the torso above the
// pelvis as a whole, where the spine's bend shows. Rigs split the spine into different numbers and
// lengths of bones (CMU's Spine, Spine1 and a neck from the chest against Mixamo's Spine, Spine1,
// Spine2), so every segment can be exact while this line is not (transfer.h, the spine's bend).
// Pelvis to neck, degrees: the same from the pelvis joint; it adds how the spine leaves the pelvis,
// the rig's build (rig.h: the pelvis's midline child is not aligned), so it is reported, not
// targeted. Spine bend error, degrees: per frame, |b_T - b_S|, b the angle between the first and
// the last segment of the spine chain (rig.h: spine_chain), how far the spine curls; no samples
// without a chain.
// End-effector error, m: per frame and paired head, wrist and ankle e,
//   | (p_T(e) - p_T(pelvis)) - s (p_S(e) - p_S(pelvis)) |,   mean and max.
// Foot skate ratio: over every foot and every pair of consecutive frames (t, t+1), the share where
// the foot is in contact (clearance, contacts.h, under h in both frames) and the foot joint that
// is lowest in frame t moves faster than v horizontally between t and t+1. Two figures:
//   foot_skate_ratio      scale-aware, the one targets use: a character s times the performer's
//                         size (s = rig.scale) is judged with h = 5 cm * s and v = 0.5 m/s * s,
//                         so a motion and the same motion scaled by s skate alike;
//   foot_skate_ratio_gmd  GMD's: h = 5 cm and v = 0.5 m/s whatever the clip's size.
// The source is measured at its own (the performer's) size, where the scale-aware thresholds are
// GMD's, so its two figures are the same number. A giant (s > 1) skates less by GMD's figure than
// by the scale-aware one, since fixed thresholds are small against its strides.
// Penetration / floating, cm: over the (foot, frame) where the SOURCE foot is planted
// (FootContacts), the mean of max(0, -clearance) and of max(0, clearance). The lowest foot point
// is the lowest of the foot's points (ankle, ball of the foot, toe: contacts.h) relative to its
// ground height. Skate follows the lowest foot joint, as ARCHITECTURE.md defines it: the toe stands
// in for a ball of the foot only on a foot of one joint.
// Foot tilt, degrees: over the same (foot, frame), the mean of |pitch - pitch_flat| for a foot with
// a front point (its toe, or else its ball: contacts.h), pitch = asin(dz / L) of the line from its
// first joint to the front point (dz its rise, L its length) and pitch_flat the same with both
// points at their ground heights: how far the foot is turned, heel or toe up, from standing flat.
// The performer's comes from heel strikes and toe-offs. A rig whose ball joint sits elsewhere on
// the sole than the performer's would stand tilted, toes up, if its foot segment followed the
// performer's direction, which is why the transfer pitches feet to the floor (transfer.h;
// docs/retargeting.md, feet).
// Jitter, m/s^2: the mean over frames 1..T-2 and paired joints of
//   | p(t+1) - 2 p(t) + p(t-1) | fps^2.
//
// For the scaled source itself the comparative metrics (bone direction, end effector) are zero
// and the others are measured on the source with its own feet.
#pragma once

#include <string>
#include <vector>

#include "retarget/contacts.h"
#include "retarget/rig.h"

namespace odyssey::retarget {

struct DirectionError {
  double mean_deg = 0, max_deg = 0;
  long samples = 0;  // (bone, frame) pairs
};

struct NamedDirectionError {
  std::string name;  // "left_hip->left_knee", or a limb name
  DirectionError error;
};

struct RetargetMetrics {
  DirectionError bone_direction;
  std::vector<NamedDirectionError> limbs;  // limbs that have chain bones, canonical order
  std::vector<NamedDirectionError> bones;  // every chain bone
  DirectionError branch_direction;
  DirectionError foot_direction;  // ankle -> ball of the foot, pitched to the floor (above)
  DirectionError hip_line;  // no samples when a rig lacks a hip
  DirectionError torso;          // spine1 -> neck (or head, above); no samples when a rig lacks either
  DirectionError pelvis_to_neck;  // the same from the pelvis
  DirectionError spine_bend;     // |b_T - b_S| (above)
  double end_effector_mean_m = 0, end_effector_max_m = 0;
  double foot_skate_ratio = 0;      // scale-aware (above)
  double foot_skate_ratio_gmd = 0;  // fixed thresholds (above)
  double penetration_cm = 0, floating_cm = 0;
  double foot_tilt_deg = 0;
  double jitter = 0;  // m/s^2
};

// GMD's thresholds, at the performer's size (the scale-aware figure multiplies them by s).
struct MetricThresholds {
  double contact_height = 0.05;  // m
  double skate_speed = 0.5;      // m/s
};

// Metrics of the scaled source (see above). `feet` and `contacts` are the source's.
RetargetMetrics source_metrics(const RetargetRig& rig, const Clip& source, const Feet& feet, const FootContacts& contacts,
                               const MetricThresholds& thresholds = {});

// Metrics of a result clip on rig.target against the source it was made from (read levelled by
// source_feet.levelling). Feet from contacts.h; `contacts` are the source's. Throws
// std::invalid_argument when the clips' frame counts or skeletons do not match the rig.
RetargetMetrics result_metrics(const RetargetRig& rig, const Clip& source, const Feet& source_feet, const Clip& result,
                               const Feet& target_feet, const FootContacts& contacts, const MetricThresholds& thresholds = {});

}  // namespace odyssey::retarget
