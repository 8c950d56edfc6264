// Quality `fast`: rotation transfer from an aligned rest (rig.h), one pass over the clip, no
// solver. Everything that does not change along the clip is precomputed per rig; the per-frame
// loop is plain arithmetic on preallocated buffers (no allocation, no search).
//
// Rotations. For each target joint T(a) that plays a paired canonical joint a, with the source
// joint S(a), world rotations Q_S(t) along the clip and Q_S^al in the aligned rest pose, and the
// target's rest world rotation W^rest:
//
//   D(t)    = Q_S(S(a), t) Q_S^al(S(a))^-1        the source joint's world rotation change
//   W(t)    = D(t) W^rest                          (the paper's transfer)
//
// then, when a is the start of exactly one non-degenerate segment (a chain bone, rig.h), the
// bone is swung onto the source bone's direction exactly:
//
//   W(t)    = swing(D(t) v, u(t)) D(t) W^rest,     v = the target bone's rest direction,
//                                                  u(t) = unit(p_S(S(c), t) - p_S(S(a), t)),
//   swing(x, y) = the shortest rotation taking x to y = normalise(1 + x.y, x cross y).
//
// D(t) v equals u(t) already when the source segment is one rigid bone and the alignment is
// exact; the swing makes the direction exact in every other case too (a source segment spanning
// several bones, spine1 -> spine3 through spine2, or an alignment residual), while D(t) keeps the
// twist about the bone. Leaves (head, hands, toes) take W(t) = D(t) W^rest. A branch joint (the
// pelvis with hips and spine, a chest with neck and clavicles, a wrist with fingers; rig.h) takes
// the rotation that best carries the source's chords from the aligned rest to frame t:
//
//   W(t) = R(t) W^rest,   R(t) = argmin over rotations R of  sum_k |R u_k^al - u_k(t)|^2 + eps |R - D(t)|^2
//                              = the rotation factor of  B = sum_k u_k(t) u_k^al^T + eps D(t),
//
// u_k the unit chords from S(a) to each child S(c_k) (aligned rest and frame t), eps = 0.1 (D(t)
// only settles what the chords leave open, the twist about collinear chords). R(t) is D(t) when
// the chords are rigid with S(a) (a pelvis); when they are not (a target torso joint playing
// spine1 whose neck and shoulders hang from the source's spine3, two bones higher), it follows
// where the children went. The factor comes from Newton's polar iteration
// X <- (X + X^-T) / 2 started from B / cbrt(det B): no SVD, a handful of 3x3 inverses. The
// target's branch chords keep whatever angle the two rigs' builds put between them at rest
// (hip width, shoulder slope); metrics.h reports them apart. A branch joint with a spine
// continuation (rig.h: chest -> neck) is then swung so that it is exact, as a chain bone is:
//   W(t) = swing(R(t) v, u(t)) R(t) W^rest,   v, u(t) that segment's target rest and source directions;
// the shoulders hanging from the same joint move with it by the few degrees the builds differ,
// and their own bones, driven, stay exact. The output is local:
// W(parent)^-1 W(t). A target joint with no paired role keeps its rest local rotation, so it
// rides rigidly on its parent.
//
// The spine's bend (rig.h: spine_chain, the segments k from spine1 up to the neck, lengths L_k on
// the target). With every segment exact, the target's chord from spine1 to the neck is
//   c_T(t) = sum_k L_k u_k(t),   u_k the source segments' directions,
// and the source's is c_S(t) = sum_k L'_k u_k(t), L'_k the performer's lengths (scaled). Two rigs
// that split the spine in other proportions (CMU's Spine, Spine1 and a neck from the chest; the
// Mixamo rig's Spine, Spine1, Spine2) put the bend at other heights, so when the performer bends
// by theta the chords part by about theta (beta_S - beta_T), beta the share of the chain's length
// above the bend: the torso leans off the performer's with every segment exact. The chain is turned as one, keeping the performer's bend
// between its segments, by half of the rotation that would make its chord exact:
//   W_k(t) = T(t) W_k^exact(t),   T(t) = slerp(1, shortest(unit c_T, unit c_S), 1/2),
// for every driven joint that starts a segment of the chain. Turned by an angle phi, the chord is
// E - phi off the performer's and every segment phi: phi = E / 2 minimises the sum of the two
// squares, the torso as a whole and its parts weighing alike. Limbs hanging from the chain (arms,
// the head) are driven in world and stay exact; only where they hang from moves.
//
// The source is read in its levelled world (contacts.h: a tilted capture floor is turned level),
// so Q_S and p_S below are the levelled source's.
//
// Root motion. The target pelvis joint is put at
//   P*(t) = P_T^rest(pelvis) + s (p_S(pelvis, t) - p_S^rest(pelvis)) + (0, 0, dz(t))
// (then moved horizontally by c(t), below) by translating the target skeleton's root (the pelvis
// itself, or a root above it that keeps its rest rotation, as RobotExpressive's `Bone`). dz(t) keeps the floor from the legs' reach: the
// target's legs follow the source's directions, but their lengths need not be s times the
// performer's (RobotExpressive's thighs are two thirds of the scaled performer's, its shins as
// long), so a planted foot stands higher or lower than the scaled source's by an amount that
// changes with how far the knees bend. With clearances as in contacts.h, per foot and frame the
// gap is
//   g(foot, t) = s clearance_S(foot, t) - clearance_T(foot, t)   (before dz),
// and
//   n(t)  = mean of g over the feet the source plants at t,
//           linear between the nearest frames with a contact (held before the first and after
//           the last; every foot's mean when the source never plants one),
//   dz(t) = n smoothed by a Gaussian of sigma = 0.1 s (normalised where it runs past the clip).
// The planted feet then stay on the floor through a crouch (which one constant for the clip
// cannot follow), a flight lands where the next contact wants the body, and the smoothing keeps
// contacts starting and ending from jerking the body.
//
// The same legs make a planted foot slide: with the thigh shorter than the scaled performer's,
// the foot under a pelvis that travels s times the performer's path moves while the source's
// stays. The root is moved horizontally by c(t), which the planted feet drive:
//   e(foot, t) = horizontal part of [ (p_T(k, t+1) - p_T(k, t)) - s (p_S(k', t+1) - p_S(k', t)) ],
//                k, k' the target's and the source's lowest foot point at t (contacts.h),
//   c(t+1) - c(t) = - mean of e over the feet planted at both t and t+1 (0 when none is),
// the steps smoothed by a Gaussian of sigma = 0.05 s before they are summed. A planted foot then
// slides as much as the scaled source's (not less: the performer's own slip is the motion), and
// the character covers the ground its legs walk, as a stride fitted per step. c(0) = 0: the clip
// starts where the scaled source does. With both feet planted, each moves by half of what the two
// disagree; no root motion can still both when the legs' proportions say otherwise.
//
// Nor can a root motion put two planted feet on the floor when one stands higher than the other:
// with hip width and leg length not the performer's in one ratio, a leg along the performer's
// ends too high or too low. The pelvis rolls instead: turned by r about the horizontal axis z x h (h the hip chord
// left minus right, horizontal part, unit), the left hip falls by r |h| relative to the right
// (to first order), and the legs, whose directions are held in world, carry the feet with them.
// So, in a first pass over the clip with the pelvis as driven,
//   r(t) = -(g(left, t) - g(right, t)) / |h(t)|   where the source plants both feet (within 15
//          degrees), 0 elsewhere, smoothed by a Gaussian of sigma = 0.05 s,
// and the clip is placed again with the pelvis's world rotation turned by r(t) before dz and c
// are measured. The chain bones stay exact; the pelvis's own rotation is a fit already (branch
// joint). The roll falls to 0 between double supports: held there, it would sway the hips through
// each step and lower the swinging foot.
//
// Joints placed by position (they become animated translations in the output clip):
// - A detached segment's end (rig.h: RobotExpressive's feet hang from the root bone, not from the
//   shins) is placed at the end of its segment's start joint A, as if it hung from it:
//     P(t) = P(A, t) + W(A, t) W^rest(A)^-1 (P_T^rest(joint) - P_T^rest(A)),
//   so the line a viewer sees from the knee to the foot follows the source shin exactly, as an
//   attached foot does. (Placed where the scaled source's foot is, a planted foot would stay
//   still, but on legs built unlike the performer's the shin it draws would leave the source's;
//   planting feet is the refinement's job, which places them this way too, refine_model.h.)
// - Feet with a toe (contacts.h: the front of the sole, from the mesh) take their pitch from
//   positions, not from the source's rotation. Copied, the foot segment would point where the
//   performer's ankle -> ball does, but rigs put the ball joint elsewhere on the sole
//   (RiggedFigure's 61 degrees below its ankle at rest, the performer's 18), so the foot would
//   stand toes up through every contact (`foot_tilt_deg`, metrics.h), and a foot much longer than
//   the scaled performer's (RobotExpressive's block) would drive its toe through the floor at
//   toe-off. The rotation above is turned
//   about its horizontal lateral axis through the foot's first joint so that the toe stands above
//   that joint as the source's ball of the foot stands above its ankle, in clearances (contacts.h)
//   scaled by s:
//     z(toe) - z(joint) = (g_toe - g_joint) + s ((z_ball - g_ball) - (z_ankle - g_ankle))_S,
//   so the sole is flat when the performer's foot is, and the heel rises as far as the performer's
//   at toe-off whatever the foot's length. With the toe's offset o = W(t) toe = L f + v z (f
//   horizontal, unit), a turn by theta about z x f gives o.z = v cos theta - L sin theta =
//   rho sin(phi - theta), rho = |o|, phi = atan2(v, L): theta = phi - asin(wanted / rho). Heading
//   and roll stay the source's; a driven ball of the foot is turned with it, keeping its bend
//   against the foot; a source foot without a ball of the foot leaves the rotation as it is. The
//   foot segment is then off the performer's direction by the two rigs' builds (metrics.h reports
//   feet apart).
//   The rise assumes the leg lifts the heel as far as the scaled performer's, and a leg short for
//   its foot (the KayKit mannequin's) does not: the rise alone would put its toe into the floor at
//   toe-off. So the toe stands no lower than the performer's lowest foot joint, in clearances
//   scaled by s:
//     rise >= g_toe + s clearance_S(t) - (z(joint) + dz_1(t)),
//   dz_1 the floor offset dz(t) above from a first pass, over the foot joints alone and the frames
//   where the performer's heel is down (ankle clearance under 1 cm): there a foot stands flat on
//   both rigs, so what the toe does at toe-off does not move the floor it is held above. Both
//   sides move with the source's height, so a clip whose floor climbs is pitched as a level one.
// - Followers (bone_map.h) ride rigidly on their canonical parent's target joint A, placed as
//   above, and take their rotation from it: W(t) = W(A, t) W^rest(A)^-1 W^rest.
//
// Quaternion signs are kept continuous along the clip (each local rotation is the sign of the
// two nearest the previous frame's; the first frame has w >= 0).
#pragma once

