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
#include <stdexcept>

#include "retarget/geometry.h"

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

// A residual before it is given to a limb: what it reads, and the unknowns it depends on.
struct PendingTerm {
  enum class Kind { direction, effector, foot } kind;
  int index;                // into the matching list below
  std::vector<int> joints;  // target joints it reads positions or rotations of
  Mask mask;
};

}  // namespace

int Limb::residual_count() const {
  int count = 3 * static_cast<int>(directions.size() + effectors.size()) + 3 * owned + (moves_pelvis ? 3 : 0);
  for (const FootTerm& foot : feet) count += 3 + static_cast<int>(foot.nodes.size());
  return count;
}

RefineModel build_refine_model(const RetargetResult& result) {
  const RetargetRig& rig = result.rig;
  const Skeleton& target = rig.target;
  const int n = target.joint_count();
  const std::vector<RigidTransform<double>> rest = target.rest_world();
  RefineModel model;
  model.scale = rig.scale;
  model.length_scale = kReferenceHeight / rig.target_height;
  model.pelvis = rig.target_joint(canonical::pelvis);
  model.source_pelvis = rig.source_joint(canonical::pelvis);
  model.root = model.pelvis;
  while (target.parent(model.root) >= 0) model.root = target.parent(model.root);

  // Placements, as the transfer decides them.
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
  model.feet = result.target_feet.sides;
  for (const RigidTransform<double>& joint : rest) model.rest_rotation.push_back(Eigen::Quaterniond(joint.rotation).normalized());
  const auto from_of = [&](int j) { return model.placement[j] == Placement::child ? target.parent(j) : model.anchor[j]; };

  // Order: depth-first over (parent, anchor); the transfer has already refused cycles.
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
      model.order.push_back(j);
      stack.pop_back();
    }
  }

  // Unknowns: the start joints of the body's chain bones below the pelvis.
  model.unknown_of.assign(n, -1);
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

  // Which joints forward kinematics from the pelvis reaches, and the unknowns their position and
  // rotation depend on.
  std::vector<std::uint8_t> reachable(n, 0);
  std::vector<Mask> position_mask(n, 0), rotation_mask(n, 0);
  reachable[model.pelvis] = 1;
  for (int j : model.order) {
    const Placement kind = model.placement[j];
    if (j == model.pelvis || kind == Placement::root) continue;
    const int from = from_of(j);
    if (from < 0 || !reachable[from]) continue;
    reachable[j] = 1;
    position_mask[j] = position_mask[from] | rotation_mask[from];
    if (kind == Placement::child) {
      rotation_mask[j] = rotation_mask[from] | (model.unknown_of[j] >= 0 ? Mask(1) << model.unknown_of[j] : 0);
    } else if (kind == Placement::rigid) {
      rotation_mask[j] = rotation_mask[from];
    }
  }
  const auto all_reachable = [&](const std::vector<int>& joints) {
    return std::all_of(joints.begin(), joints.end(), [&](int j) { return reachable[j] && j != model.pelvis; });
  };

  // Residuals.
  std::vector<DirectionTerm> directions;
  std::vector<EffectorTerm> effectors;
  std::vector<FootTerm> feet;
  std::vector<PendingTerm> pending;
  for (const Segment& segment : rig.segments) {
    if (segment.degenerate || (segment.branch && !segment.spine_continuation)) continue;
    DirectionTerm term;
    term.source_from = segment.source_start;
    term.source_to = segment.source_end;
    const int a = segment.target_start;
    PendingTerm entry{PendingTerm::Kind::direction, static_cast<int>(directions.size()), {a}, 0};
    if (segment.target_attached) {
      entry.joints.push_back(segment.target_end);
      if (!all_reachable(entry.joints)) continue;
      entry.mask = position_mask[a] | position_mask[segment.target_end];
    } else {
      if (!all_reachable(entry.joints)) continue;
      term.rest_chord = (rest[a].rotation.transpose() * (rest[segment.target_end].translation - rest[a].translation)).normalized();
      entry.mask = rotation_mask[a];
    }
    if (entry.mask == 0) continue;
    directions.push_back(term);
    pending.push_back(entry);
  }
  for (int c : {canonical::head, canonical::left_wrist, canonical::right_wrist, canonical::left_ankle, canonical::right_ankle}) {
    if (!rig.source_map.mapped(c) || !rig.target_map.mapped(c)) continue;
    const int j = rig.target_joint(c);
    if (!all_reachable({j}) || position_mask[j] == 0) continue;
    pending.push_back({PendingTerm::Kind::effector, static_cast<int>(effectors.size()), {j}, position_mask[j]});
    effectors.push_back({-1, rig.source_joint(c)});
  }
  for (int side = 0; side < 2; ++side) {
    const Foot& foot = model.feet[side];
    if (all_reachable(foot.joints)) {
      Mask mask = 0;
      for (int j : foot.joints) mask |= position_mask[j];
      pending.push_back({PendingTerm::Kind::foot, static_cast<int>(feet.size()), foot.joints, mask});
      feet.push_back({side, {}, foot.ground_heights});
    }
  }

  // Limbs: each residual goes to the last limb (in solve order) among those owning an unknown it
  // depends on (feet, which also depend on dp, at least to the lower body).
  for (int group = 0; group < group_count; ++group) {
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
    if (terms.empty() && limb.owned == 0) continue;

    // Nodes: every joint on the way from the pelvis to what the residuals and slots read.
    std::vector<std::uint8_t> needed(n, 0);
    const auto need = [&](int j) {
      for (; j >= 0 && j != model.pelvis && !needed[j]; j = from_of(j)) needed[j] = 1;
    };
    for (const PendingTerm* term : terms) {
      for (int j : term->joints) need(j);
    }
    for (int s = 0; s < limb.owned; ++s) need(model.unknown_joints[limb.slots[s]]);
    std::vector<int> node_of(n, -1);
    for (int j : model.order) {
      if (!needed[j]) continue;
      node_of[j] = static_cast<int>(limb.nodes.size());
      LimbNode node;
      node.joint = j;
      node.kind = model.placement[j];
      const int from = from_of(j);
      node.from = from == model.pelvis ? -1 : node_of[from];
      const int u = model.unknown_of[j];
      if (node.kind == Placement::child && u >= 0) {
        const auto slot = std::find(limb.slots.begin(), limb.slots.end(), u);
        node.slot = static_cast<int>(slot - limb.slots.begin());
        if (slot == limb.slots.end()) limb.slots.push_back(u);
      }
      limb.nodes.push_back(node);
      const Mask mask = position_mask[j] | rotation_mask[j];
      limb.variable.push_back(limb.moves_pelvis || (mask & owned_mask) != 0);
    }
    for (const PendingTerm* term : terms) {
      switch (term->kind) {
        case PendingTerm::Kind::direction: {
          DirectionTerm direction = directions[term->index];
          direction.from = node_of[term->joints[0]];
          direction.to = term->joints.size() > 1 ? node_of[term->joints[1]] : -1;
          limb.directions.push_back(direction);
          break;
        }
        case PendingTerm::Kind::effector: {
          EffectorTerm effector = effectors[term->index];
          effector.node = node_of[term->joints[0]];
          limb.effectors.push_back(effector);
          break;
        }
        case PendingTerm::Kind::foot: {
          FootTerm foot = feet[term->index];
          for (int j : term->joints) foot.nodes.push_back(node_of[j]);
          limb.feet.push_back(foot);
          break;
        }
      }
    }
    model.limbs.push_back(std::move(limb));
  }
  return model;
}

