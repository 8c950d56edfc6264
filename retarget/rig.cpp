#include "retarget/rig.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>
#include <type_traits>

#include "retarget/geometry.h"

namespace odyssey::retarget {

namespace {

template <class T>
using Vector3 = Eigen::Matrix<T, 3, 1>;

// Joint positions of a rig in the pose it is measured in, and the length below which a chord
// between two of them counts as zero: 1e-4 of the pose's extent (its bounding box's diagonal).
struct PosedJoints {
  std::vector<Eigen::Vector3d> position;
  double zero_length = 0;

  template <class Transform>
  explicit PosedJoints(const std::vector<Transform>& world) {
    Eigen::AlignedBox3d box;
    for (const Transform& joint : world) {
      position.push_back(joint.translation);
      box.extend(joint.translation);
    }
    zero_length = box.isEmpty() ? 0.0 : 1e-4 * box.diagonal().norm();
  }
  Eigen::Vector3d chord(int from, int to) const { return position[to] - position[from]; }
};

// The source in the pose the alignment starts from and regularises toward (SourceRest), with
// quaternion rotations: the unknowns' starting values are its local rotations.
using SourcePose = QuaternionKinematicData<double>;

SourcePose start_pose(const Clip& source, SourceRest rest) {
  const Skeleton& skeleton = source.skeleton;
  SourcePose start(skeleton.kinematics());
  if (rest == SourceRest::first_frame) {
    if (source.frame_count() == 0) throw std::invalid_argument("the source clip has no first frame to align from");
    source.local_pose(0, start.local);
  } else {
    for (int j = 0; j < skeleton.joint_count(); ++j) start.local[j] = {skeleton.rest_rotations()[j], skeleton.rest_offsets()[j]};
  }
  forward_kinematics(skeleton.kinematics(), start);
  return start;
}

double height_of(const std::vector<Eigen::Vector3d>& positions, const std::vector<int>& joints) {
  double low = std::numeric_limits<double>::infinity(), high = -low;
  for (int j : joints) {
    low = std::min(low, positions[j].z());
    high = std::max(high, positions[j].z());
  }
  return high - low;
}

// The canonical joints mapped on both rigs; throws unless the pelvis is one of them and nothing
// mapped on the target lies above its pelvis (root motion moves the target's root so that the
// pelvis lands where it should, which only works when nothing between the two is posed).
void pair_joints(RetargetRig& rig) {
  const BoneMap& source_map = rig.source_map;
  const BoneMap& target_map = rig.target_map;
  for (int c = 0; c < kCanonicalJointCount; ++c) {
    if (source_map.mapped(c) && target_map.mapped(c)) rig.paired.push_back(c);
  }
  if (!source_map.mapped(canonical::pelvis) || !target_map.mapped(canonical::pelvis)) {
    throw std::invalid_argument("the pelvis must be mapped on both rigs (source: " +
                                std::string(source_map.mapped(canonical::pelvis) ? "yes" : "no") + ", target: " +
                                (target_map.mapped(canonical::pelvis) ? "yes" : "no") + ")");
  }
  const Skeleton& target = rig.target;
  for (int j = target.parent(rig.target_joint(canonical::pelvis)); j >= 0; j = target.parent(j)) {
    const bool follows = std::any_of(target_map.followers.begin(), target_map.followers.end(),
                                     [&](const BoneMap::Follower& f) { return f.joint == j; });
    if (target_map.canonical_of(j) >= 0 || follows) {
      throw std::invalid_argument("target joint '" + target.name(j) + "' is mapped but lies above the pelvis joint '" +
                                  target.name(rig.target_joint(canonical::pelvis)) + "'");
    }
  }
}

// The segments between paired joints (rig.h): ends, degeneracy, target direction, attachment.
std::vector<Segment> find_segments(const RetargetRig& rig, const PosedJoints& source, const PosedJoints& target) {
  std::vector<bool> is_paired(kCanonicalJointCount, false);
  for (int c : rig.paired) is_paired[c] = true;
  std::vector<Segment> segments;
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
    const Eigen::Vector3d target_chord = target.chord(segment.target_start, segment.target_end);
    segment.degenerate = target_chord.norm() <= target.zero_length ||
                         source.chord(segment.source_start, segment.source_end).norm() <= source.zero_length;
    if (!segment.degenerate) segment.target_rest_direction = target_chord.normalized();
    segment.target_attached = is_ancestor(rig.target, segment.target_start, segment.target_end);
    for (const BoneMap::Follower& follower : rig.target_map.followers) {
      if (follower.canonical == a && is_ancestor(rig.target, follower.joint, segment.target_end)) segment.target_attached = true;
    }
    segments.push_back(segment);
  }
  return segments;
}

// Branch segments and spine continuations (rig.h): a start with two or more live segments is a
// branch joint; above the pelvis, its one midline child (canonical_mirror(c) == c) continues the
// spine.
void classify_branches(std::vector<Segment>& segments) {
  std::map<int, int> live_children;  // canonical start -> non-degenerate segments from it
  for (const Segment& segment : segments) {
    if (!segment.degenerate) ++live_children[segment.canonical_start];
  }
  const auto midline_branch = [](const Segment& segment) {
    return segment.branch && !segment.degenerate && segment.canonical_start != canonical::pelvis &&
           canonical_mirror(segment.canonical_end) == segment.canonical_end;
  };
  std::map<int, int> midline_children;  // canonical start above the pelvis -> its non-degenerate midline children
  for (Segment& segment : segments) {
    segment.branch = live_children[segment.canonical_start] >= 2;
    if (midline_branch(segment)) ++midline_children[segment.canonical_start];
  }
  for (Segment& segment : segments) {
    segment.spine_continuation = midline_branch(segment) && midline_children[segment.canonical_start] == 1;
  }
}

// One direction the alignment fits: from one source joint to another, against a target direction.
struct Term {
  int from, to;  // source joints
  Eigen::Vector3d target_direction;
};

struct AlignmentTerms {
  std::vector<Term> terms;
  std::vector<int> unknown_joints;  // ascending
};

// The cost's terms (rig.h): every chain bone; per branch joint, its lateral pairs, or its
// segments when it has no mirror-image children. The unknowns are the terms' start joints and the
// branch joints.
AlignmentTerms alignment_terms(const RetargetRig& rig, const PosedJoints& source, const PosedJoints& target) {
  AlignmentTerms alignment;
  std::vector<Term>& terms = alignment.terms;
  std::map<int, std::vector<const Segment*>> branches;
  for (const Segment& segment : rig.segments) {
    if (segment.degenerate) continue;
    if (segment.branch) {
      branches[segment.canonical_start].push_back(&segment);
    } else {
      terms.push_back({segment.source_start, segment.source_end, segment.target_rest_direction});
    }
  }
  for (const Term& term : terms) alignment.unknown_joints.push_back(term.from);
  for (const auto& [start_canonical, children] : branches) {
    std::vector<Term> laterals;
    for (const Segment* left : children) {
      if (!canonical_is_left(left->canonical_end)) continue;
      const int right = canonical_mirror(left->canonical_end);
      const bool has_mirror = std::any_of(children.begin(), children.end(), [&](const Segment* s) { return s->canonical_end == right; });
      if (!has_mirror) continue;
      const Eigen::Vector3d target_span = target.chord(rig.target_joint(right), rig.target_joint(left->canonical_end));
      const Eigen::Vector3d source_span = source.chord(rig.source_joint(right), rig.source_joint(left->canonical_end));
      if (target_span.norm() <= target.zero_length || source_span.norm() <= source.zero_length) continue;
      laterals.push_back({rig.source_joint(right), rig.source_joint(left->canonical_end), target_span.normalized()});
    }
    if (laterals.empty()) {
      for (const Segment* segment : children) terms.push_back({segment->source_start, segment->source_end, segment->target_rest_direction});
    } else {
      terms.insert(terms.end(), laterals.begin(), laterals.end());
    }
    alignment.unknown_joints.push_back(rig.source_joint(start_canonical));
  }
  std::vector<int>& unknowns = alignment.unknown_joints;
  std::sort(unknowns.begin(), unknowns.end());
  unknowns.erase(std::unique(unknowns.begin(), unknowns.end()), unknowns.end());
  return alignment;
}

// Derivatives are taken four parameters (one quaternion) at a time.
constexpr int kDirectionStride = 4;

// The source's start pose on the scalar types the direction costs are evaluated with: each cost
// overwrites the local rotations of the unknowns it reads, every other local stays the start
// pose's. One per problem, shared by its costs, which Ceres evaluates one after another
// (num_threads = 1).
struct AlignmentPose {
  using Jet = ceres::Jet<double, kDirectionStride>;
  const KinematicModel& model;
  SourcePose plain;
  QuaternionKinematicData<Jet> jet;