#include <optional>
#include <vector>

#include "retarget/contacts.h"
#include "retarget/rig.h"
#include "skeleton/fk.h"

namespace odyssey::retarget {

struct TransferResult {
  Clip clip;                // on rig.target, at the source's frame rate
  double floor_offset = 0;  // dz(t) above averaged over the clip, m
};

class FastTransfer {
 public:
  // Precomputes the per-joint plan. The rig must outlive the transfer. Throws
  // std::invalid_argument when the placements depend on each other in a cycle (a map that puts a
  // canonical parent below its child).
  FastTransfer(const RetargetRig& rig, const Feet& target_feet);

  // `source` must be a clip on rig.source's skeleton; `source_feet` and `contacts` come from
  // contacts.h for that clip. Throws std::invalid_argument on a skeleton mismatch, a frame count
  // mismatch, or a non-finite value in the clip (naming the frame and joint).
  TransferResult run(const Clip& source, const Feet& source_feet, const FootContacts& contacts) const;

 private:
  struct JointRule {
    enum class Rotation { rest, driven, follower };
    Rotation rotation = Rotation::rest;
    int parent = -1;
    // In the placement tree (placement_): the rest local rotation (a held rotation is set per
    // frame instead) and the offset from the joint it hangs from, its parent's frame or, attached,
    // W^rest(A)^-1 (P^rest - P^rest(A)).
    QuaternionTransform<double> local;
    int reference = -1;  // driven: S(a)
    Eigen::Quaterniond reference_to_joint = Eigen::Quaterniond::Identity();  // Q_S^al(S(a))^-1 W^rest
    // Driven chain bones and spine continuations: the segment's source joints, and v in the frame
    // the rotation is composed in (Q_S^al(S(a))^-1 v for a chain bone, W^rest^-1 v for a branch).
    int chord_from = -1, chord_to = -1;
    Eigen::Vector3d chord_rest = Eigen::Vector3d::Zero();
    int branch_first = 0, branch_count = 0;  // driven branch joints: their chords in branch_chords_
    int anchor = -1;  // follower, attached: A
    Eigen::Quaterniond anchor_to_joint = Eigen::Quaterniond::Identity();  // W^rest(A)^-1 W^rest
    int toe_side = -1;      // the first joint of a foot with a toe (contacts.h), pitched (above): its side
    int pitched_with = -1;  // a driven ball of the foot, turned with its foot: the side
    bool spine_turned = false;  // starts a segment of the spine chain: turned by T(t) (above)
  };