MotionPlan plan_motion(const RefineModel& model, FrameBuilder& builder, const FootContacts& contacts, int blend_frames,
                       bool fit_stride) {
  const int frames = contacts.frame_count();
  // The pelvis in the reference pose, and the foot's points (contacts.h: its joints, then a
  // one-joint foot's toe): position[side][k][frame].
  std::vector<Eigen::Vector3d> pelvis(frames);
  std::array<std::vector<std::vector<Eigen::Vector3d>>, 2> position;
  for (int side = 0; side < 2; ++side) position[side].assign(model.feet[side].point_count(), std::vector<Eigen::Vector3d>(frames));
  for (int f = 0; f < frames; ++f) {
    builder.load(f);
    pelvis[f] = builder.reference_position(model.pelvis);
    for (int side = 0; side < 2; ++side) {
      const Foot& foot = model.feet[side];
      for (std::size_t k = 0; k < foot.joints.size(); ++k) position[side][k][f] = builder.reference_position(foot.joints[k]);
      if (foot.has_toe) {
        position[side].back()[f] = builder.reference_position(foot.joints[0]) + builder.reference_rotation(foot.joints[0]) * foot.toe;
      }
    }
  }
  const auto support = [&](int side, int f) {
    const Foot& foot = model.feet[side];
    int lowest = 0;
    for (int k = 1; k < foot.point_count(); ++k) {
      const auto& at = position[side];
      if (at[k][f].z() - foot.point_ground_height(k) < at[lowest][f].z() - foot.point_ground_height(lowest)) lowest = k;
    }
    return lowest;
  };

  // The stride: moving the body by (k - 1) times the pelvis's horizontal travel changes a planted
  // foot's step v_f by (k - 1) v_p, so k - 1 = -sum v_f . v_p / (sum |v_p|^2 + ridge) over the
  // steps with the foot planted at both ends; the ridge, worth the pelvis moving 5 cm/s (for a
  // 1.7 m character) in every such step, keeps k at 1 when the body hardly travels. k is kept
  // within [0.5, 2].
  MotionPlan plan;
  if (fit_stride) {
    double along = 0, travel = 0;
    long steps = 0;
    for (int side = 0; side < 2; ++side) {
      const std::vector<std::uint8_t>& planted = contacts.planted[side];
      for (int f = 0; f + 1 < frames; ++f) {
        if (!planted[f] || !planted[f + 1]) continue;
        const int k = support(side, f);
        const Eigen::Vector2d foot_step = (position[side][k][f + 1] - position[side][k][f]).head<2>();
        const Eigen::Vector2d pelvis_step = (pelvis[f + 1] - pelvis[f]).head<2>();
        along += foot_step.dot(pelvis_step);
        travel += pelvis_step.squaredNorm();
        ++steps;
      }
    }
    const double ridge_step = 0.05 / model.length_scale / builder.fps();
    if (steps > 0) plan.stride = std::clamp(1.0 - along / (travel + steps * ridge_step * ridge_step), 0.5, 2.0);
  }
  // The height: the median, over the planted frames, of how far the reference's support joint is
  // above the floor (the transfer's floor offset was fitted to where it placed the feet; an IK
  // foot at the end of its shin may stand elsewhere).
  std::vector<double> heights;
  for (int side = 0; side < 2; ++side) {
    for (int f = 0; f < frames; ++f) {
      if (!contacts.planted[side][f]) continue;
      const int k = support(side, f);
      heights.push_back(model.feet[side].point_ground_height(k) - position[side][k][f].z());
    }
  }
  if (!heights.empty()) {
    const auto middle = heights.begin() + static_cast<std::ptrdiff_t>(heights.size() / 2);
    std::nth_element(heights.begin(), middle, heights.end());
    plan.height = *middle;
  }
  plan.pelvis_offset.resize(frames);
  for (int f = 0; f < frames; ++f) {
    const Eigen::Vector2d travel = (plan.stride - 1.0) * (pelvis[f] - pelvis[0]).head<2>();
    plan.pelvis_offset[f] = Eigen::Vector3d(travel.x(), travel.y(), plan.height);
    for (int side = 0; side < 2; ++side) {
      for (auto& joint : position[side]) joint[f] += plan.pelvis_offset[f];
    }
  }

  // The feet. Anchors are found on the reference moved by dp_plan; o(t) is the correction from
  // there, and offsets are stored from the unmoved reference (FootPlan).
  for (int side = 0; side < 2; ++side) {
    const Foot& foot = model.feet[side];
    const auto& at = position[side];
    FootPlan& feet = plan.feet[side];
    feet.joint.assign(frames, -1);
    feet.offset.assign(frames, Eigen::Vector3d::Zero());
    feet.follow.assign(frames, 1.0);
    if (foot.joints.size() == 1 && !foot.has_toe) feet.flat.assign(frames, 0.0);
    std::vector<Eigen::Vector3d> correction(frames, Eigen::Vector3d::Zero());  // o(t) in contacts

    // Contacts: the support joint held at its anchor, on the floor.
    const std::vector<std::uint8_t>& planted = contacts.planted[side];
    std::vector<std::pair<int, int>> runs;  // [first, last]
    for (int f = 0; f < frames; ++f) {
      if (!planted[f]) continue;
      if (!runs.empty() && runs.back().second == f - 1) {
        runs.back().second = f;
      } else {
        runs.push_back({f, f});
      }
    }
    for (const auto& [first, last] : runs) {
      int k = support(side, first);
      int phase_end = first;
      while (phase_end <= last && support(side, phase_end) == k) ++phase_end;
      Eigen::Vector2d anchor = Eigen::Vector2d::Zero();
      for (int f = first; f < phase_end; ++f) anchor += at[k][f].head<2>();
      anchor /= phase_end - first;
      for (int f = first; f <= last; ++f) {
        const int now = support(side, f);
        if (now != k) {
          anchor += (at[now][f] - at[k][f]).head<2>();
          k = now;
        }
        correction[f] = Eigen::Vector3d(anchor.x(), anchor.y(), foot.point_ground_height(k)) - at[k][f];
        // The toe is rigid with joints[0] in the reference's rotation, which the solver keeps: the
        // joint moved by the toe's correction puts the toe on its anchor.
        feet.joint[f] = static_cast<std::int8_t>(std::min<int>(k, static_cast<int>(foot.joints.size()) - 1));
        feet.offset[f] = plan.pelvis_offset[f] + correction[f];
        feet.follow[f] = 0;
        if (!feet.flat.empty()) feet.flat[f] = 1;
      }
    }

    // Around contacts: the correction fades, or passes from one contact to the next.
    for (std::size_t r = 0; r <= runs.size(); ++r) {
      const bool has_before = r > 0, has_after = r < runs.size();
      const int before = has_before ? runs[r - 1].second : -1;  // last frame of the previous contact
      const int after = has_after ? runs[r].first : frames;     // first frame of the next contact
      if (has_before && has_after && after - before - 1 <= 2 * blend_frames) {
        for (int f = before + 1; f < after; ++f) {
          const double x = static_cast<double>(f - before) / (after - before);
          const double u = smoothstep(x);
          feet.joint[f] = x < 0.5 ? feet.joint[before] : feet.joint[after];
          feet.offset[f] = plan.pelvis_offset[f] + (1 - u) * correction[before] + u * correction[after];
          feet.follow[f] = 0;
          if (!feet.flat.empty()) feet.flat[f] = 1;
        }
        continue;
      }
      const auto fade = [&](int f, int boundary, int distance) {
        const double u = smoothstep(1.0 - static_cast<double>(distance) / (blend_frames + 1));
        feet.joint[f] = feet.joint[boundary];
        feet.offset[f] = u * (plan.pelvis_offset[f] + correction[boundary]);
        feet.follow[f] = 1 - u;
        if (!feet.flat.empty()) feet.flat[f] = u;
      };
      if (has_before) {
        for (int f = before + 1; f <= std::min(before + blend_frames, after - 1); ++f) fade(f, before, f - before);
      }
      if (has_after) {
        for (int f = std::max(after - blend_frames, before + 1); f < after; ++f) fade(f, after, after - f);
      }
    }
  }
  return plan;
}

