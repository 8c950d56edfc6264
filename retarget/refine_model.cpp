// GCC 12 reports -Wmaybe-uninitialized inside its own AVX-512 intrinsics when Eigen's matrix
// products (TinySolver's J^T J) are inlined here (GCC bug 105593, fixed in GCC 13); the
// diagnostic is tied to where the intrinsics are first included, so it is silenced for those
// headers only, as in skeleton/body_model.cpp.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <Eigen/Core>
#pragma GCC diagnostic pop

#include "retarget/refine_model.h"

#include <algorithm>
#include <cstdint>
#include <optional>
#include <span>
#include <stdexcept>


namespace odyssey::retarget::refinement {

namespace {

// The limbs, in the order the balanced solver takes them.
enum LimbGroup { lower_body = 0, spine = 1, left_arm = 2, right_arm = 3, group_count = 4 };
constexpr const char* kLimbNames[group_count] = {"lower body", "spine", "left arm", "right arm"};

int limb_group(int canonical_joint) {
  const std::string_view limb = canonical_limb(canonical_joint);
  if (limb == "left_leg" || limb == "right_leg") return lower_body;
  if (limb == "left_arm") return left_arm;
  if (limb == "right_arm") return right_arm;
  return spine;  // spine joints, neck, head
}

using Mask = std::uint64_t;  // a set of unknowns (a body has at most 21)

// Placements, as the transfer decides them (above), with the root above the pelvis.
void decide_placements(const RetargetRig& rig, const std::vector<RigidTransform<double>>& rest, RefineModel& model) {
  const Skeleton& target = rig.target;
  const int n = target.joint_count();
  model.placement.assign(n, Placement::child);
  model.anchor.assign(n, -1);
  model.chain_end_offset.assign(n, Eigen::Vector3d::Zero());
  for (const Segment& segment : rig.segments) {
    if (segment.target_attached) continue;
    const int a = segment.target_start, j = segment.target_end;
    model.anchor[j] = a;
    if (is_ancestor(target, model.pelvis, j)) {
      model.placement[j] = Placement::attached;
    } else {
      model.placement[j] = Placement::chain_end;
      model.chain_end_offset[j] = rest[a].rotation.transpose() * (rest[j].translation - rest[a].translation);
    }
  }
  for (const BoneMap::Follower& follower : rig.target_map.followers) {
    const int anchor = rig.target_joint(follower.canonical);
    if (anchor < 0) continue;
    model.placement[follower.joint] = Placement::rigid;
    model.anchor[follower.joint] = anchor;
  }
  model.placement[model.root] = Placement::root;
  model.anchor[model.root] = -1;
}

// The placement tree: every joint hung from its parent (child) or its anchor (the others; none for
// the root), in an order that places a joint after both its parent and its anchor (depth-first
// over the two; the transfer has already refused cycles).
KinematicModel placement_tree(const RefineModel& model, const Skeleton& target) {
  const int n = target.joint_count();
  std::vector<int> order;
  std::vector<std::uint8_t> placed(n, 0);
  for (int start = 0; start < n; ++start) {
    std::vector<int> stack{start};
    while (!stack.empty()) {
      const int j = stack.back();
      if (placed[j]) {
        stack.pop_back();
        continue;
      }
      bool ready = true;
      for (int dependency : {target.parent(j), model.anchor[j]}) {
        if (dependency >= 0 && !placed[dependency]) {
          if (stack.size() > static_cast<std::size_t>(n)) throw std::invalid_argument("the target's placements form a cycle");
          stack.push_back(dependency);
          ready = false;
        }
      }
      if (!ready) continue;
      placed[j] = 1;
      order.push_back(j);
      stack.pop_back();
    }
  }
  std::vector<int> hung_from(n);
  std::vector<std::uint8_t> rotation_in_world(n);
  for (int j = 0; j < n; ++j) {
    const Placement kind = model.placement[j];
    hung_from[j] = kind == Placement::child ? target.parent(j) : model.anchor[j];
    rotation_in_world[j] = kind == Placement::attached || kind == Placement::chain_end;
  }
  return KinematicModel(std::move(hung_from), {}, std::move(order), std::move(rotation_in_world));
}

// The unknowns (refine.h): the start joints of the body's chain bones below the pelvis, placed
// as children. Returns the limb group of each.
std::vector<int> choose_unknowns(const RetargetRig& rig, RefineModel& model) {
  const Skeleton& target = rig.target;
  model.unknown_of.assign(target.joint_count(), -1);
  for (const Segment& segment : rig.segments) {
    const int c = segment.canonical_start;
    const int j = segment.target_start;
    if (segment.degenerate || segment.branch || c == canonical::pelvis || c > canonical::right_wrist) continue;
    if (j == model.pelvis || model.placement[j] != Placement::child || !is_ancestor(target, model.pelvis, j)) continue;
    model.unknown_joints.push_back(j);
  }
  std::sort(model.unknown_joints.begin(), model.unknown_joints.end());
  model.unknown_joints.erase(std::unique(model.unknown_joints.begin(), model.unknown_joints.end()), model.unknown_joints.end());
  std::vector<int> group_of_unknown;
  for (std::size_t u = 0; u < model.unknown_joints.size(); ++u) {
    const int j = model.unknown_joints[u];
    model.unknown_of[j] = static_cast<int>(u);
    group_of_unknown.push_back(limb_group(rig.target_map.canonical_of(j)));
  }
  return group_of_unknown;
}

// Which joints the placement tree reaches from the pelvis, and the unknowns their position and
// rotation depend on: a joint's position depends on what its parent's position and rotation do,
// its rotation on its parent's (unless held in world) and on its own unknown.
struct Dependencies {
  std::vector<std::uint8_t> reachable;
  std::vector<Mask> position, rotation;

