#include "retarget/transfer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>

#include "retarget/geometry.h"

namespace odyssey::retarget {

namespace {

constexpr double kBranchTwistWeight = 0.1;  // eps in transfer.h
constexpr double kFloorSmoothingSeconds = 0.1;  // sigma of dz(t) in transfer.h
constexpr double kSlideSmoothingSeconds = 0.05;  // sigma of c(t)'s steps in transfer.h
constexpr double kRollSmoothingSeconds = 0.05;  // sigma of r(t) in transfer.h
constexpr double kLargestRoll = 0.26;          // rad (15 degrees)
constexpr double kHeelDown = 0.01;             // m, at the performer's size: the floor bound's flat frames, transfer.h

// `values` convolved with a Gaussian of `sigma` samples, cut at 3 sigma and normalised where it
// runs past either end.
std::vector<double> gaussian_smoothed(const std::vector<double>& values, double sigma) {
  const int frames = static_cast<int>(values.size());
  const int radius = static_cast<int>(std::ceil(3 * sigma));
  std::vector<double> kernel(radius + 1);
  for (int k = 0; k <= radius; ++k) kernel[k] = std::exp(-0.5 * k * k / (sigma * sigma));
  std::vector<double> smoothed(frames);
  for (int f = 0; f < frames; ++f) {
    double sum = 0, weight = 0;
    for (int g = std::max(0, f - radius); g <= std::min(frames - 1, f + radius); ++g) {
      sum += kernel[std::abs(g - f)] * values[g];
      weight += kernel[std::abs(g - f)];
    }
    smoothed[f] = sum / weight;
  }
  return smoothed;
}

// `values` set only at the ascending frames `known` (not empty) filled in between: linear between
// two known frames, held before the first and after the last.
void fill_between(const std::vector<int>& known, std::vector<double>& values) {
  const int frames = static_cast<int>(values.size());
  for (int f = 0; f < known.front(); ++f) values[f] = values[known.front()];
  for (int f = known.back() + 1; f < frames; ++f) values[f] = values[known.back()];
  for (std::size_t k = 0; k + 1 < known.size(); ++k) {
    const int a = known[k], b = known[k + 1];
    for (int f = a + 1; f < b; ++f) values[f] = values[a] + (values[b] - values[a]) * (f - a) / (b - a);
  }
}

// dz(t) of transfer.h from the per-frame gaps: `gaps[2 f + side]`, `planted[side][f]`.
std::vector<double> floor_offsets(const std::vector<double>& gaps, const FootContacts& contacts, double fps) {
  const int frames = static_cast<int>(gaps.size() / 2);
  std::vector<double> wanted(frames, 0.0);
  std::vector<int> known;  // frames with a planted foot
  for (int f = 0; f < frames; ++f) {
    double sum = 0;
    int count = 0;
    for (int side = 0; side < 2; ++side) {
      if (!contacts.planted[side][f]) continue;
      sum += gaps[2 * f + side];
      ++count;
    }
    if (count == 0) continue;
    wanted[f] = sum / count;
    known.push_back(f);
  }
  if (known.empty()) {
    double sum = 0;
    for (double gap : gaps) sum += gap;
    return std::vector<double>(frames, gaps.empty() ? 0.0 : sum / static_cast<double>(gaps.size()));
  }
  fill_between(known, wanted);
  return gaussian_smoothed(wanted, kFloorSmoothingSeconds * fps);
}

// c(t) of transfer.h from the feet's horizontal steps: `steps[2 f + side]` is the target support
// point's step from frame f to f + 1 minus the scaled source's, valid where the foot is planted
// in both frames.
std::vector<Eigen::Vector2d> slide_corrections(const std::vector<Eigen::Vector2d>& steps, const FootContacts& contacts, double fps) {
  const int frames = contacts.frame_count();
  std::vector<Eigen::Vector2d> increments(frames, Eigen::Vector2d::Zero());  // c(f) - c(f - 1)
  for (int f = 0; f + 1 < frames; ++f) {
    Eigen::Vector2d sum = Eigen::Vector2d::Zero();
    int count = 0;
    for (int side = 0; side < 2; ++side) {
      if (!contacts.planted[side][f] || !contacts.planted[side][f + 1]) continue;
      sum += steps[2 * std::size_t(f) + side];
      ++count;
    }
    if (count > 0) increments[f + 1] = -sum / count;
  }
  std::vector<double> x(frames), y(frames);
  for (int f = 0; f < frames; ++f) {
    x[f] = increments[f].x();
    y[f] = increments[f].y();
  }
  x = gaussian_smoothed(x, kSlideSmoothingSeconds * fps);
  y = gaussian_smoothed(y, kSlideSmoothingSeconds * fps);
  std::vector<Eigen::Vector2d> corrections(frames, Eigen::Vector2d::Zero());
  for (int f = 1; f < frames; ++f) corrections[f] = corrections[f - 1] + Eigen::Vector2d(x[f], y[f]);
  return corrections;
}

// The rotation factor R of the polar decomposition B = R S (S symmetric positive definite), the
// rotation nearest B, by Newton's iteration X <- (X + X^-T) / 2, which converges quadratically
// from any B with det B > 0; starting from B / cbrt(det B) (determinant 1) it settles to 1e-12 in
// about five steps for the nearly orthogonal B met here. A B that is singular or mirrored (chords
// all gone flat, which a real clip does not do) gives `fallback`.
Eigen::Matrix3d rotation_factor(const Eigen::Matrix3d& b, const Eigen::Quaterniond& fallback) {
  const double determinant = b.determinant();
  if (!(determinant > 1e-12 * b.squaredNorm() * std::sqrt(b.squaredNorm()))) return fallback.toRotationMatrix();
  Eigen::Matrix3d x = b / std::cbrt(determinant);
  for (int step = 0; step < 30; ++step) {
    const Eigen::Matrix3d next = 0.5 * (x + x.inverse().transpose());
    const double change = (next - x).squaredNorm();
    x = next;
    if (change < 1e-26) break;
  }
  return x;
}

// The turn about the horizontal lateral axis of a foot whose world rotation is `world` that makes
// its toe (offset `toe` in the foot joint's frame) rise `wanted` above the joint (transfer.h); the
// identity when the toe stands straight below the joint (no pitch axis).
Eigen::Quaterniond toe_pitch(const Eigen::Quaterniond& world, const Eigen::Vector3d& toe, double wanted) {
  const Eigen::Vector3d offset = world * toe;
  const double ahead = offset.head<2>().norm();
  if (!(ahead > 1e-9 * offset.norm())) return Eigen::Quaterniond::Identity();
  const double phi = std::atan2(offset.z(), ahead);
  const double theta = phi - std::asin(std::clamp(wanted / offset.norm(), -1.0, 1.0));
  const Eigen::Vector3d axis(-offset.y() / ahead, offset.x() / ahead, 0.0);  // z x f
  return Eigen::Quaterniond(Eigen::AngleAxisd(theta, axis));
}

// How far the toe of a target foot should stand above its first joint (transfer.h):
//   (g_toe - g_joint) + s ((z_ball - g_ball) - (z_ankle - g_ankle))_S.
double toe_rise(const Foot& target, const Foot& source, std::span<const Eigen::Vector3d> source_position, double s) {
  const double ball_above_ankle = (source_position[source.joints[1]].z() - source.ground_heights[1]) -
                                  (source_position[source.joints[0]].z() - source.ground_heights[0]);
  return target.toe_ground_height - target.ground_heights[0] + s * ball_above_ankle;
}

}  // namespace

FastTransfer::FastTransfer(const RetargetRig& rig, const Feet& target_feet) : rig_(rig), target_feet_(target_feet) {
  const Skeleton& target = rig.target;
  const std::vector<RigidTransform<double>> rest = target.rest_world();
  for (const RigidTransform<double>& joint : rest) rest_rotation_.push_back(Eigen::Quaterniond(joint.rotation).normalized());
  const int target_pelvis = rig.target_joint(canonical::pelvis);
  target_rest_pelvis_ = rest[target_pelvis].translation;
  pelvis_ = target_pelvis;
  left_hip_ = rig.target_joint(canonical::left_hip);
  right_hip_ = rig.target_joint(canonical::right_hip);
  root_ = target_pelvis;
  while (target.parent(root_) >= 0) root_ = target.parent(root_);
  root_to_pelvis_ = rest_rotation_[root_].conjugate() * (rest[target_pelvis].translation - rest[root_].translation);
  make_rules(rest);
  make_placement(placement_order());
  source_needed_ = source_joints_to_pose();
}

// Every target joint's rule (transfer.h): rest by default; driven for a paired joint, with its
// chord or branch chords and, where a segment ends at it detached from its parent, attached to
// that segment's start; followers attached to their anchor; a driven one-joint foot with a toe.
void FastTransfer::make_rules(const std::vector<RigidTransform<double>>& rest) {
  const RetargetRig& rig = rig_;
  const Skeleton& target = rig.target;
  const int n = target.joint_count();
  const std::vector<Eigen::Quaterniond>& rest_rotation = rest_rotation_;
  rules_.resize(n);
  for (int j = 0; j < n; ++j) {
    JointRule& rule = rules_[j];
    rule.parent = target.parent(j);
    rule.local = {target.rest_rotations()[j], target.rest_offsets()[j]};
  }
  const auto attach = [&](JointRule& rule, int joint, int anchor) {
    rule.anchor = anchor;
    rule.local.translation = rest_rotation[anchor].conjugate() * (rest[joint].translation - rest[anchor].translation);
  };
  for (int c : rig.paired) {
    const int j = rig.target_joint(c);
    const int reference = rig.source_joint(c);
    JointRule& rule = rules_[j];
    rule.rotation = JointRule::Rotation::driven;
    rule.reference = reference;
    const Eigen::Quaterniond aligned_inverse = rig.source_aligned_world[reference].conjugate();
    rule.reference_to_joint = aligned_inverse * rest_rotation[j];
    std::vector<const Segment*> children;  // the non-degenerate segments starting at c
    for (const Segment& segment : rig.segments) {
      if (segment.canonical_start == c && !segment.degenerate) children.push_back(&segment);
      if (segment.canonical_end == c && !segment.target_attached) attach(rule, j, segment.target_start);
    }
    if (children.size() == 1) {
      rule.chord_from = children[0]->source_start;
      rule.chord_to = children[0]->source_end;
      rule.chord_rest = aligned_inverse * children[0]->target_rest_direction;
    } else if (children.size() >= 2) {
      rule.branch_first = static_cast<int>(branch_chords_.size());
      rule.branch_count = static_cast<int>(children.size());
      for (const Segment* segment : children) {
        const Eigen::Vector3d aligned =
            rig.source_aligned_positions[segment->source_end] - rig.source_aligned_positions[segment->source_start];
        branch_chords_.push_back({segment->source_start, segment->source_end, aligned.normalized()});
        if (segment->spine_continuation) {
          rule.chord_from = segment->source_start;
          rule.chord_to = segment->source_end;
          rule.chord_rest = rest_rotation[j].conjugate() * segment->target_rest_direction;
        }
      }
    }
  }
  for (const Segment* segment : spine_chain(rig)) {
    rules_[segment->target_start].spine_turned = true;
    spine_chain_.push_back(
        {segment->source_start, segment->source_end, (rest[segment->target_end].translation - rest[segment->target_start].translation).norm()});
  }
  for (const BoneMap::Follower& follower : rig.target_map.followers) {
    const int anchor = rig.target_joint(follower.canonical);
    if (anchor < 0) continue;
    JointRule& rule = rules_[follower.joint];
    rule.rotation = JointRule::Rotation::follower;
    rule.anchor_to_joint = rest_rotation[anchor].conjugate() * rest_rotation[follower.joint];
    attach(rule, follower.joint, anchor);
  }
  for (int side = 0; side < 2; ++side) {
    const Foot& foot = target_feet_[side];
    if (rules_[foot.joints[0]].rotation != JointRule::Rotation::driven || !foot.has_toe) continue;
    rules_[foot.joints[0]].toe_side = side;
    if (foot.joints.size() > 1 && rules_[foot.joints[1]].rotation == JointRule::Rotation::driven) rules_[foot.joints[1]].pitched_with = side;
  }
}

// Evaluation order: depth-first over the dependencies (parent, anchor); a joint met again while
// still open is on a cycle.
std::vector<int> FastTransfer::placement_order() const {
  const Skeleton& target = rig_.target;
  const int n = target.joint_count();
  std::vector<int> order;
  std::vector<int> state(n, 0);  // 0 new, 1 open, 2 done
  std::vector<std::pair<int, int>> stack;  // joint, next dependency to visit
  for (int start = 0; start < n; ++start) {
    if (state[start] == 2) continue;
    stack.push_back({start, 0});
    state[start] = 1;
    while (!stack.empty()) {
      auto& [joint, next] = stack.back();
      const int dependencies[2] = {rules_[joint].parent, rules_[joint].anchor};
      if (next < 2) {
        const int dependency = dependencies[next++];
        if (dependency < 0 || state[dependency] == 2) continue;
        if (state[dependency] == 1) {
          throw std::invalid_argument("target joint '" + target.name(dependency) +
                                      "' is placed from a joint that depends on it (check the bone map)");
        }
        state[dependency] = 1;
        stack.push_back({dependency, 0});
        continue;
      }
      state[joint] = 2;
      order.push_back(joint);
      stack.pop_back();
    }
  }
  return order;
}

// The placement tree (transfer.h) in `order`, and the output clip's translated joints: the root
// and every attached joint.
void FastTransfer::make_placement(std::vector<int> order) {
  const int n = static_cast<int>(rules_.size());
  std::vector<int> hung_from(n);
  std::vector<std::uint8_t> held(n);  // and a root's: its local rotation is its world one, exactly
  for (int j = 0; j < n; ++j) {
    const JointRule& rule = rules_[j];
    hung_from[j] = j == root_ ? -1 : rule.anchor >= 0 ? rule.anchor : rule.parent;
    held[j] = rule.rotation != JointRule::Rotation::rest || hung_from[j] < 0;
    if (j == root_ || rule.anchor >= 0) translated_joints_.push_back(j);
  }
  placement_ = KinematicModel(std::move(hung_from), {}, std::move(order), std::move(held));
  root_track_ = static_cast<int>(std::find(translated_joints_.begin(), translated_joints_.end(), root_) - translated_joints_.begin());
}

// Source joints to pose: everything the rules and the feet read, with their ancestors, ascending.
std::vector<int> FastTransfer::source_joints_to_pose() const {
  const RetargetRig& rig = rig_;
  const int source_pelvis = rig.source_joint(canonical::pelvis);
  std::vector<bool> needed(rig.source.joint_count(), false);
  const auto need = [&](int joint) {
    for (int k = joint; k >= 0 && !needed[k]; k = rig.source.parent(k)) needed[k] = true;
  };
  need(source_pelvis);
  for (const JointRule& rule : rules_) {
    for (int joint : {rule.reference, rule.chord_from, rule.chord_to}) {
      if (joint >= 0) need(joint);
    }
  }
  for (int side = 0; side < 2; ++side) {
    for (int c : {side == 0 ? canonical::left_ankle : canonical::right_ankle, side == 0 ? canonical::left_foot : canonical::right_foot}) {
      if (rig.source_map.mapped(c)) need(rig.source_joint(c));
    }
  }
  std::vector<int> joints;
  for (int k = 0; k < rig.source.joint_count(); ++k) {
    if (needed[k]) joints.push_back(k);
  }
  return joints;
}

// One run's buffers, reused from frame to frame.
struct FastTransfer::Workspace {
  QuaternionKinematicData<double> source;  // Q_S, p_S: the clip's frame from the levelled base (contacts.h)
  QuaternionKinematicData<double> target;  // W(t), P(t) over the placement tree
  std::vector<Eigen::Vector3d> source_position, target_position;  // p_S, P(t) again, as contacts.h reads them
  Eigen::Vector3d source_rest_pelvis;      // p_S^rest(pelvis), levelled
  std::vector<double> gaps;                // g(foot, t) at 2 t + side
  std::vector<double> joint_gaps;          // the same over the foot joints only (no toe)
  std::vector<double> source_heel;         // the source ankle's clearance at 2 t + side
  std::vector<Eigen::Vector2d> steps;      // e(foot, t) at 2 t + side, from t to t + 1
  // Per foot, its support point (the lowest, contacts.h) in the last frame: which and where.
  std::array<int, 2> last_target_point{}, last_source_joint{};
  std::array<Eigen::Vector3d, 2> last_target_support, last_source_support;
  Eigen::Quaterniond spine_turn = Eigen::Quaterniond::Identity();  // T(t) of transfer.h, this frame

