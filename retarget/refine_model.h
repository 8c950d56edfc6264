// The refinement's model of a target rig (refine.h): which joints are unknown, how every target
// joint's world transform follows from them, the limbs the balanced solver splits a frame into,
// their residuals written once for doubles and Ceres jets, the foot plan, and the per-frame data
// the solvers read. Internal to refine.cpp; in a header so that tests can check its pieces.
//
// Placement of target joints (as transfer.h places them, so that a refined pose is assembled the
// way the transfer assembled the reference, but for IK effectors):
//   child      world = parent's world * local (local: solved, or the reference's)
//   rigid      a follower: rigid with its anchor, X = X(A) X_ref(A)^-1 X_ref(j)
//   attached   a detached joint inside the body: its position rigid with the anchor A,
//              P = P(A) + W(A) W_ref(A)^-1 (P_ref(j) - P_ref(A)); its world rotation the
//              reference's (the transfer drives it from the source)
//   chain_end  an IK effector (a detached segment's end outside the pelvis's subtree, as
//              RobotExpressive's feet under the root bone): at the end of its segment's start
//              joint A, P = P(A) + W(A) c_rest with c_rest the rest chord A -> j in A's frame, so
//              the leg reaches the foot; its world rotation the reference's
//   root       the skeleton root above the pelvis: the reference's, moved by dp
//
// These placements make a kinematic tree over the target's joints (RefineModel::kinematics,
// fk.h): a joint hangs from its parent (child) or its anchor (the others), with its local
// transform read off the reference; attached and chain_end joints hold their rotation in world;
// the root hangs from the world. Placing a frame is forward kinematics over that tree.
//
// A limb is the part of the tree its residuals read: nodes from the pelvis down to every joint a
// residual needs, as their own tree hanging from the pelvis (Limb::kinematics). Its slots are the
// unknown rotations its nodes read; the first `owned` are solved with it, the others are held at
// their current value.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "retarget/geometry.h"
#include "retarget/refine.h"
#include "skeleton/fk.h"

namespace odyssey::retarget::refinement {

template <class T>
using Vector3 = Eigen::Matrix<T, 3, 1>;

inline constexpr double kReferenceHeight = 1.7;  // m

inline double smoothstep(double x) { return x * x * (3.0 - 2.0 * x); }

enum class Placement { child, rigid, attached, chain_end, root };

struct LimbNode {
  int joint = -1;  // target joint
  int slot = -1;   // child nodes whose rotation is unknown: the limb's slot
};

struct DirectionTerm {
  int from = -1, to = -1;        // nodes; `to` is -1 for a detached segment
  Eigen::Vector3d rest_chord;    // detached: unit rest chord in the start joint's frame
  int source_from = -1, source_to = -1;
  // Segment::foot or a segment of the spine chain (rig.h): the target is the reference's direction,
  // which the transfer shaped (transfer.h: feet pitched to the floor, the spine's bend shared), not
  // the source's.
  bool from_reference = false;
};

struct EffectorTerm {
  int node = -1;
  int source_joint = -1;
};

struct FootTerm {
  int side = 0;
  std::vector<int> nodes;  // one per foot joint, in Foot::joints order
  std::vector<double> ground_heights;
  // The foot's toe (contacts.h), its last point: at nodes[0] + W(nodes[0]) toe.
  bool has_toe = false;
  Eigen::Vector3d toe = Eigen::Vector3d::Zero();
  double toe_ground_height = 0;

  int point_count() const { return static_cast<int>(nodes.size()) + (has_toe ? 1 : 0); }
};

struct Limb {
  std::string name;
  std::vector<LimbNode> nodes;
  // The nodes as a tree hanging from the pelvis (the base): each hangs from the node of its
  // parent or anchor, attached and chain_end nodes with their rotation in world.
  KinematicModel kinematics;
  std::vector<int> slots;       // unknown index of each slot, owned first
  std::vector<int> slot_nodes;  // node of each slot
  int owned = 0;
  bool moves_pelvis = false;  // dp is solved with this limb
  std::vector<DirectionTerm> directions;
  std::vector<EffectorTerm> effectors;
  std::vector<FootTerm> feet;
  double length_scale = 1;  // RefineModel::length_scale
  // The nodes whose world transform depends on what the limb solves (its owned slots, dp if it
  // moves the pelvis), in order: forward kinematics runs over these per evaluation, the others
  // (fixed_nodes) keep the frame's world transforms.
  std::vector<int> moving_nodes, fixed_nodes;