FrameBuilder::FrameBuilder(const RefineModel& model, const Clip& reference, const Clip& source, const Feet& source_feet)
    : model_(model), reference_(reference), source_(source), levelling_(source_feet.levelling) {
  const int n = reference.joint_count();
  track_of_.assign(n, -1);
  for (std::size_t t = 0; t < reference.translated_joints.size(); ++t) track_of_[reference.translated_joints[t]] = static_cast<int>(t);
  local_rotation_.resize(n);
  world_rotation_.resize(n);
  local_translation_.resize(n);
  world_position_.resize(n);
  new_rotation_.resize(n);
  new_position_.resize(n);
  reference_placed_.resize(n);
  reference_rotated_.resize(n);
  flattened_.assign(n, 0);
  source_track_of_.assign(source.joint_count(), -1);
  for (std::size_t t = 0; t < source.translated_joints.size(); ++t) source_track_of_[source.translated_joints[t]] = static_cast<int>(t);
  source_position_.resize(source.joint_count());
  source_rotation_.resize(source.joint_count());
}

void FrameBuilder::load(int frame) {
  frame_ = frame;
  const Skeleton& skeleton = reference_.skeleton;
  const std::size_t tracks = reference_.translated_joints.size();
  for (int j = 0; j < skeleton.joint_count(); ++j) {
    local_rotation_[j] = reference_.rotation(frame, j);
    local_translation_[j] =
        track_of_[j] >= 0 ? reference_.translations[std::size_t(frame) * tracks + track_of_[j]] : skeleton.rest_offsets()[j];
    const int p = skeleton.parent(j);
    world_rotation_[j] = p < 0 ? local_rotation_[j] : world_rotation_[p] * local_rotation_[j];
    world_position_[j] = p < 0 ? local_translation_[j] : Eigen::Vector3d(world_position_[p] + world_rotation_[p] * local_translation_[j]);
  }
  // The source in its levelled world (contacts.h).
  const Skeleton& source_skeleton = source_.skeleton;
  const std::size_t source_tracks = source_.translated_joints.size();
  for (int j = 0; j < source_skeleton.joint_count(); ++j) {
    const Eigen::Vector3d& step = source_track_of_[j] >= 0 ? source_.translations[std::size_t(frame) * source_tracks + source_track_of_[j]]
                                                           : source_skeleton.rest_offsets()[j];
    const int p = source_skeleton.parent(j);
    const Eigen::Quaterniond& local = source_.rotation(frame, j);
    source_rotation_[j] = p < 0 ? levelling_ * local : source_rotation_[p] * local;
    source_position_[j] = p < 0 ? Eigen::Vector3d(levelling_ * step) : Eigen::Vector3d(source_position_[p] + source_rotation_[p] * step);
  }
  reference_pose(reference_pose_);
  place(reference_pose_, nullptr);
  reference_placed_ = new_position_;
  reference_rotated_ = new_rotation_;
}

