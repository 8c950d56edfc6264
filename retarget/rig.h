// The pairing of a source skeleton with a target skeleton, built once and shared by every stage
// that follows (fast transfer, Ceres refinement, metrics): which joints drive which, the bone
// segments between them, the source's rest pose aligned to the target's, and the height scale.
//
// Bone segments. The canonical joints mapped on both rigs are the paired joints. A segment runs
// from a paired joint a to a paired joint c whose nearest paired ancestor in the canonical tree
// is a. On each rig it is the straight line from a's joint to c's joint, whatever lies between:
// three source spine bones against one target torso bone is one segment (spine1 -> spine3 when
// the target has no spine2), and so is the reverse. A target joint between a and c that plays
// no paired role keeps its rest rotation relative to its parent, so the target's a..c chain is
// rigid with a's joint and its direction is set by a's rotation alone.
//
// A segment is degenerate when it has (almost) zero length on either rig at rest (CMU's clavicles
// start on the chest joint itself, CMU's thumb stub sits on the wrist): it has no direction, and
// alignment, transfer and metrics leave it out. A segment's start is a branch joint when two or
// more non-degenerate segments start there (pelvis -> hips and spine, chest -> neck and
// clavicles, wrist -> fingers); otherwise the segment is a chain bone, the bone of its start
// joint. Above the pelvis, a branch joint's one midline child (chest -> neck, a single torso bone
// -> head) is its spine continuation: the transfer aligns it exactly as it aligns chain bones, and
// the shoulders, which hang from the same joint, take the difference in build with them (their
// own bones are driven and stay exact). At the pelvis the midline child is not aligned: how the
// spine leaves the pelvis is the build (RobotExpressive's pelvis -> spine leans 26 degrees from a
// human's at rest), and turning the pelvis for it would swing the hips and so the legs. On the target, a segment is detached when c's joint does not hang below a's joint (nor
// below one of its followers): RobotExpressive's feet are children of the root bone, not of the
// shins. Such a segment's target direction is the direction a's bone would point at c if c were
// attached: the rest offset a -> c turned with a's joint.
//
// Rest alignment (the paper's p_i^S* = p_j^T). The source's start pose (its skeleton rest, or the
// clip's first frame, see SourceRest) is posed, with Ceres, so that its segments point along the
// target's rest segments. Unknowns: the local rotation q_j of the source joint of every segment
// start that has a direction term, each a unit quaternion on EigenQuaternionManifold; every other
// source joint keeps its start-pose rotation. Cost:
//
//   sum over chain bones (a, c)       || dir_S(a, c; q) - dir_T(a, c) ||^2
//   sum over lateral pairs (l, r)     || dir_S(r, l; q) - dir_T(r, l) ||^2
//   sum over unknowns j               || lambda * 2 vec( q0_j^-1 q_j ) ||^2      (w >= 0 sign)
//
// dir(x, y) is the unit vector from x's joint to y's joint at rest, computed by forward kinematics
// on the Ceres jets. A branch joint's orientation is not fitted to its child segments' directions:
// how far apart the hips sit or how steeply the clavicles leave the chest is the rig's build, not
// its pose (RobotExpressive's thighs start above its pelvis joint, a human's below), and fitting
// those directions would tilt the whole source. Where a branch joint has mirror-image children
// (left and right hips, clavicles, shoulders, eyes) the lateral pair fixes which way the body
// faces and its roll, ||.|| of the left-minus-right direction; its pitch stays the start pose's
// (both rigs stand upright at rest). A branch without mirror-image children (a wrist and its
// fingers) fits its segments' directions. The regulariser (lambda = 0.01 by default) decides
// what the directions leave free, the twist about each bone, and keeps it at the start pose, so
// an arm lowered from T-pose to A-pose turns the short way; its pull on the directions themselves
// is of order lambda^2, far below a hundredth of a degree.
//
// Height scale (the paper): s = (Zmax - Zmin)(target rest) / (Zmax - Zmin)(source aligned rest),
// z up, where the points measured are the paired joints of each rig. Measuring the same landmarks
// on both sides is what makes the ratio mean "equally tall": counting every joint would compare
// a target's head-top end joint or IK pole target against a source that has none (Mixamo's
// HeadTop_End, RobotExpressive's PoleTarget), and joint heights against mesh heights would mix
// what the two rigs can measure (a BVH has no mesh). The source is measured in the aligned pose,
// the target's rest posture, so that a source recorded with splayed legs (the CMU BVH rest) is
// not measured short. After scaling the source by s, its paired joints span the target's.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "retarget/bone_map.h"
#include "skeleton/clip.h"