  AlignmentPose(const KinematicModel& model, const SourcePose& start) : model(model), plain(start) {
    jet.base = start.base.cast<Jet>();
    for (const QuaternionTransform<double>& local : start.local) jet.local.push_back(local.cast<Jet>());
    jet.world.resize(start.world.size());
  }
  template <class T>
  QuaternionKinematicData<T>& get() {
    if constexpr (std::is_same_v<T, double>) {
      return plain;
    } else {
      return jet;
    }
  }
};

// unit(p(to) - p(from)) - d_T: one direction term, p by forward kinematics over the two joints'
// ancestors with the unknowns among them (unit quaternions, one parameter block each) as their
// local rotations.
struct DirectionCost {
  AlignmentPose* pose;
  std::vector<int> joints;    // the ancestors of `from` and `to`, parents first
  std::vector<int> unknowns;  // the unknown joints among them, in parameter block order
  int from = -1, to = -1;
  Eigen::Vector3d target_direction;

  template <class T>
  bool operator()(T const* const* parameters, T* residuals) const {
    using std::sqrt;
    QuaternionKinematicData<T>& data = pose->get<T>();
    for (std::size_t k = 0; k < unknowns.size(); ++k) data.local[unknowns[k]].rotation = Eigen::Map<const Eigen::Quaternion<T>>(parameters[k]);
    forward_kinematics(pose->model, data, joints);
    const Vector3<T> chord = data.world[to].translation - data.world[from].translation;
    const Vector3<T> direction = chord / sqrt(chord.squaredNorm());
    for (int i = 0; i < 3; ++i) residuals[i] = direction[i] - T(target_direction[i]);
    return true;
  }
};

// lambda rotation_difference(q0, q): the small-angle rotation vector from the start rotation q0.
struct StayNearStart {
  Eigen::Quaterniond start;
  double weight;