void FrameBuilder::reference_pose(FramePose& pose) const {
  pose.rotation.resize(model_.unknown_joints.size());
  for (std::size_t u = 0; u < model_.unknown_joints.size(); ++u) pose.rotation[u] = local_rotation_[model_.unknown_joints[u]];
  pose.pelvis_offset.setZero();
}

void FrameBuilder::fill(const Limb& limb, const FramePose& pose, const MotionPlan& plan, LimbFrame& frame) const {
  const std::size_t nodes = limb.nodes.size();
  frame.pelvis_rotation = world_rotation_[model_.pelvis];
  frame.pelvis_position = world_position_[model_.pelvis];
  frame.pelvis_offset = pose.pelvis_offset;
  frame.pelvis_prior = plan.pelvis_offset[frame_];
  frame.node_rotation.resize(nodes);
  frame.node_offset.resize(nodes);
  frame.world_rotation.resize(nodes);
  frame.world_position.resize(nodes);
  frame.slot_value.resize(limb.slots.size());
  frame.slot_reference.resize(limb.slots.size());
  for (std::size_t s = 0; s < limb.slots.size(); ++s) {
    frame.slot_value[s] = pose.rotation[limb.slots[s]];
    frame.slot_reference[s] = local_rotation_[model_.unknown_joints[limb.slots[s]]];
  }
  const Eigen::Vector3d pelvis_position = frame.pelvis_position + frame.pelvis_offset;
  for (std::size_t n = 0; n < nodes; ++n) {
    const LimbNode& node = limb.nodes[n];
    const int j = node.joint;
    if (node.kind == Placement::child) {
      frame.node_rotation[n] = node.slot >= 0 ? frame.slot_value[node.slot] : local_rotation_[j];
      frame.node_offset[n] = local_translation_[j];
    } else {
      const int a = model_.anchor[j];
      const Eigen::Quaterniond anchor_inverse = world_rotation_[a].conjugate();
      frame.node_rotation[n] = node.kind == Placement::rigid ? anchor_inverse * world_rotation_[j] : world_rotation_[j];
      frame.node_offset[n] = node.kind == Placement::chain_end
                                 ? model_.chain_end_offset[j]
                                 : Eigen::Vector3d(anchor_inverse * (world_position_[j] - world_position_[a]));
    }
    const Eigen::Quaterniond& from_rotation = node.from < 0 ? frame.pelvis_rotation : frame.world_rotation[node.from];
    const Eigen::Vector3d& from_position = node.from < 0 ? pelvis_position : frame.world_position[node.from];
    frame.world_position[n] = from_position + from_rotation * frame.node_offset[n];
    const bool world_rotation = node.kind == Placement::attached || node.kind == Placement::chain_end;
    frame.world_rotation[n] = world_rotation ? frame.node_rotation[n] : from_rotation * frame.node_rotation[n];
  }
  frame.direction_target.resize(limb.directions.size());
  for (std::size_t d = 0; d < limb.directions.size(); ++d) {
    const DirectionTerm& term = limb.directions[d];
    frame.direction_target[d] = (source_position_[term.source_to] - source_position_[term.source_from]).normalized();
  }
  frame.effector_target.resize(limb.effectors.size());
  for (std::size_t e = 0; e < limb.effectors.size(); ++e) {
    frame.effector_target[e] = model_.scale * (source_position_[limb.effectors[e].source_joint] - source_position_[model_.source_pelvis]);
  }
  frame.contact_joint.resize(limb.feet.size());
  frame.contact_target.resize(limb.feet.size());
  frame.contact_follow.resize(limb.feet.size());
  for (std::size_t f = 0; f < limb.feet.size(); ++f) {
    const FootPlan& feet = plan.feet[limb.feet[f].side];
    const int k = feet.joint[frame_];
    frame.contact_joint[f] = k;
    frame.contact_follow[f] = feet.follow[frame_];
    const int joint = k >= 0 ? model_.feet[limb.feet[f].side].joints[k] : -1;
    frame.contact_target[f] = k >= 0 ? Eigen::Vector3d(reference_placed_[joint] + feet.offset[frame_]) : Eigen::Vector3d::Zero();
  }
}

