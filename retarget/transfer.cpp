#include "retarget/transfer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

#include "retarget/geometry.h"

namespace odyssey::retarget {

namespace {

constexpr double kBranchTwistWeight = 0.1;  // eps in transfer.h
constexpr double kFloorSmoothingSeconds = 0.1;  // sigma of dz(t) in transfer.h
constexpr double kSlideSmoothingSeconds = 0.05;  // sigma of c(t)'s steps in transfer.h

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
  for (int f = 0; f < known.front(); ++f) wanted[f] = wanted[known.front()];
  for (int f = known.back() + 1; f < frames; ++f) wanted[f] = wanted[known.back()];
  for (std::size_t k = 0; k + 1 < known.size(); ++k) {
    const int a = known[k], b = known[k + 1];
    for (int f = a + 1; f < b; ++f) wanted[f] = wanted[a] + (wanted[b] - wanted[a]) * (f - a) / (b - a);
  }
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

// `world` turned about its horizontal lateral axis so that its toe offset `toe` (in its frame)
// rises `wanted` above the joint (transfer.h).
Eigen::Quaterniond pitched_toe(const Eigen::Quaterniond& world, const Eigen::Vector3d& toe, double wanted) {
  const Eigen::Vector3d offset = world * toe;
  const double ahead = offset.head<2>().norm();
  if (!(ahead > 1e-9 * offset.norm())) return world;  // a toe straight below the joint: no pitch axis
  const double phi = std::atan2(offset.z(), ahead);
  const double theta = phi - std::asin(std::clamp(wanted / offset.norm(), -1.0, 1.0));
  const Eigen::Vector3d axis(-offset.y() / ahead, offset.x() / ahead, 0.0);  // z x f
  return (Eigen::AngleAxisd(theta, axis) * world).normalized();
}

}  // namespace

FastTransfer::FastTransfer(const RetargetRig& rig, const Feet& target_feet) : rig_(rig), target_feet_(target_feet) {
  const Skeleton& target = rig.target;
  const int n = target.joint_count();
  const std::vector<RigidTransform<double>> rest = target.rest_world();
  rest_rotation_.resize(n);
  for (int j = 0; j < n; ++j) rest_rotation_[j] = Eigen::Quaterniond(rest[j].rotation).normalized();
  const std::vector<Eigen::Quaterniond>& rest_rotation = rest_rotation_;
  const int target_pelvis = rig.target_joint(canonical::pelvis);
  const int source_pelvis = rig.source_joint(canonical::pelvis);
  target_rest_pelvis_ = rest[target_pelvis].translation;

  rules_.resize(n);
  for (int j = 0; j < n; ++j) {
    JointRule& rule = rules_[j];
    rule.parent = target.parent(j);
    rule.rest_local = target.rest_rotations()[j];
    rule.offset = target.rest_offsets()[j];
  }
  const auto attach = [&](JointRule& rule, int joint, int anchor) {
    rule.placement = JointRule::Placement::attached;
    rule.anchor = anchor;
    rule.anchor_offset = rest_rotation[anchor].conjugate() * (rest[joint].translation - rest[anchor].translation);
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
    if (foot.has_toe && rules_[foot.joints[0]].rotation == JointRule::Rotation::driven) rules_[foot.joints[0]].toe_side = side;
  }
  int root = target_pelvis;
  while (target.parent(root) >= 0) root = target.parent(root);
  rules_[root].placement = JointRule::Placement::root;
  rules_[root].root_to_pelvis = rest_rotation[root].conjugate() * (rest[target_pelvis].translation - rest[root].translation);

  // Evaluation order: depth-first over the dependencies (parent, anchor); a joint met again
  // while still open is on a cycle.
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
      order_.push_back(joint);
      stack.pop_back();
    }
  }

  for (int j = 0; j < n; ++j) {
    if (rules_[j].placement != JointRule::Placement::offset) translated_joints_.push_back(j);
  }
  root_track_ = static_cast<int>(std::find(translated_joints_.begin(), translated_joints_.end(), root) - translated_joints_.begin());

  // Source joints to pose: everything the rules and the feet read, with their ancestors.
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
  for (int k = 0; k < rig.source.joint_count(); ++k) {
    if (needed[k]) source_needed_.push_back(k);
  }
}