  template <class T>
  bool operator()(const T* q, T* residuals) const {
    const Vector3<T> change = rotation_difference(Eigen::Quaternion<T>(start.cast<T>()), Eigen::Quaternion<T>(q));
    for (int i = 0; i < 3; ++i) residuals[i] = T(weight) * change[i];
    return true;
  }
};

// The cost (rig.h) over the unknowns' local rotations, solved from the start pose: the solved
// rotations (normalised), in the order of alignment.unknown_joints.
std::vector<Eigen::Quaterniond> solve_alignment(const Skeleton& source, const SourcePose& start, const AlignmentTerms& alignment,
                                                const AlignmentOptions& options, ceres::Solver::Summary& summary) {
  const std::vector<int>& unknown_joints = alignment.unknown_joints;
  std::vector<Eigen::Quaterniond> unknown_rotation;
  std::vector<int> unknown_of(source.joint_count(), -1);
  for (int j : unknown_joints) {
    unknown_of[j] = static_cast<int>(unknown_rotation.size());
    unknown_rotation.push_back(start.local[j].rotation.normalized());
  }
  if (unknown_rotation.empty()) return unknown_rotation;

  AlignmentPose pose(source.kinematics(), start);
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  ceres::EigenQuaternionManifold quaternion_manifold;
  for (Eigen::Quaterniond& q : unknown_rotation) problem.AddParameterBlock(q.coeffs().data(), 4, &quaternion_manifold);
  for (const Term& term : alignment.terms) {
    std::vector<bool> needed(source.joint_count(), false);
    for (int end : {term.from, term.to}) {
      for (int j = end; j >= 0; j = source.parent(j)) needed[j] = true;
    }
    auto* functor = new DirectionCost{&pose, {}, {}, term.from, term.to, term.target_direction};
    std::vector<double*> blocks;
    for (int j = 0; j < source.joint_count(); ++j) {
      if (!needed[j]) continue;
      functor->joints.push_back(j);
      if (unknown_of[j] < 0) continue;
      functor->unknowns.push_back(j);
      blocks.push_back(unknown_rotation[unknown_of[j]].coeffs().data());
    }
    auto* cost = new ceres::DynamicAutoDiffCostFunction<DirectionCost, kDirectionStride>(functor);
    for (std::size_t b = 0; b < blocks.size(); ++b) cost->AddParameterBlock(4);
    cost->SetNumResiduals(3);
    problem.AddResidualBlock(cost, nullptr, blocks);
  }
  for (std::size_t u = 0; u < unknown_joints.size(); ++u) {
    auto* cost = new ceres::AutoDiffCostFunction<StayNearStart, 3, 4>(
        new StayNearStart{start.local[unknown_joints[u]].rotation.normalized(), options.regularisation});
    problem.AddResidualBlock(cost, nullptr, unknown_rotation[u].coeffs().data());
  }
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_QR;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.function_tolerance = 1e-14;
  solver_options.gradient_tolerance = 1e-14;
  solver_options.parameter_tolerance = 1e-12;
  solver_options.num_threads = 1;  // the costs share `pose`
  solver_options.logging_type = ceres::SILENT;
  ceres::Solve(solver_options, &problem, &summary);
  for (Eigen::Quaterniond& q : unknown_rotation) q.normalize();
  return unknown_rotation;
}

// The angles left after alignment, over the fitted terms and per segment.
void measure_alignment(RetargetRig& rig, const AlignmentTerms& alignment) {
  const auto aligned_chord = [&](int from, int to) -> Eigen::Vector3d {
    return rig.source_aligned_positions[to] - rig.source_aligned_positions[from];
  };
  AlignmentSummary& report = rig.alignment;
  for (const Term& term : alignment.terms) {
    const double error = angle_deg(aligned_chord(term.from, term.to), term.target_direction);
    report.mean_residual_deg += error;
    report.max_residual_deg = std::max(report.max_residual_deg, error);
  }
  if (!alignment.terms.empty()) report.mean_residual_deg /= static_cast<double>(alignment.terms.size());
  for (Segment& segment : rig.segments) {
    if (segment.degenerate) continue;
    segment.aligned_error_deg = angle_deg(aligned_chord(segment.source_start, segment.source_end), segment.target_rest_direction);
  }
}

// Poses the source onto the target's rest directions (rig.h): the aligned pose and its summary.
void align_source(RetargetRig& rig, SourcePose start, const AlignmentTerms& alignment, const AlignmentOptions& options) {
  const auto solve_start = std::chrono::steady_clock::now();
  ceres::Solver::Summary summary;
  const std::vector<Eigen::Quaterniond> solved = solve_alignment(rig.source, start, alignment, options, summary);
  for (std::size_t u = 0; u < solved.size(); ++u) start.local[alignment.unknown_joints[u]].rotation = solved[u];
  forward_kinematics(rig.source.kinematics(), start);
  rig.source_aligned_local.clear();
  rig.source_aligned_world.clear();
  rig.source_aligned_positions.clear();
  for (std::size_t j = 0; j < start.local.size(); ++j) {
    rig.source_aligned_local.push_back(start.local[j].rotation);
    rig.source_aligned_world.push_back(start.world[j].rotation);
    rig.source_aligned_positions.push_back(start.world[j].translation);
  }
  AlignmentSummary& report = rig.alignment;
  report.unknowns = static_cast<int>(alignment.unknown_joints.size());
  report.fitted_terms = static_cast<int>(alignment.terms.size());
  report.iterations = static_cast<int>(summary.iterations.size());
  report.solver_report = solved.empty() ? "nothing to align" : summary.BriefReport();
  measure_alignment(rig, alignment);
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - solve_start).count();
}