void FrameBuilder::place(const FramePose& pose, const MotionPlan* plan) {
  const Skeleton& skeleton = reference_.skeleton;
  std::fill(flattened_.begin(), flattened_.end(), 0);
  for (int j : model_.order) {
    const int p = skeleton.parent(j);
    switch (model_.placement[j]) {
      case Placement::root:
        new_rotation_[j] = world_rotation_[j];
        new_position_[j] = world_position_[j] + pose.pelvis_offset;
        break;
      case Placement::child: {
        const int u = model_.unknown_of[j];
        const Eigen::Quaterniond& local = u >= 0 ? pose.rotation[u] : local_rotation_[j];
        new_rotation_[j] = p < 0 ? local : new_rotation_[p] * local;
        new_position_[j] = p < 0 ? local_translation_[j] : Eigen::Vector3d(new_position_[p] + new_rotation_[p] * local_translation_[j]);
        break;
      }
      case Placement::rigid:
      case Placement::attached: {
        const int a = model_.anchor[j];
        const Eigen::Quaterniond carried = new_rotation_[a] * world_rotation_[a].conjugate();
        new_rotation_[j] = model_.placement[j] == Placement::rigid ? carried * world_rotation_[j] : world_rotation_[j];
        new_position_[j] = new_position_[a] + carried * (world_position_[j] - world_position_[a]);
        break;
      }
      case Placement::chain_end: {
        const int a = model_.anchor[j];
        new_rotation_[j] = world_rotation_[j];
        new_position_[j] = new_position_[a] + new_rotation_[a] * model_.chain_end_offset[j];
        break;
      }
    }
    if (!plan) continue;
    for (int side = 0; side < 2; ++side) {
      const std::vector<double>& flat = plan->feet[side].flat;
      if (flat.empty() || model_.feet[side].joints.front() != j || flat[frame_] <= 0) continue;
      const Eigen::Quaterniond& rest = model_.rest_rotation[j];
      const Eigen::Quaterniond held = heading_of(new_rotation_[j] * rest.conjugate()) * rest;
      new_rotation_[j] = new_rotation_[j].slerp(flat[frame_], held);
      flattened_[j] = 1;
    }
  }
}

void FrameBuilder::write(const FramePose& pose, const MotionPlan& plan, Clip& out) {
  place(pose, &plan);
  const Skeleton& skeleton = reference_.skeleton;
  const int joints = skeleton.joint_count();
  Eigen::Quaterniond* rotation = &out.rotations[std::size_t(frame_) * joints];
  for (int j = 0; j < joints; ++j) {
    const int p = skeleton.parent(j);
    if (model_.placement[j] == Placement::child && model_.unknown_of[j] < 0 && !flattened_[j]) {
      rotation[j] = local_rotation_[j];
    } else {
      rotation[j] = (p < 0 ? new_rotation_[j] : new_rotation_[p].conjugate() * new_rotation_[j]).normalized();
    }
  }
  const std::size_t tracks = out.translated_joints.size();
  Eigen::Vector3d* translation = &out.translations[std::size_t(frame_) * tracks];
  for (std::size_t t = 0; t < tracks; ++t) {
    const int j = out.translated_joints[t];
    const int p = skeleton.parent(j);
    translation[t] = p < 0 ? new_position_[j] : Eigen::Vector3d(new_rotation_[p].conjugate() * (new_position_[j] - new_position_[p]));
  }
}

}  // namespace odyssey::retarget::refinement
