#include "retarget/rig.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>

#include "retarget/geometry.h"

namespace odyssey::retarget {

namespace {

// Local rotations and translations of every joint in a pose.
struct Pose {
  std::vector<Eigen::Quaterniond> rotation;
  std::vector<Eigen::Vector3d> translation;
};

Pose start_pose(const Clip& source, SourceRest rest) {
  const Skeleton& skeleton = source.skeleton;
  Pose pose{skeleton.rest_rotations(), skeleton.rest_offsets()};
  if (rest == SourceRest::first_frame) {
    if (source.frame_count() == 0) throw std::invalid_argument("the source clip has no first frame to align from");
    for (int j = 0; j < skeleton.joint_count(); ++j) pose.rotation[j] = source.rotation(0, j);
    const std::size_t k = source.translated_joints.size();
    for (std::size_t t = 0; t < k; ++t) pose.translation[source.translated_joints[t]] = source.translations[t];
  }
  return pose;
}

void pose_world(const Skeleton& skeleton, const Pose& pose, std::vector<Eigen::Quaterniond>& world_rotation,
                std::vector<Eigen::Vector3d>& world_position) {
  const int n = skeleton.joint_count();
  world_rotation.resize(n);
  world_position.resize(n);
  for (int j = 0; j < n; ++j) {
    const int p = skeleton.parent(j);
    if (p < 0) {
      world_rotation[j] = pose.rotation[j];
      world_position[j] = pose.translation[j];
    } else {
      world_rotation[j] = world_rotation[p] * pose.rotation[j];
      world_position[j] = world_position[p] + world_rotation[p] * pose.translation[j];
    }
  }
}

double extent(const std::vector<Eigen::Vector3d>& points) {
  Eigen::AlignedBox3d box;
  for (const auto& p : points) box.extend(p);
  return box.isEmpty() ? 0.0 : box.diagonal().norm();
}

double height_of(const std::vector<Eigen::Vector3d>& positions, const std::vector<int>& joints) {
  double low = std::numeric_limits<double>::infinity(), high = -low;
  for (int j : joints) {
    low = std::min(low, positions[j].z());
    high = std::max(high, positions[j].z());
  }
  return high - low;
}

// One direction term of the alignment: the unit vector from one source joint to another,
// against a target direction. Forward kinematics runs over the joints the two depend on (the
// union of their ancestors, parents first); the unknowns among them are the cost's parameter
// blocks, in the order of `unknown` indices.
struct DirectionTerm {
  std::vector<int> parent_slot;
  std::vector<int> unknown;  // parameter block of each slot, -1 for a fixed rotation
  std::vector<Eigen::Quaterniond> fixed_rotation;
  std::vector<Eigen::Vector3d> offset;
  int from_slot = 0, to_slot = 0;
  Eigen::Vector3d target_direction;

  template <class T>
  bool operator()(T const* const* parameters, T* residuals) const {
    using Vector3 = Eigen::Matrix<T, 3, 1>;
    using std::sqrt;
    const std::size_t n = parent_slot.size();
    std::vector<Eigen::Quaternion<T>> rotation(n);
    std::vector<Vector3> position(n);
    for (std::size_t k = 0; k < n; ++k) {
      const Eigen::Quaternion<T> local = unknown[k] >= 0 ? Eigen::Quaternion<T>(Eigen::Map<const Eigen::Quaternion<T>>(parameters[unknown[k]]))
                                                         : fixed_rotation[k].template cast<T>();
      const Vector3 step = offset[k].template cast<T>();
      const int p = parent_slot[k];
      if (p < 0) {
        rotation[k] = local;
        position[k] = step;
      } else {
        rotation[k] = rotation[p] * local;
        position[k] = position[p] + rotation[p] * step;
      }
    }
    const Vector3 chord = position[to_slot] - position[from_slot];
    const Vector3 direction = chord / sqrt(chord.squaredNorm());
    for (int i = 0; i < 3; ++i) residuals[i] = direction[i] - T(target_direction[i]);
    return true;
  }
};

// lambda * 2 vec(q0^-1 q), the small-angle rotation vector from the start pose (sign chosen so
// the scalar part is positive: q and -q are the same rotation).
struct StayNearStart {
  Eigen::Quaterniond start_inverse;
  double weight;