// The height scale over the paired joints (rig.h), the source measured aligned.
void measure_heights(RetargetRig& rig, const PosedJoints& target) {
  std::vector<int> source_joints, target_joints;
  for (int c : rig.paired) {
    source_joints.push_back(rig.source_joint(c));
    target_joints.push_back(rig.target_joint(c));
  }
  rig.source_height = height_of(rig.source_aligned_positions, source_joints);
  rig.target_height = height_of(target.position, target_joints);
  if (!(rig.source_height > 0) || !(rig.target_height > 0)) {
    throw std::invalid_argument("a rig has no height over its paired joints (source " + std::to_string(rig.source_height) +
                                " m, target " + std::to_string(rig.target_height) + " m)");
  }
  rig.scale = rig.target_height / rig.source_height;
}

}  // namespace

const char* source_rest_name(SourceRest rest) {
  return rest == SourceRest::rest ? "rest" : "first_frame";
}

std::vector<const Segment*> spine_chain(const RetargetRig& rig) {
  const auto paired = [&rig](int c) { return rig.source_map.mapped(c) && rig.target_map.mapped(c); };
  const int top = paired(canonical::neck) ? canonical::neck : canonical::head;
  std::vector<const Segment*> chain;
  if (!paired(canonical::spine1) || !paired(top)) return chain;
  for (int at = canonical::spine1; at != top;) {
    const auto next = std::find_if(rig.segments.begin(), rig.segments.end(), [&](const Segment& segment) {
      return segment.canonical_start == at && (canonical_limb(segment.canonical_end) == "spine" || segment.canonical_end == top);
    });
    if (next == rig.segments.end() || next->degenerate) return {};
    chain.push_back(&*next);
    at = next->canonical_end;
  }
  if (chain.size() < 2) chain.clear();
  return chain;
}

RetargetRig build_retarget_rig(const Clip& source, const BoneMap& source_map, const Skeleton& target,
                               const BoneMap& target_map, SourceRest source_rest, const AlignmentOptions& options) {
  RetargetRig rig;
  rig.source = source.skeleton;
  rig.target = target;
  rig.source_map = source_map;
  rig.target_map = target_map;
  rig.source_rest = source_rest;
  pair_joints(rig);
  SourcePose start = start_pose(source, source_rest);
  const PosedJoints source_start(start.world), target_rest(target.rest_world());
  rig.segments = find_segments(rig, source_start, target_rest);
  classify_branches(rig.segments);
  const AlignmentTerms alignment = alignment_terms(rig, source_start, target_rest);
  align_source(rig, std::move(start), alignment, options);
  measure_heights(rig, target_rest);
  rig.source_rest_pelvis = rig.source.rest_world()[rig.source_joint(canonical::pelvis)].translation;
  return rig;
}

}  // namespace odyssey::retarget