namespace odyssey::retarget {

// The source pose the alignment starts from and regularises toward.
enum class SourceRest {
  rest,         // the skeleton's rest pose (BVH offsets, SMPL-X J(beta) standing)
  first_frame,  // the clip's first frame (CMU BVH files open with a T-pose reference frame,
                // while their rest pose has the legs splayed)
};
const char* source_rest_name(SourceRest rest);

struct AlignmentOptions {
  double regularisation = 0.01;  // lambda above
  int max_iterations = 200;
};

struct Segment {
  int canonical_start = -1, canonical_end = -1;
  int source_start = -1, source_end = -1;  // source joints
  int target_start = -1, target_end = -1;  // target joints
  bool degenerate = false;
  bool branch = false;            // its start is a branch joint (see above)
  bool spine_continuation = false;  // a branch segment aligned as chain bones are (see above)
  bool target_attached = true;    // false: detached on the target (see above)
  Eigen::Vector3d target_rest_direction = Eigen::Vector3d::Zero();  // unit, world; zero if degenerate
  double aligned_error_deg = 0;   // angle between source (aligned) and target rest directions

  // Ankle -> ball of the foot. The transfer pitches a foot from the floor, not from this segment's
  // source direction (transfer.h): rigs put the ball joint at different places on the sole.
  bool foot() const {
    return (canonical_start == canonical::left_ankle && canonical_end == canonical::left_foot) ||
           (canonical_start == canonical::right_ankle && canonical_end == canonical::right_foot);
  }
};

struct AlignmentSummary {
  // Over the terms fitted (chain bones and lateral pairs): the angle left between source and
  // target directions after alignment.
  double mean_residual_deg = 0, max_residual_deg = 0;
  int fitted_terms = 0;
  int unknowns = 0;
  int iterations = 0;
  double seconds = 0;
  std::string solver_report;  // Ceres' one-line summary
};

struct RetargetRig {
  Skeleton source;
  Skeleton target;
  BoneMap source_map, target_map;
  SourceRest source_rest = SourceRest::rest;
  std::vector<int> paired;  // canonical joints mapped on both rigs, in canonical order
  std::vector<Segment> segments;
  // The source posed onto the target's rest directions, in world: rotations and positions of
  // every source joint (root at the start pose's translation).
  std::vector<Eigen::Quaterniond> source_aligned_local;
  std::vector<Eigen::Quaterniond> source_aligned_world;
  std::vector<Eigen::Vector3d> source_aligned_positions;
  // Where the source pelvis joint stands in the skeleton's rest pose: root motion is measured
  // from it (whatever SourceRest says), so the choice of alignment pose never moves the path.
  Eigen::Vector3d source_rest_pelvis = Eigen::Vector3d::Zero();
  double source_height = 0, target_height = 0;
  double scale = 1;  // target_height / source_height
  AlignmentSummary alignment;

  int source_joint(int canonical) const { return source_map.joints[canonical]; }
  int target_joint(int canonical) const { return target_map.joints[canonical]; }
};

// The spine's segments from spine1 up to the neck (the head on a rig without a neck), in order
// up the canonical tree: the chain along which the transfer shares the performer's bend
// (transfer.h). Empty when spine1 or the top is not paired, when a segment of the way is
// degenerate, or when the chain is one segment (its chord is the segment: nothing to share).
std::vector<const Segment*> spine_chain(const RetargetRig& rig);

// Pairs the maps, aligns and scales. `source` supplies the skeleton and, for
// SourceRest::first_frame, the first frame. Throws std::invalid_argument when the pelvis is not
// mapped on both rigs, when a target joint mapped above the target pelvis would fight the root
// motion, when a rig has no height over the paired joints, or when the source clip is empty but
// its first frame is asked for.
RetargetRig build_retarget_rig(const Clip& source, const BoneMap& source_map, const Skeleton& target,
                               const BoneMap& target_map, SourceRest source_rest = SourceRest::rest,
                               const AlignmentOptions& options = {});

}  // namespace odyssey::retarget