  explicit Dependencies(const RefineModel& model) {
    const int n = model.kinematics.joint_count();
    reachable.assign(n, 0);
    position.assign(n, 0);
    rotation.assign(n, 0);
    reachable[model.pelvis] = 1;
    for (int j : model.kinematics.order) {
      const int from = model.kinematics.parents[j];
      if (j == model.pelvis || from < 0 || !reachable[from]) continue;
      reachable[j] = 1;
      position[j] = position[from] | rotation[from];
      if (model.placement[j] == Placement::child) {
        rotation[j] = rotation[from] | (model.unknown_of[j] >= 0 ? Mask(1) << model.unknown_of[j] : 0);
      } else if (model.placement[j] == Placement::rigid) {
        rotation[j] = rotation[from];
      }
    }
  }
  // Whether a limb can read every one of `joints` (the pelvis itself is the limb's base).
  bool all_reachable(const std::vector<int>& joints, int pelvis) const {
    return std::all_of(joints.begin(), joints.end(), [&](int j) { return reachable[j] && j != pelvis; });
  }
};

// A residual before it is given to a limb: the term (of its kind; node indices still unset), the
// target joints it reads positions or rotations of, and the unknowns it depends on.
struct PendingTerm {
  enum class Kind { direction, effector, foot } kind;
  DirectionTerm direction;
  EffectorTerm effector;
  FootTerm foot;
  std::vector<int> joints;
  Mask mask = 0;
};

// The residuals (refine.h) that depend on at least one unknown: chain bone directions (and
// spine continuations), end effectors, feet.
std::vector<PendingTerm> residual_terms(const RetargetRig& rig, const RefineModel& model,
                                        const std::vector<RigidTransform<double>>& rest, const Dependencies& depends) {
  std::vector<PendingTerm> pending;
  const std::vector<const Segment*> spine = spine_chain(rig);
  for (const Segment& segment : rig.segments) {
    if (segment.degenerate || (segment.branch && !segment.spine_continuation)) continue;
    PendingTerm term{PendingTerm::Kind::direction, {}, {}, {}, {segment.target_start}, 0};
    term.direction.source_from = segment.source_start;
    term.direction.source_to = segment.source_end;
    term.direction.from_reference = segment.foot() || std::find(spine.begin(), spine.end(), &segment) != spine.end();
    const int a = segment.target_start;
    if (segment.target_attached) {
      term.joints.push_back(segment.target_end);
      if (!depends.all_reachable(term.joints, model.pelvis)) continue;
      term.mask = depends.position[a] | depends.position[segment.target_end];
    } else {
      if (!depends.all_reachable(term.joints, model.pelvis)) continue;
      term.direction.rest_chord =
          (rest[a].rotation.transpose() * (rest[segment.target_end].translation - rest[a].translation)).normalized();
      term.mask = depends.rotation[a];
    }
    if (term.mask != 0) pending.push_back(std::move(term));
  }
  for (int c : {canonical::head, canonical::left_wrist, canonical::right_wrist, canonical::left_ankle, canonical::right_ankle}) {
    if (!rig.source_map.mapped(c) || !rig.target_map.mapped(c)) continue;
    const int j = rig.target_joint(c);
    if (!depends.all_reachable({j}, model.pelvis) || depends.position[j] == 0) continue;
    pending.push_back({PendingTerm::Kind::effector, {}, {-1, rig.source_joint(c)}, {}, {j}, depends.position[j]});
  }
  for (int side = 0; side < 2; ++side) {
    const Foot& foot = model.feet[side];
    if (!depends.all_reachable(foot.joints, model.pelvis)) continue;
    Mask mask = 0;
    for (int j : foot.joints) mask |= depends.position[j];
    pending.push_back(
        {PendingTerm::Kind::foot, {}, {}, {side, {}, foot.ground_heights, foot.has_toe, foot.toe, foot.toe_ground_height}, foot.joints, mask});
  }
  return pending;
}

// The limb's nodes: every joint on the way from the pelvis to what its residuals and owned slots
// read, in placement order, as a tree hanging from the pelvis; the slots of unknowns it reads but
// does not own are added after the owned ones. Returns each joint's node (-1 none).
std::vector<int> add_nodes(const RefineModel& model, const std::vector<const PendingTerm*>& terms, const Dependencies& depends,
                           Mask owned_mask, Limb& limb) {
  const KinematicModel& tree = model.kinematics;
  const int n = tree.joint_count();
  std::vector<std::uint8_t> needed(n, 0);
  const auto need = [&](int j) {
    for (; j >= 0 && j != model.pelvis && !needed[j]; j = tree.parents[j]) needed[j] = 1;
  };
  for (const PendingTerm* term : terms) {
    for (int j : term->joints) need(j);
  }
  for (int s = 0; s < limb.owned; ++s) need(model.unknown_joints[limb.slots[s]]);
  std::vector<int> node_of(n, -1);
  std::vector<int> node_parents;
  std::vector<std::uint8_t> rotation_in_world;
  for (int j : tree.order) {
    if (!needed[j]) continue;
    const int node = static_cast<int>(limb.nodes.size());
    node_of[j] = node;
    LimbNode entry{j, -1};
    const int u = model.unknown_of[j];
    if (model.placement[j] == Placement::child && u >= 0) {
      const auto slot = std::find(limb.slots.begin(), limb.slots.end(), u);
      entry.slot = static_cast<int>(slot - limb.slots.begin());
      if (slot == limb.slots.end()) limb.slots.push_back(u);
    }
    limb.nodes.push_back(entry);
    node_parents.push_back(tree.parents[j] == model.pelvis ? -1 : node_of[tree.parents[j]]);
    rotation_in_world.push_back(tree.rotation_in_world[j]);
    const bool moving = limb.moves_pelvis || ((depends.position[j] | depends.rotation[j]) & owned_mask) != 0;
    (moving ? limb.moving_nodes : limb.fixed_nodes).push_back(node);
  }
  limb.kinematics = KinematicModel(std::move(node_parents), {}, {}, std::move(rotation_in_world));
  limb.slot_nodes.resize(limb.slots.size());
  for (std::size_t node = 0; node < limb.nodes.size(); ++node) {
    if (limb.nodes[node].slot >= 0) limb.slot_nodes[limb.nodes[node].slot] = static_cast<int>(node);
  }
  return node_of;
}

// The residuals, their joints turned into the limb's nodes.
void add_terms(const std::vector<const PendingTerm*>& terms, const std::vector<int>& node_of, Limb& limb) {
  for (const PendingTerm* term : terms) {
    switch (term->kind) {
      case PendingTerm::Kind::direction: {
        DirectionTerm direction = term->direction;
        direction.from = node_of[term->joints[0]];
        direction.to = term->joints.size() > 1 ? node_of[term->joints[1]] : -1;
        limb.directions.push_back(direction);
        break;
      }
      case PendingTerm::Kind::effector: {
        EffectorTerm effector = term->effector;
        effector.node = node_of[term->joints[0]];
        limb.effectors.push_back(effector);
        break;
      }
      case PendingTerm::Kind::foot: {
        FootTerm foot = term->foot;
        for (int j : term->joints) foot.nodes.push_back(node_of[j]);
        limb.feet.push_back(foot);
        break;
      }
    }
  }
}

// The limb of one group: its unknowns (owned slots), the residuals that go to it (each to the last
// limb in solve order among those owning an unknown it depends on; feet, which also depend on dp,
// at least to the lower body), and the nodes they read. None when it has neither.
std::optional<Limb> build_limb(int group, const RefineModel& model, const std::vector<int>& group_of_unknown,
                               const std::vector<PendingTerm>& pending, const Dependencies& depends) {
  Limb limb;
  limb.name = kLimbNames[group];
  limb.moves_pelvis = group == lower_body;
  limb.length_scale = model.length_scale;
  Mask owned_mask = 0;
  for (std::size_t u = 0; u < model.unknown_joints.size(); ++u) {
    if (group_of_unknown[u] == group) {
      limb.slots.push_back(static_cast<int>(u));
      owned_mask |= Mask(1) << u;
    }
  }
  limb.owned = static_cast<int>(limb.slots.size());
  std::vector<const PendingTerm*> terms;
  for (const PendingTerm& term : pending) {
    int last = lower_body;
    for (std::size_t u = 0; u < model.unknown_joints.size(); ++u) {
      if (term.mask & (Mask(1) << u)) last = std::max(last, group_of_unknown[u]);
    }
    if (last == group) terms.push_back(&term);
  }
  if (terms.empty() && limb.owned == 0) return std::nullopt;
  const std::vector<int> node_of = add_nodes(model, terms, depends, owned_mask, limb);
  add_terms(terms, node_of, limb);
  return limb;
}

// A foot's points (contacts.h: its joints, then a one-joint foot's toe) frame by frame:
// points[k][frame].
using FootPaths = std::vector<std::vector<Eigen::Vector3d>>;

// The point of a foot lowest above its own ground height in frame f: the one that supports it.
int support_point(const Foot& foot, const FootPaths& points, int f) {
  int lowest = 0;
  for (int k = 1; k < foot.point_count(); ++k) {
    if (points[k][f].z() - foot.point_ground_height(k) < points[lowest][f].z() - foot.point_ground_height(lowest)) lowest = k;
  }
  return lowest;
}

// The reference's pelvis and both feet's points, frame by frame, and the source's foot joints'
// clearances (above their ground heights, at the performer's size): clearance[side][joint][frame].
struct ReferencePaths {
  std::vector<Eigen::Vector3d> pelvis;
  std::array<FootPaths, 2> feet;
  std::array<std::vector<std::vector<double>>, 2> source_clearance;
};

ReferencePaths reference_paths(const RefineModel& model, FrameBuilder& builder, const Feet& source_feet, int frames) {
  ReferencePaths paths;
  paths.pelvis.resize(frames);
  for (int side = 0; side < 2; ++side) {
    paths.feet[side].assign(model.feet[side].point_count(), std::vector<Eigen::Vector3d>(frames));
    paths.source_clearance[side].assign(source_feet[side].joints.size(), std::vector<double>(frames));
  }
  for (int f = 0; f < frames; ++f) {
    builder.load(f);
    paths.pelvis[f] = builder.reference_position(model.pelvis);
    for (int side = 0; side < 2; ++side) {
      const Foot& foot = model.feet[side];
      FootPaths& points = paths.feet[side];
      for (int k = 0; k < foot.point_count(); ++k) points[k][f] = builder.reference_point(foot, k);
      const Foot& source = source_feet[side];
      for (std::size_t j = 0; j < source.joints.size(); ++j) {
        paths.source_clearance[side][j][f] = builder.source_position(source.joints[j]).z() - source.ground_heights[j];
      }
    }
  }
  return paths;
}

// The stride factor k: moving the body by (k - 1) times the pelvis's horizontal travel changes a
// planted foot's step v_f by (k - 1) v_p, so k - 1 = -sum v_f . v_p / (sum |v_p|^2 + ridge) over
// the steps with the foot planted at both ends; the ridge, worth the pelvis moving 5 cm/s (for a
// 1.7 m character) in every such step, keeps k at 1 when the body hardly travels. k is kept
// within [0.5, 2].
double fit_stride(const RefineModel& model, const ReferencePaths& paths, const FootContacts& contacts, double fps) {
  const int frames = contacts.frame_count();
  double along = 0, travel = 0;
  long steps = 0;
  for (int side = 0; side < 2; ++side) {
    const std::vector<std::uint8_t>& planted = contacts.planted[side];
    for (int f = 0; f + 1 < frames; ++f) {
      if (!planted[f] || !planted[f + 1]) continue;
      const int k = support_point(model.feet[side], paths.feet[side], f);
      const Eigen::Vector2d foot_step = (paths.feet[side][k][f + 1] - paths.feet[side][k][f]).head<2>();
      const Eigen::Vector2d pelvis_step = (paths.pelvis[f + 1] - paths.pelvis[f]).head<2>();
      along += foot_step.dot(pelvis_step);
      travel += pelvis_step.squaredNorm();
      ++steps;
    }
  }
  const double ridge_step = 0.05 / model.length_scale / fps;
  return steps > 0 ? std::clamp(1.0 - along / (travel + steps * ridge_step * ridge_step), 0.5, 2.0) : 1.0;
}

// The height h: the median, over the planted frames, of how far the reference's support point is
// above the floor (the transfer's floor offset was fitted to where it placed the feet; an IK foot
// at the end of its shin may stand elsewhere). 0 without a planted frame.
double planted_height(const RefineModel& model, const ReferencePaths& paths, const FootContacts& contacts) {
  std::vector<double> heights;
  for (int side = 0; side < 2; ++side) {
    for (int f = 0; f < contacts.frame_count(); ++f) {
      if (!contacts.planted[side][f]) continue;
      const int k = support_point(model.feet[side], paths.feet[side], f);
      heights.push_back(model.feet[side].point_ground_height(k) - paths.feet[side][k][f].z());
    }
  }
  if (heights.empty()) return 0;
  const auto middle = heights.begin() + static_cast<std::ptrdiff_t>(heights.size() / 2);
  std::nth_element(heights.begin(), middle, heights.end());
  return *middle;
}

// Maximal runs of planted frames, [first, last].
std::vector<std::pair<int, int>> contact_runs(const std::vector<std::uint8_t>& planted) {
  std::vector<std::pair<int, int>> runs;
  for (int f = 0; f < static_cast<int>(planted.size()); ++f) {
    if (!planted[f]) continue;
    if (!runs.empty() && runs.back().second == f - 1) {
      runs.back().second = f;
    } else {
      runs.push_back({f, f});
    }
  }
  return runs;
}

// How high each point of a target foot should stand above its ground height, frame by frame
// (lift[k][frame]): s e(c_S - d), the lift of refine.h, from the clearance of the performer's joint
// the point corresponds to (`source_clearance`, ReferencePaths; a toe takes the ball of the
// foot's). Empty when `contact_lift` is off.
std::vector<std::vector<double>> foot_lift(const Foot& foot, const std::vector<std::vector<double>>& source_clearance,
                                           double scale, std::optional<double> contact_lift) {
  constexpr double kEase = 0.02;  // m, the width of the ramp's eased knee
  if (!contact_lift) return {};
  std::vector<std::vector<double>> lift(foot.point_count());
  for (int k = 0; k < foot.point_count(); ++k) {
    const std::vector<double>& clearance = source_clearance[std::min<std::size_t>(k, source_clearance.size() - 1)];
    lift[k].reserve(clearance.size());
    for (const double c : clearance) {
      const double x = c - *contact_lift;
      const double eased = x <= -kEase / 2 ? 0.0 : x >= kEase / 2 ? x : (x + kEase / 2) * (x + kEase / 2) / (2 * kEase);
      lift[k].push_back(scale * eased);
    }
  }
  return lift;
}

// One foot's plan (FootPlan) in its contacts, from its points on the reference moved by dp_plan
// (`at`): the support point held at its anchor, on the floor or, with `lift` (foot_lift; empty:
// none), lifted. Returns o(t), the correction that takes it there (zero outside contacts).
std::vector<Eigen::Vector3d> hold_contacts(const Foot& foot, const FootPaths& at, const std::vector<std::pair<int, int>>& runs,
                                           const std::vector<Eigen::Vector3d>& pelvis_offset,
                                           const std::vector<std::vector<double>>& lift, FootPlan& plan) {
  const auto support = [&](int f) { return support_point(foot, at, f); };
  const auto wanted_height = [&](int k, int f) { return foot.point_ground_height(k) + (lift.empty() ? 0.0 : lift[k][f]); };
  std::vector<Eigen::Vector3d> correction(pelvis_offset.size(), Eigen::Vector3d::Zero());
  for (const auto& [first, last] : runs) {
    // The anchor: the mean horizontal position over the whole contact of the support point, each
    // frame's brought back to the first point by the offsets at the switches before it (the least
    // squares anchor for the contact); when the support passes to another point, the anchor
    // passes with it by their offset. With a lift, so does the height: what the old point's target
    // implies for the new one (rigid with it in this frame) less the new one's own is carried to the
    // end of the contact, so the new point pivots where it stands instead of stepping down while the
    // performer's foot rises. Never below the new point's own: that would push it into the floor
    // (RobotExpressive's toe, 0.2-0.3 cm on average over its planted frames of the SMPL-X walk).
    int k = support(first);
    Eigen::Vector2d anchor = Eigen::Vector2d::Zero(), switched = Eigen::Vector2d::Zero();
    for (int f = first, held = k; f <= last; ++f) {
      const int now = support(f);
      switched += (at[now][f] - at[held][f]).head<2>();
      held = now;
      anchor += at[now][f].head<2>() - switched;
    }
    anchor /= last - first + 1;
    double carried = 0;
    for (int f = first; f <= last; ++f) {
      const int now = support(f);
      if (now != k) {
        anchor += (at[now][f] - at[k][f]).head<2>();
        if (!lift.empty()) carried = std::max(0.0, wanted_height(k, f) + (at[now][f].z() - at[k][f].z()) - wanted_height(now, f));
        k = now;
      }
      correction[f] = Eigen::Vector3d(anchor.x(), anchor.y(), wanted_height(k, f) + carried) - at[k][f];
      plan.point[f] = static_cast<std::int8_t>(k);
      plan.offset[f] = pelvis_offset[f] + correction[f];
      plan.follow[f] = 0;
      if (!plan.flat.empty()) plan.flat[f] = 1;
    }
  }
  return correction;
}

// Around contacts the correction fades out and in over `blend_frames` (smoothstep), or passes
// from one contact to the next across a gap shorter than two fades.
void fade_around_contacts(const std::vector<std::pair<int, int>>& runs, const std::vector<Eigen::Vector3d>& correction,
                          const std::vector<Eigen::Vector3d>& pelvis_offset, int blend_frames, FootPlan& plan) {
  const int frames = static_cast<int>(pelvis_offset.size());
  for (std::size_t r = 0; r <= runs.size(); ++r) {
    const bool has_before = r > 0, has_after = r < runs.size();
    const int before = has_before ? runs[r - 1].second : -1;  // last frame of the previous contact
    const int after = has_after ? runs[r].first : frames;     // first frame of the next contact
    if (has_before && has_after && after - before - 1 <= 2 * blend_frames) {
      for (int f = before + 1; f < after; ++f) {
        const double x = static_cast<double>(f - before) / (after - before);
        const double u = smoothstep(x);
        plan.point[f] = x < 0.5 ? plan.point[before] : plan.point[after];
        plan.offset[f] = pelvis_offset[f] + (1 - u) * correction[before] + u * correction[after];
        plan.follow[f] = 0;
        if (!plan.flat.empty()) plan.flat[f] = 1;
      }
      continue;
    }
    const auto fade = [&](int f, int boundary, int distance) {
      const double u = smoothstep(1.0 - static_cast<double>(distance) / (blend_frames + 1));
      plan.point[f] = plan.point[boundary];
      plan.offset[f] = u * (pelvis_offset[f] + correction[boundary]);
      plan.follow[f] = 1 - u;
      if (!plan.flat.empty()) plan.flat[f] = u;
    };
    if (has_before) {
      for (int f = before + 1; f <= std::min(before + blend_frames, after - 1); ++f) fade(f, before, f - before);
    }
    if (has_after) {
      for (int f = std::max(after - blend_frames, before + 1); f < after; ++f) fade(f, after, after - f);
    }
  }
}

}  // namespace

int Limb::residual_count() const {
  int count = 3 * static_cast<int>(directions.size() + effectors.size()) + 3 * owned + (moves_pelvis ? 9 : 0);
  for (const FootTerm& foot : feet) count += 3 + foot.point_count();
  return count;
}

RefineModel build_refine_model(const RetargetResult& result) {
  const RetargetRig& rig = result.rig;
  const Skeleton& target = rig.target;
  const std::vector<RigidTransform<double>> rest = target.rest_world();
  RefineModel model;
  model.scale = rig.scale;
  model.length_scale = kReferenceHeight / rig.target_height;
  model.pelvis = rig.target_joint(canonical::pelvis);
  model.source_pelvis = rig.source_joint(canonical::pelvis);
  model.root = model.pelvis;
  while (target.parent(model.root) >= 0) model.root = target.parent(model.root);
  model.feet = result.target_feet.sides;
  for (const RigidTransform<double>& joint : rest) model.rest_rotation.push_back(Eigen::Quaterniond(joint.rotation).normalized());

  decide_placements(rig, rest, model);
  model.kinematics = placement_tree(model, target);
  const std::vector<int> group_of_unknown = choose_unknowns(rig, model);
  const Dependencies depends(model);
  const std::vector<PendingTerm> pending = residual_terms(rig, model, rest, depends);
  for (int group = 0; group < group_count; ++group) {
    if (std::optional<Limb> limb = build_limb(group, model, group_of_unknown, pending, depends)) model.limbs.push_back(std::move(*limb));
  }
  return model;
}

MotionPlan plan_motion(const RefineModel& model, FrameBuilder& builder, const Feet& source_feet, const FootContacts& contacts,
                       int blend_frames, bool fit_stride_factor, std::optional<double> contact_lift) {
  const int frames = contacts.frame_count();
  ReferencePaths paths = reference_paths(model, builder, source_feet, frames);
  MotionPlan plan;
  if (fit_stride_factor) plan.stride = fit_stride(model, paths, contacts, builder.fps());
  plan.height = planted_height(model, paths, contacts);
  plan.pelvis_offset.resize(frames);
  for (int f = 0; f < frames; ++f) {
    const Eigen::Vector2d travel = (plan.stride - 1.0) * (paths.pelvis[f] - paths.pelvis[0]).head<2>();
    plan.pelvis_offset[f] = Eigen::Vector3d(travel.x(), travel.y(), plan.height);
  }
  // Anchors are found on the reference moved by dp_plan; o(t) is the correction from there, and
  // offsets are stored from the unmoved reference (FootPlan).
  for (int side = 0; side < 2; ++side) {
    const Foot& foot = model.feet[side];
    FootPaths& at = paths.feet[side];
    for (auto& point : at) {
      for (int f = 0; f < frames; ++f) point[f] += plan.pelvis_offset[f];
    }
    FootPlan& feet = plan.feet[side];
    feet.point.assign(frames, -1);
    feet.offset.assign(frames, Eigen::Vector3d::Zero());
    feet.follow.assign(frames, 1.0);
    if (foot.joints.size() == 1 && !foot.has_toe) feet.flat.assign(frames, 0.0);
    const std::vector<std::pair<int, int>> runs = contact_runs(contacts.planted[side]);
    const std::vector<std::vector<double>> lift = foot_lift(foot, paths.source_clearance[side], model.scale, contact_lift);
    const std::vector<Eigen::Vector3d> correction = hold_contacts(foot, at, runs, plan.pelvis_offset, lift, feet);
    fade_around_contacts(runs, correction, plan.pelvis_offset, blend_frames, feet);
  }
  return plan;
}

FrameBuilder::FrameBuilder(const RefineModel& model, const Clip& reference, const Clip& source, const Feet& source_feet)
    : model_(model),
      reference_(reference),
      source_(source),
      reference_pose_(reference.skeleton.kinematics()),
      source_pose_(source.skeleton.kinematics()),
      reference_placed_(model.kinematics),
      placed_(model.kinematics),
      flattened_(reference.joint_count(), 0) {
  source_pose_.base.rotation = source_feet.levelling;
}

void FrameBuilder::load(int frame) {
  frame_ = frame;
  reference_.world_pose(frame, reference_pose_);
  source_.world_pose(frame, source_pose_);
  place_locals();
  forward_kinematics(model_.kinematics, reference_placed_);
}

// The placement tree's local transforms (above) read off the loaded reference: a child's local
// transform; a rigid joint's transform relative to its anchor, X_ref(A)^-1 X_ref(j); an attached
// joint's offset from its anchor in the anchor's frame, W_ref(A)^-1 (P_ref(j) - P_ref(A)), a chain
// end's c_rest, both with their world rotation; the root's world transform.
void FrameBuilder::place_locals() {
  const std::vector<QuaternionTransform<double>>& world = reference_pose_.world;
  for (int j = 0; j < reference_.joint_count(); ++j) {
    QuaternionTransform<double>& local = reference_placed_.local[j];
    const int a = model_.anchor[j];
    switch (model_.placement[j]) {
      case Placement::child:
        local = reference_pose_.local[j];
        break;
      case Placement::root:
        local = world[j];
        break;
      case Placement::rigid:
      case Placement::attached: {
        const Eigen::Quaterniond anchor_inverse = world[a].rotation.conjugate();
        local.rotation = model_.placement[j] == Placement::rigid ? anchor_inverse * world[j].rotation : world[j].rotation;
        local.translation = anchor_inverse * (world[j].translation - world[a].translation);
        break;
      }
      case Placement::chain_end:
        local.rotation = world[j].rotation;
        local.translation = model_.chain_end_offset[j];
        break;
    }
  }
}

void FrameBuilder::reference_pose(FramePose& pose) const {
  pose.rotation.resize(model_.unknown_joints.size());
  for (std::size_t u = 0; u < model_.unknown_joints.size(); ++u) pose.rotation[u] = reference_local(model_.unknown_joints[u]);
  pose.pelvis_offset.setZero();
  pose.pelvis_turn.setIdentity();
}

void FrameBuilder::fill(const Limb& limb, const FramePose& pose, const MotionPlan& plan, LimbFrame& frame) const {
  const std::size_t nodes = limb.nodes.size();
  frame.pelvis = reference_pose_.world[model_.pelvis];
  frame.pelvis_offset = pose.pelvis_offset;
  frame.pelvis_prior = plan.pelvis_offset[frame_];
  frame.pelvis_turn = pose.pelvis_turn;
  frame.slot_value.resize(limb.slots.size());
  frame.slot_reference.resize(limb.slots.size());
  for (std::size_t s = 0; s < limb.slots.size(); ++s) {
    frame.slot_value[s] = pose.rotation[limb.slots[s]];
    frame.slot_reference[s] = reference_local(model_.unknown_joints[limb.slots[s]]);
  }
  QuaternionKinematicData<double>& limb_pose = frame.pose;
  limb_pose.base = {frame.pelvis.rotation * frame.pelvis_turn, frame.pelvis.translation + frame.pelvis_offset};
  limb_pose.local.resize(nodes);
  limb_pose.world.resize(nodes);
  for (std::size_t n = 0; n < nodes; ++n) limb_pose.local[n] = reference_placed_.local[limb.nodes[n].joint];
  for (std::size_t s = 0; s < limb.slots.size(); ++s) limb_pose.local[limb.slot_nodes[s]].rotation = frame.slot_value[s];
  forward_kinematics(limb.kinematics, limb_pose);

  const auto source_position = [this](int joint) -> const Eigen::Vector3d& { return source_pose_.world[joint].translation; };
  frame.direction_target.resize(limb.directions.size());
  for (std::size_t d = 0; d < limb.directions.size(); ++d) {
    const DirectionTerm& term = limb.directions[d];
    frame.direction_target[d] = term.from_reference && term.to >= 0
                                    ? Eigen::Vector3d(reference_position(limb.nodes[term.to].joint) - reference_position(limb.nodes[term.from].joint))
                                          .normalized()
                                    : Eigen::Vector3d(source_position(term.source_to) - source_position(term.source_from)).normalized();
  }
  frame.effector_target.resize(limb.effectors.size());
  for (std::size_t e = 0; e < limb.effectors.size(); ++e) {
    frame.effector_target[e] = model_.scale * (source_position(limb.effectors[e].source_joint) - source_position(model_.source_pelvis));
  }
  frame.contact_point.resize(limb.feet.size());
  frame.contact_target.resize(limb.feet.size());
  frame.contact_follow.resize(limb.feet.size());
  for (std::size_t f = 0; f < limb.feet.size(); ++f) {
    const FootPlan& feet = plan.feet[limb.feet[f].side];
    const int k = feet.point[frame_];
    frame.contact_point[f] = k;
    frame.contact_follow[f] = feet.follow[frame_];
    frame.contact_target[f] = k >= 0 ? Eigen::Vector3d(reference_point(model_.feet[limb.feet[f].side], k) + feet.offset[frame_])
                                     : Eigen::Vector3d::Zero();
  }
}

// Forward kinematics over the placement tree with the pose's unknowns and dp; a foot the plan
// holds flat is turned as soon as it is placed, so that what hangs from it follows.
void FrameBuilder::place(const FramePose& pose, const MotionPlan* plan) {
  placed_.local = reference_placed_.local;
  for (std::size_t u = 0; u < model_.unknown_joints.size(); ++u) {
    placed_.local[model_.unknown_joints[u]].rotation = pose.rotation[u];
  }
  placed_.local[model_.root].translation += pose.pelvis_offset;
  placed_.local[model_.pelvis].rotation *= pose.pelvis_turn;
  std::fill(flattened_.begin(), flattened_.end(), 0);
  const std::span<const int> order(model_.kinematics.order);
  std::array<std::pair<std::size_t, double>, 2> flat_feet{};  // position in the order, weight
  int flat_count = 0;
  for (int side = 0; plan && side < 2; ++side) {
    const std::vector<double>& flat = plan->feet[side].flat;
    if (flat.empty() || flat[frame_] <= 0) continue;
    const int joint = model_.feet[side].joints.front();
    flat_feet[flat_count++] = {static_cast<std::size_t>(std::find(order.begin(), order.end(), joint) - order.begin()), flat[frame_]};
  }
  if (flat_count == 2 && flat_feet[1].first < flat_feet[0].first) std::swap(flat_feet[0], flat_feet[1]);
  std::size_t placed = 0;
  for (int k = 0; k < flat_count; ++k) {
    const auto [position, weight] = flat_feet[k];
    forward_kinematics(model_.kinematics, placed_, order.subspan(placed, position + 1 - placed));
    placed = position + 1;
    // Held flat: the rest rotation turned about z as the placed foot turns, slerped in by `weight`.
    const int j = order[position];
    const Eigen::Quaterniond& rest = model_.rest_rotation[j];
    Eigen::Quaterniond& now = placed_.world[j].rotation;
    const Eigen::Quaterniond held = heading_of(now * rest.conjugate()) * rest;
    now = now.slerp(weight, held);
    flattened_[j] = 1;
  }
  forward_kinematics(model_.kinematics, placed_, order.subspan(placed));
}

void FrameBuilder::write(const FramePose& pose, const MotionPlan& plan, Clip& out) {
  place(pose, &plan);
  const Skeleton& skeleton = reference_.skeleton;
  const int joints = skeleton.joint_count();
  const std::vector<QuaternionTransform<double>>& world = placed_.world;
  Eigen::Quaterniond* rotation = &out.rotations[std::size_t(frame_) * joints];
  for (int j = 0; j < joints; ++j) {
    const int p = skeleton.parent(j);
    if (model_.placement[j] == Placement::child && model_.unknown_of[j] < 0 && !flattened_[j] && j != model_.pelvis) {
      rotation[j] = reference_local(j);
    } else {
      rotation[j] = local_rotation_from_world(world, j, p);
    }
  }
  const std::size_t tracks = out.translated_joints.size();
  Eigen::Vector3d* translation = &out.translations[std::size_t(frame_) * tracks];
  for (std::size_t t = 0; t < tracks; ++t) {
    const int j = out.translated_joints[t];
    translation[t] = local_translation_from_world(world, j, skeleton.parent(j));
  }
}

}  // namespace odyssey::retarget::refinement
