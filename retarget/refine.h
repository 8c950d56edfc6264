// Refinement of a transferred clip with Ceres: qualities `balanced` (frame by frame) and
// `accurate` (space-time). It starts from a RetargetResult of quality `fast` (retarget.h),
// the reference below, and replaces result.transfer.clip and result.report.result_metrics.
// What the options do for a user, and what they trade, is in docs/retargeting.md.
//
// Unknowns. Per frame: the local rotation q_j of every target joint that starts a chain bone of
// the body (rig.h: a non-degenerate segment whose start starts no other; hips, knees, ankles,
// spine joints, neck, collars, shoulders, elbows, wrists) below the pelvis, a displacement dp
// of the pelvis in world (the root's translation moves by dp), and a turn r of the pelvis (its
// world rotation is the reference's times r). The turn lets the hips roll level when both feet
// are planted: a rig whose hip width and leg length are not the performer's in one ratio would
// otherwise bend a near-straight leg to plant its second foot. Other branch joints (a chest with
// neck and shoulders) keep the transferred rotation; so do fingers, the head's children and every
// unmapped joint (they ride on their parents). Joints the transfer places rigidly with another
// (followers, a thumb hung from the forearm: transfer.h) move with it again. IK-style effectors
// (a detached segment's end outside the pelvis's subtree, as RobotExpressive's feet under the
// root bone) are not placed where the transfer put them (the scaled source ankle) but at the end
// of their segment, the rest chord carried by the start joint (the knee): positions drive the leg
// that carries them.
//
// Residuals of frame t (p_T, W_T: target world positions and rotations from forward kinematics
// of the unknowns; p_S: the levelled source, contacts.h; s the rig's scale; q_ref, p_ref the
// reference; L = 1.7 m / the target's height (rig.h), so that lengths weigh the same on a 5 cm
// figure as on a 50 m one: length weights are per metre of a 1.7 m tall character):
//
//   bone direction   w_dir ( unit(p_T(c) - p_T(a)) - unit(p_S(S(c)) - p_S(S(a))) )
//                    every chain bone (a, c) whose direction depends on an unknown; for a
//                    detached target segment (rig.h) the target direction is W_T(a) times the
//                    rest chord in a's frame, as metrics.h measures it; a foot segment (ankle ->
//                    ball of the foot) is aimed at the reference's direction instead, which the
//                    transfer pitched to the floor (transfer.h), and so is a segment of the
//                    spine chain (rig.h), whose bend the transfer shared between the torso and
//                    its segments
//   end effector     w_ee L ( (p_T(e) - p_T(pelvis)) - s (p_S(e) - p_S(pelvis)) ),  e = head,
//                    wrists, ankles
//   foot contact     w_foot L ( p_T(k) - D(t) ),  when the foot plan below places a point k
//   floor            w_floor L max(0, g_k - z_T(k)),  every foot joint k, every frame
//   pose             w_pose 2 vec( q_ref,j^-1 q_j ),  sign taken so the scalar part is >= 0
//   pelvis           w_pelvis L ( dp - dp_plan(t) )
//   pelvis turn      w_turn 2 vec( r ),  sign taken so the scalar part is >= 0
//   (balanced) lag   w_lag L sqrt(fps) ( c(t) - c(t-1) ),  horizontal, c = dp - dp_plan, c(t-1)
//                    the frame solved before; each window starts 0.25 s early (frames it
//                    discards) so that its first frame's lag has settled and windows meet
//                    without a step (tests/test_extremes.cpp)
//   (accurate only)  w_smooth fps^2 ( c_j(t+1) - 2 c_j(t) + c_j(t-1) ),  c_j = q_ref,j^-1 q_j,
//                    the leg joints' corrections and the turn r (quaternion components), and
//                    w_pelvis_smooth L fps^2 ( dp(t+1) - 2 dp(t) + dp(t-1) ),
//                    each through a Cauchy loss (below)
//
// A unit-vector difference is about the angle in radians: with w_dir = 1, a weight w on a
// length term says that 1 m (of a 1.7 m character) costs as much as w radians of direction.
// End effectors against the height-scaled source mostly measure how the rigs' proportions differ,
// even with every bone exact, so the default keeps that term a tie-breaker. The contact weight
// trades the legs against the floor where the rig's foot cannot follow both.
//
// The lag. Solved frame by frame, dp is wherever this frame's contacts put it, and the
// reference's planted feet slide a little each frame where the rigs' feet differ, so dp would
// jump at each handoff between planted feet. With a per-frame stiffness a of the other terms on
// dp, the lag makes each frame's solution c(t) = alpha y(t) + (1 - alpha) c(t-1), y the lag-free
// solution: an exponential smoother with (1 - alpha) / alpha = w_lag^2 L^2 fps / a frames, a time
// constant of about w_lag^2 L^2 / a seconds at any frame rate (hence sqrt(fps)). Horizontal only:
// lagging the height would lift planted feet off the floor. First order on purpose: the same term
// on the acceleration, against 2 c(t-1) - c(t-2), is an underdamped second-order filter whose
// damping falls with the frame rate. accurate's space-time problem smooths dp itself, and its
// first pass runs without the lag by default.
//
// Smoothing the corrections rather than the rotations themselves leaves the performer's motion
// (and its capture noise) as it was: smoothing local rotations fights the capture, whose root
// noise the legs compensate, and makes the pelvis shake to keep the feet planted; what the
// refinement adds (contacts switching, per-frame solves) is what is smoothed.
//
// The plan, fixed before solving (refine_model.h: plan_motion):
// - Stride and height. The target's legs need not be s times the source's, so with every leg
//   bone along the source's a planted foot would slide by that share of each stride. The stride
//   factor k is fitted so that moving the body by (k - 1) times the pelvis's horizontal travel
//   best stills the reference's planted feet (least squares, ridge-regularised, within [0.5, 2]),
//   and the height h is the median over planted frames of the support joint's height; then
//   dp_plan(t) = ((k - 1) (P_ref(t) - P_ref(0)) horizontally, h) (`fit_stride` off: k = 1).
// - Feet. Feet are the points contacts.h names (ankle, ball of the foot, the toe from the mesh)
//   with the target's ground heights g_k; the floor is z = 0. During a source contact (a maximal
//   run of planted frames) the foot's support point k(t), its lowest point in the reference
//   (lowest_foot_point), is held at D(t) = (anchor_x, anchor_y, g_k): on the floor, still. When
//   the support passes to another point (heel strike -> flat -> toe-off) the anchor passes with
//   it, shifted by the reference's vector between the two at that frame, so the foot rolls over
//   the point that holds without a jump. The anchor is the mean over the whole contact of where
//   the reference (moved by dp_plan) has the support point, each frame's shifted back to the
//   first point by those switches (the least-squares anchor). Around a contact the correction fades in and out over
//   `contact_blend_seconds` (smoothstep u from 1 to 0): the boundary's support point is wanted at
//   p_ref + u (dp_plan + o) + (1 - u) dp, passing from its anchor to moving with the body;
//   contacts closer than two fades hand the correction from one to the next across the gap. The
//   toe is placed through the foot's first joint, rigid with it (p + W toe). A foot of one joint
//   without a toe (no mesh to find it on) is held flat while planted (its rest rotation turned
//   about z as the reference turns).
// - Lift (`contact_lift` d, 3 cm by default). A performer's foot is planted while its lowest point
//   is within 5 cm of the floor (contacts.h), and at toe-off the heel rises well before that ends.
//   Held on the floor through it, the target's heel would bend both legs. With d set, the support
//   joint k is wanted at g_k + s e(c_S(t) - d) instead of g_k: c_S the clearance of the
//   performer's joint that k corresponds to (ankle, ball of the foot; a toe takes the ball's), s
//   the rig's scale, e() a ramp eased over 2 cm (0 below -1 cm, x above +1 cm, (x + 1 cm)^2 / 4 cm
//   between). Where the support passes to another joint, the height the old target implies for the
//   new one, where it is above the new one's own, is carried to the end of the contact: the foot
//   pivots on the new joint where it stands.
//
// Solvers.
// - balanced: frame by frame, one small problem per limb with ceres::TinySolver and automatic
//   derivatives (fixed parameter counts, buffers reused: no allocation per solve); rotations as
//   q = q0 q(x), q(x) the rotation by the vector x (EigenQuaternionManifold's chart). The lower
//   body (dp, the turn and both legs, up to 24 unknowns) first, then the spine (chain joints and
//   neck, without the arms' end-effector terms), then each arm with the solved spine held. The
//   lower body's residuals do not read the upper body's unknowns, so that split is exact. Each frame
//   warm-starts from the previous one (its corrections q_ref^-1 q, dp - dp_plan and the turn
//   carried onto this frame); each window of `window_frames` starts from the reference, at its
//   first frame or, with the lag, 0.25 s before it (those frames are solved and discarded).
// - accurate: the balanced solution, then the lower body as a space-time problem: one
//   ceres::Problem over every frame's dp and leg rotations (EigenQuaternionManifold) of a span of
//   up to `span_frames` frames (the whole of most clips), with the limb residuals and the
//   smoothness terms, solved with SPARSE_NORMAL_CHOLESKY (the second differences make the system
//   banded in time) for at most `span_iterations` iterations. A longer clip is solved span after
//   span: each span also solves the `span_lookahead` frames after it, which the next solves again,
//   and holds the two frames before it at the solution so far, so the accelerations across a cut
//   are terms of its problem and nothing is cross-faded. The upper body keeps its balanced
//   solution (its first joints turned against the change of the pelvis's turn, so that their
//   world rotations stay): its residuals read neither dp nor the legs and its corrections (end
//   effectors against directions, no contacts) change smoothly; leaving it out makes the problem
//   several times cheaper. The smoothness residuals pass through Cauchy losses
//   rho(s) = b^2 log(1 + s / b^2) with b at `smoothness_limit` and `pelvis_smoothness_limit`:
//   quadratic for accelerations below, nearly flat far above, so a genuine jump (the T-pose
//   reference frame that opens CMU files) is left alone instead of being smeared over its
//   neighbours.
// Balanced windows are solved in parallel (options.threads), each from data no other window
// writes, and cut at fixed frames whatever the thread count; the spans are solved in turn on one
// thread: threads change the speed, not the result.
#pragma once