  int residual_count() const;
  // Rotation vectors of the owned slots, then (when the limb moves the pelvis) dp and the pelvis's
  // turn.
  int parameter_count() const { return 3 * owned + (moves_pelvis ? 6 : 0); }
};

struct RefineModel {
  int pelvis = -1, root = -1;  // target joints
  double scale = 1;            // the rig's height scale s
  // Length residuals are multiplied by kReferenceHeight / the target's height (rig.h), so that a
  // weight means the same on a 5 cm figure as on a 50 m one: weights are per metre of a 1.7 m
  // tall character.
  double length_scale = 1;
  std::vector<Placement> placement;  // per target joint
  std::vector<int> anchor;           // rigid, attached, chain_end: the joint it moves with
  std::vector<Eigen::Vector3d> chain_end_offset;  // chain_end: c_rest
  // The placement tree (above): parents the joints hung from, each after its parent and its
  // anchor in `kinematics.order`; rest transforms unused (every frame sets its own).
  KinematicModel kinematics;
  std::vector<int> unknown_joints;   // ascending
  std::vector<int> unknown_of;       // per target joint, -1 when not unknown
  std::array<Foot, 2> feet;          // the target's
  std::vector<Eigen::Quaterniond> rest_rotation;  // world, per target joint
  std::vector<Limb> limbs;           // in solve order: lower body, spine, left arm, right arm
  int source_pelvis = -1;
};

RefineModel build_refine_model(const RetargetResult& result);

// The foot plan of one side (refine.h): per frame the foot point it places (index into the foot's
// points, contacts.h: its joints, then its toe; -1 none), and where: D(t) = p_ref(t) + offset(t)
// + follow(t) dp(t), p_ref the point in the reference pose (placed as above), dp the pelvis's
// displacement. In a contact follow = 0 and D is the anchor; fading out, u(t) going from 1 to 0,
// offset = u (dp_plan + o) and follow = 1 - u, so the foot passes from its anchor to moving with
// the body.
//
// A foot of one joint without a toe is held flat while planted, its rotation the rest's turned
// about z as the reference turns (heading_of), slerped from the reference's with weight
// flat(t) = u(t) in the fades.
struct FootPlan {
  std::vector<std::int8_t> point;
  std::vector<Eigen::Vector3d> offset;
  std::vector<double> follow;
  std::vector<double> flat;  // empty for feet of two joints or with a toe
};

// What refine() plans before solving: the stride factor k and the height h, the pelvis
// displacement they imply, dp_plan(t) = ((k - 1) (P_ref(t) - P_ref(0)) horizontally, h), and
// the feet.
struct MotionPlan {
  double stride = 1;
  double height = 0;
  std::vector<Eigen::Vector3d> pelvis_offset;  // dp_plan, per frame
  std::array<FootPlan, 2> feet;
};

// The unknowns of one frame.
struct FramePose {
  std::vector<Eigen::Quaterniond> rotation;  // per unknown joint, local
  Eigen::Vector3d pelvis_offset = Eigen::Vector3d::Zero();  // dp
  // The pelvis's turn: its world rotation is the reference's times this (a rotation in its own
  // frame), so that with both feet planted it can roll the hips level instead of bending a leg.
  Eigen::Quaterniond pelvis_turn = Eigen::Quaterniond::Identity();
};

// What a limb's residuals read in one frame.
struct LimbFrame {
  QuaternionTransform<double> pelvis;  // the reference's pelvis, world (dp not added)
  Eigen::Vector3d pelvis_offset;  // dp's current value
  Eigen::Vector3d pelvis_prior;   // dp_plan(t)
  // balanced: the previous frame's solved dp carried onto this frame, dp(t-1) + dp_plan(t) -
  // dp_plan(t-1), and the lag weight w_lag L sqrt(fps) on dp's horizontal change from it (refine.h);
  // the weight is 0 on the first frame a window solves, and in accurate's space-time problem.
  Eigen::Vector3d pelvis_previous = Eigen::Vector3d::Zero();
  double pelvis_lag = 0;
  Eigen::Quaterniond pelvis_turn; // the turn's current value
  // The limb's nodes at the current values: base the pelvis moved by dp; locals as the placement
  // tree's (a slot's at its current value); world transforms from forward kinematics.
  QuaternionKinematicData<double> pose;
  std::vector<Eigen::Quaterniond> slot_value;      // current value of every slot
  std::vector<Eigen::Quaterniond> slot_reference;  // the reference's local rotation of every slot
  std::vector<Eigen::Vector3d> direction_target;   // unit
  std::vector<Eigen::Vector3d> effector_target;    // s (p_S(e) - p_S(pelvis))
  std::vector<int> contact_point;                  // per foot term: the plan's point, -1 none
  std::vector<Eigen::Vector3d> contact_target;     // p_ref(t) + offset(t)
  std::vector<double> contact_follow;              // follow(t)
};

// Reference and source poses of one frame, limb data from them, and the refined frame written
// back. One per thread; holds scratch buffers.
class FrameBuilder {
 public:
  FrameBuilder(const RefineModel& model, const Clip& reference, const Clip& source, const Feet& source_feet);