  Workspace(const FastTransfer& transfer, const Clip& clip, const Eigen::Quaterniond& levelling)
      : source(clip.skeleton.kinematics()),
        target(transfer.placement_),
        source_position(clip.joint_count()),
        target_position(transfer.placement_.joint_count()),
        source_rest_pelvis(levelling * transfer.rig_.source_rest_pelvis),
        gaps(2 * std::size_t(clip.frame_count())),
        joint_gaps(2 * std::size_t(clip.frame_count())),
        source_heel(2 * std::size_t(clip.frame_count())),
        steps(2 * std::size_t(clip.frame_count()), Eigen::Vector2d::Zero()) {
    source.base.rotation = levelling;
    for (std::size_t j = 0; j < transfer.rules_.size(); ++j) target.local[j] = transfer.rules_[j].local;
  }
};

TransferResult FastTransfer::run(const Clip& source, const Feet& source_feet, const FootContacts& contacts) const {
  check_source(source, contacts);
  TransferResult result{empty_output(source)};
  Workspace work(*this, source, source_feet.levelling);
  const int frames = source.frame_count();
  // First where the feet stand with the pelvis as driven: for the roll that levels them, and for
  // the floor a pitched foot's toe is kept above (transfer.h); then the clip with both.
  std::vector<Eigen::Quaterniond> rolls(frames, Eigen::Quaterniond::Identity());
  std::vector<std::optional<double>> floor(frames);
  const bool rolled = left_hip_ >= 0 && right_hip_ >= 0;
  const bool pitched = std::any_of(rules_.begin(), rules_.end(), [](const JointRule& rule) { return rule.toe_side >= 0; });
  if (rolled || pitched) {
    std::vector<Eigen::Vector3d> hip_chords(frames, Eigen::Vector3d::Zero());
    for (int f = 0; f < frames; ++f) {
      pose_source(source, f, work);
      place_target(source_feet, rolls[f], std::nullopt, work);
      measure_feet(f, source_feet, work);
      if (rolled) hip_chords[f] = work.target_position[left_hip_] - work.target_position[right_hip_];
    }
    if (rolled) rolls = pelvis_rolls(work.gaps, hip_chords, contacts, source.fps);
    if (pitched) {
      FootContacts heel_down = contacts;
      for (int side = 0; side < 2; ++side) {
        for (int f = 0; f < frames; ++f) heel_down.planted[side][f] &= work.source_heel[2 * std::size_t(f) + side] < kHeelDown;
      }
      const std::vector<double> offsets = floor_offsets(work.joint_gaps, heel_down, source.fps);
      for (int f = 0; f < frames; ++f) floor[f] = offsets[f];
    }
  }
  for (int f = 0; f < frames; ++f) {
    pose_source(source, f, work);
    place_target(source_feet, rolls[f], floor[f], work);
    write_frame(f, work, result.clip);
    measure_feet(f, source_feet, work);
  }
  result.clip.make_signs_continuous();
  move_root(work, contacts, result);
  return result;
}

// Throws unless the clip is on rig.source's skeleton, finite, and as long as `contacts`.
void FastTransfer::check_source(const Clip& source, const FootContacts& contacts) const {
  if (source.skeleton.names() != rig_.source.names() || source.skeleton.parents() != rig_.source.parents()) {
    throw std::invalid_argument("the source clip's skeleton is not the one the retargeting rig was built for");
  }
  try {
    source.validate();
  } catch (const std::invalid_argument& error) {
    throw std::invalid_argument(std::string("source clip: ") + error.what());
  }
  if (contacts.frame_count() != source.frame_count()) {
    throw std::invalid_argument("contacts cover " + std::to_string(contacts.frame_count()) + " frames, the clip has " +
                                std::to_string(source.frame_count()));
  }
}

// The output clip on the target skeleton at the source's frame rate, sized for its frames.
Clip FastTransfer::empty_output(const Clip& source) const {
  Clip out;
  out.skeleton = rig_.target;
  out.fps = source.fps;
  out.translated_joints = translated_joints_;
  out.rotations.resize(std::size_t(source.frame_count()) * rig_.target.joint_count());
  out.translations.resize(std::size_t(source.frame_count()) * translated_joints_.size());
  return out;
}

// Q_S(t), p_S(t) of the source joints the rules and the feet read: forward kinematics of the
// clip's frame from the levelled base.
void FastTransfer::pose_source(const Clip& source, int frame, Workspace& work) const {
  source.local_pose(frame, work.source.local);
  forward_kinematics(source.skeleton.kinematics(), work.source, std::span<const int>(source_needed_));
  for (int k : source_needed_) work.source_position[k] = work.source.world[k].translation;
}

// W(t), P(t) of every target joint, joint by joint down the placement tree: a held rotation by
// its rule, the root put where the pelvis goes (before dz and c),
//   P(root) = P*(t) - W(root) W^rest(root)^-1 (P^rest(pelvis) - P^rest(root)),
//   P*(t)   = P_T^rest(pelvis) + s (p_S(pelvis, t) - p_S^rest(pelvis)),
// then forward kinematics places the joint (and composes a rest rotation with its parent's).
void FastTransfer::place_target(const Feet& source_feet, const Eigen::Quaterniond& pelvis_roll, std::optional<double> floor_offset,
                                Workspace& work) const {
  const double s = rig_.scale;
  const Eigen::Vector3d& pelvis_source = work.source_position[rig_.source_joint(canonical::pelvis)];
  const Eigen::Vector3d pelvis_target = target_rest_pelvis_ + s * (pelvis_source - work.source_rest_pelvis);
  std::vector<QuaternionTransform<double>>& local = work.target.local;
  // Per foot, the pitch its first joint took: a driven ball of the foot takes it too, so that it
  // keeps its bend against the foot.
  std::array<Eigen::Quaterniond, 2> pitch{Eigen::Quaterniond::Identity(), Eigen::Quaterniond::Identity()};
  if (!spine_chain_.empty()) {
    const auto position = [&work](int joint) -> const Eigen::Vector3d& { return work.source_position[joint]; };
    Eigen::Vector3d target_chord = Eigen::Vector3d::Zero();
    for (const SpineLink& link : spine_chain_) {
      target_chord += link.target_length * (position(link.source_to) - position(link.source_from)).normalized();
    }
    const Eigen::Vector3d source_chord = position(spine_chain_.back().source_to) - position(spine_chain_.front().source_from);
    work.spine_turn = Eigen::Quaterniond::Identity().slerp(0.5, shortest_rotation(target_chord.normalized(), source_chord.normalized()));
  }
  const std::span<const int> order(placement_.order);
  for (std::size_t i = 0; i < order.size(); ++i) {
    const int j = order[i];
    const JointRule& rule = rules_[j];
    if (rule.rotation == JointRule::Rotation::driven) {
      local[j].rotation = driven_rotation(j, work);
      if (j == pelvis_) local[j].rotation = pelvis_roll * local[j].rotation;
      if (rule.toe_side >= 0 && source_feet[rule.toe_side].joints.size() == 2) {
        const int side = rule.toe_side;
        const Foot& foot = target_feet_[side];
        double rise = toe_rise(foot, source_feet[side], work.source_position, s);
        if (floor_offset) {
          forward_kinematics(placement_, work.target, order.subspan(i, 1));  // its position, which its rotation does not move
          const double lowest = s * foot_clearance(source_feet[side], work.source_position);
          rise = std::max(rise, foot.toe_ground_height + lowest - (work.target.world[j].translation.z() + *floor_offset));
        }
        pitch[side] = toe_pitch(local[j].rotation, foot.toe, rise);
        local[j].rotation = (pitch[side] * local[j].rotation).normalized();
      } else if (rule.pitched_with >= 0) {
        local[j].rotation = (pitch[rule.pitched_with] * local[j].rotation).normalized();
      }
    } else if (rule.rotation == JointRule::Rotation::follower) {
      local[j].rotation = work.target.world[rule.anchor].rotation * rule.anchor_to_joint;
    }
    if (j == root_) local[j].translation = pelvis_target - local[j].rotation * root_to_pelvis_;
    forward_kinematics(placement_, work.target, order.subspan(i, 1));
  }
  for (std::size_t j = 0; j < local.size(); ++j) work.target_position[j] = work.target.world[j].translation;
}

// W(t) of a driven joint (transfer.h): D(t) W^rest = Q_S(t) Q_S^al^-1 W^rest, swung onto the
// source chord for a chain bone; R(t) W^rest for a branch joint, R(t) the rotation factor of
// B = sum_k u_k(t) u_k^al^T + eps D(t), swung onto its spine continuation's chord if it has one.
Eigen::Quaterniond FastTransfer::driven_rotation(int joint, const Workspace& work) const {
  const JointRule& rule = rules_[joint];
  if (rule.spine_turned) return (work.spine_turn * exact_rotation(joint, work)).normalized();
  return exact_rotation(joint, work);
}

// W(t) of a driven joint before the spine's turn.
Eigen::Quaterniond FastTransfer::exact_rotation(int joint, const Workspace& work) const {
  const JointRule& rule = rules_[joint];
  const Eigen::Quaterniond& reference = work.source.world[rule.reference].rotation;
  const auto chord = [&](int from, int to) -> Eigen::Vector3d {
    return (work.source_position[to] - work.source_position[from]).normalized();
  };
  if (rule.branch_count > 0) {
    const Eigen::Quaterniond change = reference * rig_.source_aligned_world[rule.reference].conjugate();
    Eigen::Matrix3d b = kBranchTwistWeight * change.toRotationMatrix();
    for (int k = rule.branch_first; k < rule.branch_first + rule.branch_count; ++k) {
      const BranchChord& branch = branch_chords_[k];
      b.noalias() += chord(branch.from, branch.to) * branch.aligned_direction.transpose();
    }
    Eigen::Quaterniond world = Eigen::Quaterniond(rotation_factor(b, change)) * rest_rotation_[joint];
    if (rule.chord_from >= 0) world = shortest_rotation(world * rule.chord_rest, chord(rule.chord_from, rule.chord_to)) * world;
    return world;
  }
  if (rule.chord_from >= 0) {
    return shortest_rotation(reference * rule.chord_rest, chord(rule.chord_from, rule.chord_to)) * reference * rule.reference_to_joint;
  }
  return reference * rule.reference_to_joint;
}

// Frame `frame` of the output: local rotations W(parent)^-1 W(t) and the translated joints'
// W(parent)^-1 (P(t) - P(parent)).
void FastTransfer::write_frame(int frame, const Workspace& work, Clip& out) const {
  const int joints = static_cast<int>(rules_.size());
  const std::vector<QuaternionTransform<double>>& world = work.target.world;
  Eigen::Quaterniond* out_rotation = &out.rotations[std::size_t(frame) * joints];
  for (int j = 0; j < joints; ++j) out_rotation[j] = local_rotation_from_world(world, j, rules_[j].parent);
  const std::size_t tracks = translated_joints_.size();
  Eigen::Vector3d* out_translation = out.translations.data() + std::size_t(frame) * tracks;
  for (std::size_t t = 0; t < tracks; ++t) {
    const int j = translated_joints_[t];
    out_translation[t] = local_translation_from_world(world, j, rules_[j].parent);
  }
}

// g(foot, t) and, from the second frame on, e(foot, t - 1) of transfer.h, per foot; its support
// point is kept for the next frame's step.
void FastTransfer::measure_feet(int frame, const Feet& source_feet, Workspace& work) const {
  const double s = rig_.scale;
  const std::vector<Eigen::Vector3d>& position = work.target_position;
  const std::vector<Eigen::Vector3d>& source_position = work.source_position;
  for (int side = 0; side < 2; ++side) {
    const Foot& target_foot = target_feet_[side];
    const Foot& source_foot = source_feet[side];
    const Eigen::Matrix3d first_rotation = work.target.world[target_foot.joints[0]].rotation.toRotationMatrix();
    work.gaps[2 * std::size_t(frame) + side] = s * foot_clearance(source_foot, source_position) -
                                               foot_clearance(target_foot, position, first_rotation);
    work.source_heel[2 * std::size_t(frame) + side] = source_position[source_foot.joints[0]].z() - source_foot.ground_heights[0];
    work.joint_gaps[2 * std::size_t(frame) + side] = s * foot_clearance(source_foot, source_position) - foot_clearance(target_foot, position);
    if (frame > 0) {
      const Eigen::Vector3d target_step =
          target_foot.point(work.last_target_point[side], position, first_rotation) - work.last_target_support[side];
      const Eigen::Vector3d source_step =
          source_position[source_foot.joints[work.last_source_joint[side]]] - work.last_source_support[side];
      work.steps[2 * std::size_t(frame - 1) + side] = (target_step - s * source_step).head<2>();
    }
    work.last_target_point[side] = lowest_foot_point(target_foot, position, first_rotation);
    work.last_source_joint[side] = lowest_foot_joint(source_foot, source_position);
    work.last_target_support[side] = target_foot.point(work.last_target_point[side], position, first_rotation);
    work.last_source_support[side] = source_position[source_foot.joints[work.last_source_joint[side]]];
  }
}

// r(t) of transfer.h from the first pass's gaps and hip chords (left minus right).
std::vector<Eigen::Quaterniond> FastTransfer::pelvis_rolls(const std::vector<double>& gaps, const std::vector<Eigen::Vector3d>& hip_chords,
                                                           const FootContacts& contacts, double fps) {
  const int frames = contacts.frame_count();
  std::vector<double> wanted(frames, 0.0);  // 0 but where both feet are planted
  for (int f = 0; f < frames; ++f) {
    const double width = hip_chords[f].head<2>().norm();
    if (!contacts.planted[0][f] || !contacts.planted[1][f] || width <= 0) continue;
    wanted[f] = std::clamp(-(gaps[2 * std::size_t(f)] - gaps[2 * std::size_t(f) + 1]) / width, -kLargestRoll, kLargestRoll);
  }
  wanted = gaussian_smoothed(wanted, kRollSmoothingSeconds * fps);
  std::vector<Eigen::Quaterniond> rolls(frames, Eigen::Quaterniond::Identity());
  for (int f = 0; f < frames; ++f) {
    const Eigen::Vector3d lateral(hip_chords[f].x(), hip_chords[f].y(), 0);
    if (lateral.norm() <= 0) continue;
    const Eigen::Vector3d axis = Eigen::Vector3d::UnitZ().cross(lateral.normalized());
    rolls[f] = Eigen::Quaterniond(Eigen::AngleAxisd(wanted[f], axis));
  }
  return rolls;
}

// The root moved by c(t) horizontally and dz(t) vertically (transfer.h); floor_offset is dz's mean.
void FastTransfer::move_root(const Workspace& work, const FootContacts& contacts, TransferResult& result) const {
  Clip& out = result.clip;
  const int frames = contacts.frame_count();
  const std::vector<double> offsets = floor_offsets(work.gaps, contacts, out.fps);
  const std::vector<Eigen::Vector2d> slides = slide_corrections(work.steps, contacts, out.fps);
  const std::size_t tracks = translated_joints_.size();
  for (int f = 0; f < frames; ++f) {
    Eigen::Vector3d& root = out.translations[std::size_t(f) * tracks + root_track_];
    root.head<2>() += slides[f];
    root.z() += offsets[f];
    result.floor_offset += offsets[f] / frames;
  }
}

}  // namespace odyssey::retarget