  template <class T>
  bool operator()(const T* q, T* residuals) const {
    const Eigen::Quaternion<T> change = start_inverse.template cast<T>() * Eigen::Map<const Eigen::Quaternion<T>>(q);
    const T sign = change.w() < T(0) ? T(-2.0 * weight) : T(2.0 * weight);
    for (int i = 0; i < 3; ++i) residuals[i] = sign * change.vec()[i];
    return true;
  }
};

struct Term {
  int from, to;  // source joints
  Eigen::Vector3d target_direction;
};

}  // namespace

const char* source_rest_name(SourceRest rest) {
  return rest == SourceRest::rest ? "rest" : "first_frame";
}

RetargetRig build_retarget_rig(const Clip& source, const BoneMap& source_map, const Skeleton& target,
                               const BoneMap& target_map, SourceRest source_rest, const AlignmentOptions& options) {
  RetargetRig rig;
  rig.source = source.skeleton;
  rig.target = target;
  rig.source_map = source_map;
  rig.target_map = target_map;
  rig.source_rest = source_rest;
  for (int c = 0; c < kCanonicalJointCount; ++c) {
    if (source_map.mapped(c) && target_map.mapped(c)) rig.paired.push_back(c);
  }
  if (!source_map.mapped(canonical::pelvis) || !target_map.mapped(canonical::pelvis)) {
    throw std::invalid_argument("the pelvis must be mapped on both rigs (source: " +
                                std::string(source_map.mapped(canonical::pelvis) ? "yes" : "no") + ", target: " +
                                (target_map.mapped(canonical::pelvis) ? "yes" : "no") + ")");
  }
  // Root motion moves the target's root so that the pelvis lands where it should; that only
  // works when nothing between the root and the pelvis is posed.
  for (int j = target.parent(rig.target_joint(canonical::pelvis)); j >= 0; j = target.parent(j)) {
    const bool follows = std::any_of(target_map.followers.begin(), target_map.followers.end(),
                                     [&](const BoneMap::Follower& f) { return f.joint == j; });
    if (target_map.canonical_of(j) >= 0 || follows) {
      throw std::invalid_argument("target joint '" + target.name(j) + "' is mapped but lies above the pelvis joint '" +
                                  target.name(rig.target_joint(canonical::pelvis)) + "'");
    }
  }

  // Rest poses.
  const Pose start = start_pose(source, source_rest);
  std::vector<Eigen::Quaterniond> start_world;
  std::vector<Eigen::Vector3d> start_position;
  pose_world(rig.source, start, start_world, start_position);
  const std::vector<RigidTransform<double>> target_rest = target.rest_world();
  std::vector<Eigen::Vector3d> target_position(target.joint_count());
  for (int j = 0; j < target.joint_count(); ++j) target_position[j] = target_rest[j].translation;
  const double source_tolerance = 1e-4 * extent(start_position);
  const double target_tolerance = 1e-4 * extent(target_position);

  // Segments.
  std::vector<bool> is_paired(kCanonicalJointCount, false);
  for (int c : rig.paired) is_paired[c] = true;
  for (int c : rig.paired) {
    int a = canonical_parent(c);
    while (a >= 0 && !is_paired[a]) a = canonical_parent(a);
    if (a < 0) continue;
    Segment segment;
    segment.canonical_start = a;
    segment.canonical_end = c;
    segment.source_start = rig.source_joint(a);
    segment.source_end = rig.source_joint(c);
    segment.target_start = rig.target_joint(a);
    segment.target_end = rig.target_joint(c);
    const Eigen::Vector3d target_chord = target_position[segment.target_end] - target_position[segment.target_start];
    const Eigen::Vector3d source_chord = start_position[segment.source_end] - start_position[segment.source_start];
    segment.degenerate = target_chord.norm() <= target_tolerance || source_chord.norm() <= source_tolerance;
    if (!segment.degenerate) segment.target_rest_direction = target_chord.normalized();
    segment.target_attached = is_ancestor(target, segment.target_start, segment.target_end);
    for (const BoneMap::Follower& follower : target_map.followers) {
      if (follower.canonical == a && is_ancestor(target, follower.joint, segment.target_end)) segment.target_attached = true;
    }
    rig.segments.push_back(segment);
  }
  std::map<int, int> live_children;  // canonical start -> non-degenerate segments from it
  for (const Segment& segment : rig.segments) {
    if (!segment.degenerate) ++live_children[segment.canonical_start];
  }
  std::map<int, int> midline_children;  // canonical start above the pelvis -> its non-degenerate midline children
  for (Segment& segment : rig.segments) {
    segment.branch = live_children[segment.canonical_start] >= 2;
    if (segment.branch && !segment.degenerate && segment.canonical_start != canonical::pelvis &&
        canonical_mirror(segment.canonical_end) == segment.canonical_end) {
      ++midline_children[segment.canonical_start];
    }
  }
  for (Segment& segment : rig.segments) {
    segment.spine_continuation = segment.branch && !segment.degenerate && segment.canonical_start != canonical::pelvis &&
                                 canonical_mirror(segment.canonical_end) == segment.canonical_end &&
                                 midline_children[segment.canonical_start] == 1;
  }

  // Alignment terms (see rig.h).
  std::vector<Term> terms;
  const auto target_direction = [&](int from_canonical, int to_canonical) -> Eigen::Vector3d {
    return (target_position[rig.target_joint(to_canonical)] - target_position[rig.target_joint(from_canonical)]).normalized();
  };
  std::map<int, std::vector<const Segment*>> branches;
  for (const Segment& segment : rig.segments) {
    if (segment.degenerate) continue;
    if (segment.branch) {
      branches[segment.canonical_start].push_back(&segment);
    } else {
      terms.push_back({segment.source_start, segment.source_end, segment.target_rest_direction});
    }
  }
  std::vector<int> unknown_joints;
  for (const Term& term : terms) unknown_joints.push_back(term.from);
  for (const auto& [start_canonical, children] : branches) {
    std::vector<Term> laterals;
    for (const Segment* left : children) {
      if (!canonical_is_left(left->canonical_end)) continue;
      const int mirror = canonical_mirror(left->canonical_end);
      const bool has_mirror = std::any_of(children.begin(), children.end(), [&](const Segment* s) { return s->canonical_end == mirror; });
      if (!has_mirror) continue;
      const Eigen::Vector3d target_span = target_position[rig.target_joint(left->canonical_end)] - target_position[rig.target_joint(mirror)];
      const Eigen::Vector3d source_span = start_position[rig.source_joint(left->canonical_end)] - start_position[rig.source_joint(mirror)];
      if (target_span.norm() <= target_tolerance || source_span.norm() <= source_tolerance) continue;
      laterals.push_back({rig.source_joint(mirror), rig.source_joint(left->canonical_end), target_direction(mirror, left->canonical_end)});
    }
    if (laterals.empty()) {
      for (const Segment* segment : children) terms.push_back({segment->source_start, segment->source_end, segment->target_rest_direction});
    } else {
      terms.insert(terms.end(), laterals.begin(), laterals.end());
    }
    unknown_joints.push_back(rig.source_joint(start_canonical));
  }
  std::sort(unknown_joints.begin(), unknown_joints.end());
  unknown_joints.erase(std::unique(unknown_joints.begin(), unknown_joints.end()), unknown_joints.end());

  // Ceres problem.
  const auto solve_start = std::chrono::steady_clock::now();
  std::vector<Eigen::Quaterniond> unknown_rotation;
  for (int j : unknown_joints) unknown_rotation.push_back(start.rotation[j].normalized());
  std::vector<int> unknown_of(rig.source.joint_count(), -1);
  for (std::size_t u = 0; u < unknown_joints.size(); ++u) unknown_of[unknown_joints[u]] = static_cast<int>(u);

  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  ceres::EigenQuaternionManifold quaternion_manifold;
  for (Eigen::Quaterniond& q : unknown_rotation) problem.AddParameterBlock(q.coeffs().data(), 4, &quaternion_manifold);
  for (const Term& term : terms) {
    std::vector<bool> needed(rig.source.joint_count(), false);
    for (int end : {term.from, term.to}) {
      for (int j = end; j >= 0; j = rig.source.parent(j)) needed[j] = true;
    }
    auto* functor = new DirectionTerm;
    std::vector<int> slot_of(rig.source.joint_count(), -1);
    std::vector<double*> blocks;
    for (int j = 0; j < rig.source.joint_count(); ++j) {
      if (!needed[j]) continue;
      slot_of[j] = static_cast<int>(functor->parent_slot.size());
      const int p = rig.source.parent(j);
      functor->parent_slot.push_back(p < 0 ? -1 : slot_of[p]);
      functor->offset.push_back(start.translation[j]);
      functor->fixed_rotation.push_back(start.rotation[j]);
      if (unknown_of[j] >= 0) {
        functor->unknown.push_back(static_cast<int>(blocks.size()));
        blocks.push_back(unknown_rotation[unknown_of[j]].coeffs().data());
      } else {
        functor->unknown.push_back(-1);
      }
    }
    functor->from_slot = slot_of[term.from];
    functor->to_slot = slot_of[term.to];
    functor->target_direction = term.target_direction;
    auto* cost = new ceres::DynamicAutoDiffCostFunction<DirectionTerm, 4>(functor);
    for (std::size_t b = 0; b < blocks.size(); ++b) cost->AddParameterBlock(4);
    cost->SetNumResiduals(3);
    problem.AddResidualBlock(cost, nullptr, blocks);
  }
  for (std::size_t u = 0; u < unknown_joints.size(); ++u) {
    auto* cost = new ceres::AutoDiffCostFunction<StayNearStart, 3, 4>(
        new StayNearStart{start.rotation[unknown_joints[u]].normalized().conjugate(), options.regularisation});
    problem.AddResidualBlock(cost, nullptr, unknown_rotation[u].coeffs().data());
  }
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_QR;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.function_tolerance = 1e-14;
  solver_options.gradient_tolerance = 1e-14;
  solver_options.parameter_tolerance = 1e-12;
  solver_options.num_threads = 1;
  solver_options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  if (!unknown_rotation.empty()) ceres::Solve(solver_options, &problem, &summary);

  Pose aligned = start;
  for (std::size_t u = 0; u < unknown_joints.size(); ++u) aligned.rotation[unknown_joints[u]] = unknown_rotation[u].normalized();
  rig.source_aligned_local = aligned.rotation;
  pose_world(rig.source, aligned, rig.source_aligned_world, rig.source_aligned_positions);

  AlignmentSummary& report = rig.alignment;
  report.unknowns = static_cast<int>(unknown_joints.size());
  report.fitted_terms = static_cast<int>(terms.size());
  report.iterations = static_cast<int>(summary.iterations.size());
  report.solver_report = unknown_rotation.empty() ? "nothing to align" : summary.BriefReport();
  for (const Term& term : terms) {
    const Eigen::Vector3d aligned_direction = rig.source_aligned_positions[term.to] - rig.source_aligned_positions[term.from];
    const double error = angle_deg(aligned_direction, term.target_direction);
    report.mean_residual_deg += error;
    report.max_residual_deg = std::max(report.max_residual_deg, error);
  }
  if (!terms.empty()) report.mean_residual_deg /= static_cast<double>(terms.size());
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - solve_start).count();
  for (Segment& segment : rig.segments) {
    if (segment.degenerate) continue;
    segment.aligned_error_deg = angle_deg(rig.source_aligned_positions[segment.source_end] - rig.source_aligned_positions[segment.source_start],
                                          segment.target_rest_direction);
  }

  // Scale over the paired joints.
  std::vector<int> source_joints, target_joints;
  for (int c : rig.paired) {
    source_joints.push_back(rig.source_joint(c));
    target_joints.push_back(rig.target_joint(c));
  }
  rig.source_height = height_of(rig.source_aligned_positions, source_joints);
  rig.target_height = height_of(target_position, target_joints);
  if (!(rig.source_height > 0) || !(rig.target_height > 0)) {
    throw std::invalid_argument("a rig has no height over its paired joints (source " + std::to_string(rig.source_height) +
                                " m, target " + std::to_string(rig.target_height) + " m)");
  }
  rig.scale = rig.target_height / rig.source_height;
  rig.source_rest_pelvis = rig.source.rest_world()[rig.source_joint(canonical::pelvis)].translation;
  return rig;
}

}  // namespace odyssey::retarget