  void load(int frame);
  // The loaded frame's reference as a FramePose (unknowns at the reference, dp = 0).
  void reference_pose(FramePose& pose) const;
  // The loaded frame's reference local rotation of a target joint.
  const Eigen::Quaterniond& reference_local(int joint) const { return reference_.rotation(frame_, joint); }
  double fps() const { return reference_.fps; }
  void fill(const Limb& limb, const FramePose& pose, const MotionPlan& plan, LimbFrame& frame) const;
  // Where a joint is in the loaded frame's reference pose, placed as above (an IK foot at the
  // end of its shin, not where the transfer put it).
  const Eigen::Vector3d& reference_position(int joint) const { return reference_placed_.world[joint].translation; }
  // Where point k of a foot (contacts.h: its joints, then its toe) is in the loaded frame's reference.
  Eigen::Vector3d reference_point(const Foot& foot, int k) const {
    if (k < static_cast<int>(foot.joints.size())) return reference_position(foot.joints[k]);
    return reference_position(foot.joints[0]) + reference_rotation(foot.joints[0]) * foot.toe;
  }
  const Eigen::Quaterniond& reference_rotation(int joint) const { return reference_placed_.world[joint].rotation; }
  // Where a source joint is in the loaded frame: levelled, at the performer's size.
  const Eigen::Vector3d& source_position(int joint) const { return source_pose_.world[joint].translation; }
  // Writes the loaded frame of `out` (a clip laid out as the reference) from a solved pose: every
  // joint placed as above, single-joint feet held flat as the plan says, locals recomputed where
  // a joint's parent or anchor moved.
  void write(const FramePose& pose, const MotionPlan& plan, Clip& out);

 private:
  const RefineModel& model_;
  const Clip& reference_;
  const Clip& source_;
  int frame_ = -1;
  QuaternionKinematicData<double> reference_pose_;    // the reference's frame on the target skeleton
  QuaternionKinematicData<double> source_pose_;       // the source's frame, levelled (contacts.h)
  QuaternionKinematicData<double> reference_placed_;  // the placement tree at the reference (dp = 0)
  QuaternionKinematicData<double> placed_;            // place()'s output
  std::vector<std::uint8_t> flattened_;     // place() held the joint flat

  void place_locals();
  void place(const FramePose& pose, const MotionPlan* plan);
};

// The plan (refine.h), from the reference and the source (loaded frame by frame into `builder`),
// the source's feet and contacts; blend_frames is contact_blend_seconds in frames; with
// fit_stride false, k = 1; contact_lift as RefineOptions'.
MotionPlan plan_motion(const RefineModel& model, FrameBuilder& builder, const Feet& source_feet, const FootContacts& contacts,
                       int blend_frames, bool fit_stride, std::optional<double> contact_lift);

// Buffers for limb_residuals, sized for one limb and reused across evaluations (a jet is large,
// and a fresh array of them would be zeroed on every call): the limb's pose, which load() fills
// from a frame and whose owned slots' rotations the caller sets per evaluation.
template <class T>
struct LimbWork {
  const Limb& limb;
  QuaternionKinematicData<T> pose;