TransferResult FastTransfer::run(const Clip& source, const Feet& source_feet, const FootContacts& contacts) const {
  const Skeleton& source_skeleton = rig_.source;
  if (source.skeleton.names() != source_skeleton.names() || source.skeleton.parents() != source_skeleton.parents()) {
    throw std::invalid_argument("the source clip's skeleton is not the one the retargeting rig was built for");
  }
  try {
    source.validate();
  } catch (const std::invalid_argument& error) {
    throw std::invalid_argument(std::string("source clip: ") + error.what());
  }
  const int frames = source.frame_count();
  if (contacts.frame_count() != frames) {
    throw std::invalid_argument("contacts cover " + std::to_string(contacts.frame_count()) + " frames, the clip has " +
                                std::to_string(frames));
  }
  const int source_joints = source.joint_count();
  const int target_joints = rig_.target.joint_count();
  const double s = rig_.scale;
  const int source_pelvis = rig_.source_joint(canonical::pelvis);

  // Where each posed source joint's local translation comes from: its rest offset, or the clip.
  std::vector<int> translation_track(source_joints, -1);
  for (std::size_t k = 0; k < source.translated_joints.size(); ++k) translation_track[source.translated_joints[k]] = static_cast<int>(k);
  const std::size_t source_tracks = source.translated_joints.size();
  const std::vector<Eigen::Vector3d>& source_offsets = source_skeleton.rest_offsets();
  // The source is posed in its levelled world (contacts.h), its rest pelvis too.
  const Eigen::Quaterniond& levelling = source_feet.levelling;
  const Eigen::Vector3d source_rest_pelvis = levelling * rig_.source_rest_pelvis;

  TransferResult result;
  Clip& out = result.clip;
  out.skeleton = rig_.target;
  out.fps = source.fps;
  out.translated_joints = translated_joints_;
  const std::size_t tracks = translated_joints_.size();
  out.rotations.resize(std::size_t(frames) * target_joints);
  out.translations.resize(std::size_t(frames) * tracks);

  std::vector<Eigen::Quaterniond> source_rotation(source_joints);
  std::vector<Eigen::Vector3d> source_position(source_joints);
  std::vector<Eigen::Quaterniond> world(target_joints);
  std::vector<Eigen::Vector3d> position(target_joints);
  std::vector<double> gaps(2 * std::size_t(frames));  // g(foot, t) of transfer.h
  // Per foot: the support points (lowest) of the last frame, target and source, and the steps
  // since (slide_corrections).
  std::vector<Eigen::Vector2d> steps(2 * std::size_t(frames), Eigen::Vector2d::Zero());
  std::array<int, 2> last_target_point{}, last_source_joint{};
  std::array<Eigen::Vector3d, 2> last_target_support, last_source_support;

  for (int f = 0; f < frames; ++f) {
    const Eigen::Quaterniond* local_rotation = &source.rotations[std::size_t(f) * source_joints];
    const Eigen::Vector3d* local_translation = source.translations.data() + std::size_t(f) * source_tracks;
    for (int k : source_needed_) {
      const int p = source_skeleton.parent(k);
      const Eigen::Vector3d& step = translation_track[k] >= 0 ? local_translation[translation_track[k]] : source_offsets[k];
      if (p < 0) {
        source_rotation[k] = levelling * local_rotation[k];
        source_position[k] = levelling * step;
      } else {
        source_rotation[k] = source_rotation[p] * local_rotation[k];
        source_position[k] = source_position[p] + source_rotation[p] * step;
      }
    }
    const Eigen::Vector3d& pelvis_source = source_position[source_pelvis];
    const Eigen::Vector3d pelvis_target = target_rest_pelvis_ + s * (pelvis_source - source_rest_pelvis);

    for (int j : order_) {
      const JointRule& rule = rules_[j];
      const int p = rule.parent;
      switch (rule.rotation) {
        case JointRule::Rotation::rest:
          world[j] = p < 0 ? rule.rest_local : world[p] * rule.rest_local;
          break;
        case JointRule::Rotation::driven: {
          const Eigen::Quaterniond& reference = source_rotation[rule.reference];
          if (rule.branch_count > 0) {
            const Eigen::Quaterniond change = reference * rig_.source_aligned_world[rule.reference].conjugate();
            Eigen::Matrix3d b = kBranchTwistWeight * change.toRotationMatrix();
            for (int k = rule.branch_first; k < rule.branch_first + rule.branch_count; ++k) {
              const BranchChord& chord = branch_chords_[k];
              const Eigen::Vector3d now = (source_position[chord.to] - source_position[chord.from]).normalized();
              b.noalias() += now * chord.aligned_direction.transpose();
            }
            world[j] = Eigen::Quaterniond(rotation_factor(b, change)) * rest_rotation_[j];
            if (rule.chord_from >= 0) {  // the spine continuation, swung exact
              const Eigen::Vector3d wanted = (source_position[rule.chord_to] - source_position[rule.chord_from]).normalized();
              world[j] = shortest_rotation(world[j] * rule.chord_rest, wanted) * world[j];
            }
          } else if (rule.chord_from >= 0) {
            const Eigen::Vector3d carried = reference * rule.chord_rest;
            const Eigen::Vector3d wanted = (source_position[rule.chord_to] - source_position[rule.chord_from]).normalized();
            world[j] = shortest_rotation(carried, wanted) * reference * rule.reference_to_joint;
          } else {
            world[j] = reference * rule.reference_to_joint;
          }
          break;
        }
        case JointRule::Rotation::follower:
          world[j] = world[rule.anchor] * rule.anchor_to_joint;
          break;
      }
      if (rule.toe_side >= 0 && source_feet[rule.toe_side].joints.size() == 2) {
        const Foot& source_foot = source_feet[rule.toe_side];
        const Foot& foot = target_feet_[rule.toe_side];
        const double ball_above_ankle = (source_position[source_foot.joints[1]].z() - source_foot.ground_heights[1]) -
                                        (source_position[source_foot.joints[0]].z() - source_foot.ground_heights[0]);
        world[j] = pitched_toe(world[j], foot.toe, foot.toe_ground_height - foot.ground_heights[0] + s * ball_above_ankle);
      }
      switch (rule.placement) {
        case JointRule::Placement::offset:
          position[j] = p < 0 ? rule.offset : Eigen::Vector3d(position[p] + world[p] * rule.offset);
          break;
        case JointRule::Placement::root:
          position[j] = pelvis_target - world[j] * rule.root_to_pelvis;
          break;
        case JointRule::Placement::attached:
          position[j] = position[rule.anchor] + world[rule.anchor] * rule.anchor_offset;
          break;
      }
    }

    // Local rotations, sign-continuous; translations of the positioned joints.
    Eigen::Quaterniond* out_rotation = &out.rotations[std::size_t(f) * target_joints];
    const Eigen::Quaterniond* previous = f > 0 ? out_rotation - target_joints : nullptr;
    for (int j = 0; j < target_joints; ++j) {
      const int p = rules_[j].parent;
      Eigen::Quaterniond local = p < 0 ? world[j] : world[p].conjugate() * world[j];
      local.normalize();
      const double reference_sign = previous ? local.dot(previous[j]) : local.w();
      if (reference_sign < 0) local.coeffs() = -local.coeffs();
      out_rotation[j] = local;
    }
    Eigen::Vector3d* out_translation = out.translations.data() + std::size_t(f) * tracks;
    for (std::size_t t = 0; t < tracks; ++t) {
      const int j = translated_joints_[t];
      const int p = rules_[j].parent;
      out_translation[t] = p < 0 ? position[j] : Eigen::Vector3d(world[p].conjugate() * (position[j] - position[p]));
    }

    for (int side = 0; side < 2; ++side) {
      const Foot& target_foot = target_feet_[side];
      const Foot& source_foot = source_feet[side];
      const Eigen::Matrix3d first_rotation = world[target_foot.joints[0]].toRotationMatrix();
      gaps[2 * std::size_t(f) + side] = s * foot_clearance(source_foot, source_position) -
                                        foot_clearance(target_foot, position, first_rotation);
      if (f > 0) {
        const Eigen::Vector3d target_step = target_foot.point(last_target_point[side], position, first_rotation) - last_target_support[side];
        const Eigen::Vector3d source_step = source_position[source_foot.joints[last_source_joint[side]]] - last_source_support[side];
        steps[2 * std::size_t(f - 1) + side] = (target_step - s * source_step).head<2>();
      }
      last_target_point[side] = lowest_foot_point(target_foot, position, first_rotation);
      last_source_joint[side] = lowest_foot_joint(source_foot, source_position);
      last_target_support[side] = target_foot.point(last_target_point[side], position, first_rotation);
      last_source_support[side] = source_position[source_foot.joints[last_source_joint[side]]];
    }
  }

  const std::vector<double> offsets = floor_offsets(gaps, contacts, source.fps);
  const std::vector<Eigen::Vector2d> slides = slide_corrections(steps, contacts, source.fps);
  for (int f = 0; f < frames; ++f) {
    Eigen::Vector3d& root = out.translations[std::size_t(f) * tracks + root_track_];
    root.head<2>() += slides[f];
    root.z() += offsets[f];
    result.floor_offset += offsets[f] / frames;
  }
  return result;
}

}  // namespace odyssey::retarget