  struct SpineLink {
    int source_from, source_to;  // source joints of the segment
    double target_length;        // L_k, the target's rest chord
  };

  struct BranchChord {
    int from, to;                       // source joints
    Eigen::Vector3d aligned_direction;  // u^al, world
  };

  struct Workspace;  // one run's buffers (transfer.cpp)

  void make_rules(const std::vector<RigidTransform<double>>& rest);
  std::vector<int> placement_order() const;
  void make_placement(std::vector<int> order);
  std::vector<int> source_joints_to_pose() const;

  void check_source(const Clip& source, const FootContacts& contacts) const;
  Clip empty_output(const Clip& source) const;
  void pose_source(const Clip& source, int frame, Workspace& work) const;
  void place_target(const Feet& source_feet, const Eigen::Quaterniond& pelvis_roll, std::optional<double> floor_offset, Workspace& work) const;
  static std::vector<Eigen::Quaterniond> pelvis_rolls(const std::vector<double>& gaps, const std::vector<Eigen::Vector3d>& hip_chords,
                                                      const FootContacts& contacts, double fps);
  Eigen::Quaterniond driven_rotation(int joint, const Workspace& work) const;
  Eigen::Quaterniond exact_rotation(int joint, const Workspace& work) const;
  void write_frame(int frame, const Workspace& work, Clip& out) const;
  void measure_feet(int frame, const Feet& source_feet, Workspace& work) const;
  void move_root(const Workspace& work, const FootContacts& contacts, TransferResult& result) const;

  const RetargetRig& rig_;
  Feet target_feet_;
  std::vector<JointRule> rules_;
  std::vector<BranchChord> branch_chords_;
  std::vector<SpineLink> spine_chain_;  // empty: no turn (rig.h: spine_chain)
  std::vector<Eigen::Quaterniond> rest_rotation_;  // W^rest of every target joint
  // The target's positions as forward kinematics: a joint hangs from its parent, an attached one
  // (followers too) from its anchor A, the root from nothing, each after what it hangs from and
  // its anchor in `order`; every rotation but a rest one below a parent is held in world.
  KinematicModel placement_;
  std::vector<int> translated_joints_;  // output clip's animated translations, ascending
  int root_ = 0;                        // the target joint placed by the pelvis (transfer.h)
  int root_track_ = 0;                  // index of the root in translated_joints_
  Eigen::Vector3d root_to_pelvis_;      // W^rest(root)^-1 (P^rest(pelvis) - P^rest(root))
  std::vector<int> source_needed_;      // source joints to pose each frame, parents first
  Eigen::Vector3d target_rest_pelvis_;
  int pelvis_ = -1, left_hip_ = -1, right_hip_ = -1;  // target joints; no roll without both hips
};

}  // namespace odyssey::retarget