  explicit LimbWork(const Limb& limb) : limb(limb), pose(limb.kinematics) {}
  Eigen::Quaternion<T>& slot(int s) { return pose.local[limb.slot_nodes[s]].rotation; }
  // What evaluations do not change: the pelvis's rotation (turned; a limb that moves the pelvis
  // sets its own), the moving nodes' local transforms (held slots at their value) and the other
  // nodes' world transforms.
  void load(const LimbFrame& frame) {
    pose.base.rotation = (frame.pelvis.rotation * frame.pelvis_turn).template cast<T>();
    for (int n : limb.moving_nodes) pose.local[n] = frame.pose.local[n].template cast<T>();
    for (int n : limb.fixed_nodes) pose.world[n] = frame.pose.world[n].template cast<T>();
  }
};

// Residuals of one limb in one frame (refine.h), in the order: directions (3 each), effectors
// (3 each), feet (contact 3, then floor 1 per joint), pose of the owned slots (3 each), pelvis,
// its turn and its lag (3 each, when the limb moves it); lengths times limb.length_scale. The owned slots'
// rotations are in work.slot(s), the rest as work.load(frame) left it; pelvis_turn is read only
// when the limb moves the pelvis.
template <class T>
void limb_residuals(const Limb& limb, const RefineWeights& w, const LimbFrame& frame, const Vector3<T>& pelvis_offset,
                    const Eigen::Quaternion<T>& pelvis_turn, LimbWork<T>& work, T* residual) {
  using std::sqrt;
  QuaternionKinematicData<T>& pose = work.pose;
  pose.base.translation = frame.pelvis.translation.template cast<T>() + pelvis_offset;
  if (limb.moves_pelvis) pose.base.rotation = frame.pelvis.rotation.template cast<T>() * pelvis_turn;
  forward_kinematics(limb.kinematics, pose, limb.moving_nodes);
  const auto position = [&pose](int node) -> const Vector3<T>& { return pose.world[node].translation; };

  T* r = residual;
  const auto put = [&r](const Vector3<T>& value, double weight) {
    for (int i = 0; i < 3; ++i) *r++ = T(weight) * value[i];
  };
  for (std::size_t d = 0; d < limb.directions.size(); ++d) {
    const DirectionTerm& term = limb.directions[d];
    Vector3<T> direction;
    if (term.to < 0) {
      direction = pose.world[term.from].rotation * term.rest_chord.template cast<T>();
    } else {
      const Vector3<T> chord = position(term.to) - position(term.from);
      direction = chord / sqrt(chord.squaredNorm());
    }
    put(direction - frame.direction_target[d].template cast<T>(), w.bone_direction);
  }
  const double length = limb.length_scale;
  for (std::size_t e = 0; e < limb.effectors.size(); ++e) {
    put(position(limb.effectors[e].node) - pose.base.translation - frame.effector_target[e].template cast<T>(),
        length * w.end_effector);
  }
  for (std::size_t f = 0; f < limb.feet.size(); ++f) {
    const FootTerm& foot = limb.feet[f];
    const auto point = [&](int k) -> Vector3<T> {
      if (k < static_cast<int>(foot.nodes.size())) return position(foot.nodes[k]);
      return position(foot.nodes[0]) + pose.world[foot.nodes[0]].rotation * foot.toe.template cast<T>();
    };
    const int contact = frame.contact_point[f];
    if (contact >= 0) {
      put(point(contact) - frame.contact_target[f].template cast<T>() - T(frame.contact_follow[f]) * pelvis_offset,
          length * w.foot_contact);
    } else {
      put(Vector3<T>::Zero(), 0.0);
    }
    for (int k = 0; k < foot.point_count(); ++k) {
      const double ground = k < static_cast<int>(foot.nodes.size()) ? foot.ground_heights[k] : foot.toe_ground_height;
      const T depth = T(ground) - point(k).z();
      *r++ = depth > T(0) ? T(length * w.floor) * depth : T(0);
    }
  }
  for (int s = 0; s < limb.owned; ++s) {
    put(rotation_difference(Eigen::Quaternion<T>(frame.slot_reference[s].template cast<T>()), work.slot(s)), w.pose);
  }
  if (limb.moves_pelvis) {
    put(pelvis_offset - frame.pelvis_prior.template cast<T>(), length * w.pelvis);
    put(rotation_difference(Eigen::Quaternion<T>::Identity(), pelvis_turn), w.pelvis_turn);
    const Vector3<T> moved = pelvis_offset - frame.pelvis_previous.template cast<T>();
    put(Vector3<T>(moved.x(), moved.y(), T(0)), frame.pelvis_lag);
  }
}

}  // namespace odyssey::retarget::refinement