#include <optional>
#include <span>
#include <string_view>

#include "retarget/retarget.h"

namespace odyssey::retarget {

enum class Quality { fast, balanced, accurate };
std::optional<Quality> parse_quality(std::string_view text);
const char* quality_name(Quality quality);

// The weights of the residuals above (lengths: per metre of a 1.7 m tall character).
struct RefineWeights {
  double bone_direction = 1.0;     // w_dir, per unit-vector difference (about radians)
  double end_effector = 0.05;      // w_ee, per metre: a tie-breaker (above)
  double foot_contact = 6.0;       // w_foot, per metre: 1 cm off costs as 3.4 degrees (above)
  double floor = 30.0;             // w_floor, per metre below the floor
  double pose = 0.05;              // w_pose, per radian: settles the twist directions leave free
  double pelvis = 1.0;             // w_pelvis, per metre from dp_plan
  double pelvis_turn = 1.0;        // w_turn, per radian of the pelvis's turn (FramePose)
  double smoothness = 0.0;         // w_smooth, per rad/s^2 (accurate)
  double pelvis_smoothness = 0.0;  // w_pelvis_smooth, per m/s^2 (accurate)
  double pelvis_lag = 0.5;         // w_lag, per metre the correction moves in a frame, times sqrt(fps) (balanced)
};

struct RefineOptions {
  Quality quality = Quality::balanced;
  RefineWeights weights;
  double contact_blend_seconds = 0.1;     // fade of a foot correction into and out of a contact
  // m, at the performer's size: a planted foot's support joint rises with the performer's
  // corresponding joint once that is more than this above its ground height (the foot plan above).
  // Off (nullopt): the support joint is held on the floor through the whole contact.
  std::optional<double> contact_lift = 0.03;
  int window_frames = 64;                 // balanced: frames of one warm-start run
  int span_frames = 1024;                 // accurate: frames one space-time problem keeps
  int span_lookahead = 32;                // accurate: frames after a span it solves too
  int max_iterations = 50;                // per limb and frame (most converge in 2 to 4)
  int span_iterations = 10;               // accurate: per span, from the balanced solution
  double smoothness_limit = 300;          // rad/s^2, the Cauchy scale b of the rotation smoothness
  double pelvis_smoothness_limit = 20;    // m/s^2 (1.7 m character), that of the pelvis smoothness
  bool warm_start = true;                 // balanced: start each frame from the previous one
  bool fit_stride = true;                 // fit the stride factor k (above); false: k = 1
  int threads = 1;                        // balanced windows solved in parallel
};

// Defaults per quality (fast: nothing to refine):
//   balanced: the weights above, windows of 64 frames;
//   accurate: no lag, foot contact 12 per m (at 6 its smoothness lets planted feet lift and
//   slide), smoothness 0.0001 per rad/s^2 and pelvis smoothness 0.01 per m/s^2, spans of 1,024
//   frames with 32 frames of lookahead. The rotation smoothness fights the contacts: a planted
//   foot's correction must cancel the performer's leg noise, whose acceleration grows with the
//   frame rate squared, so a higher weight is rougher at high frame rates (docs/retargeting.md).
RefineOptions default_refine_options(Quality quality);

// The weights by the names that command lines, scene files and reports use ("bone_direction",
// "end_effector", "foot_contact", "floor", "pose", "pelvis", "pelvis_turn", "smoothness",
// "pelvis_smoothness", "pelvis_lag").
struct RefineWeightName {
  const char* name;
  double RefineWeights::*weight;
};
std::span<const RefineWeightName> refine_weight_names();
// The weight called `name`, or nullptr for an unknown name.
double* refine_weight(RefineWeights& weights, std::string_view name);

struct RefineSummary {
  double seconds = 0;        // wall clock, all of refine() (plan, solvers, metrics)
  double solve_seconds = 0;  // the solvers alone (balanced pass and accurate spans)
  int frames = 0;
  int windows = 0;           // balanced windows
  int spans = 0;             // accurate spans
  long iterations = 0;       // solver iterations, summed over problems
  int unknown_joints = 0;
  double stride = 1;         // the stride factor k
  double height = 0;         // the plan's height h, m
};

// Refines result.transfer.clip in place and recomputes result.report.result_metrics (and sets
// report.quality; the CLI times the call). `source` is the clip the result was transferred from.
// Quality fast leaves the result as it is. Throws std::invalid_argument when the source is not the
// result's (skeleton, frame count), or an option is out of range (threads, window and span sizes,
// iterations, negative or non-finite weights, limits).
RefineSummary refine(RetargetResult& result, const Clip& source, const RefineOptions& options);

}  // namespace odyssey::retarget
