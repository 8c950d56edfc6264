#include "retarget/contacts.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>

#include "retarget/geometry.h"

namespace odyssey::retarget {

namespace {

constexpr int kFloorIterations = 5;
constexpr double kGroundPercentile = 0.1;
constexpr std::size_t kMinimumStanceSamples = 10;
constexpr double kSlopeRidgeSpread = 0.1;  // m

Foot foot_joints(const BoneMap& map, bool left) {
  Foot foot;
  for (int c : {left ? canonical::left_ankle : canonical::right_ankle, left ? canonical::left_foot : canonical::right_foot}) {
    if (map.mapped(c)) foot.joints.push_back(map.joints[c]);
  }
  if (foot.joints.empty()) {
    throw std::invalid_argument(std::string("the bone map has neither ankle nor ball of the foot for the ") +
                                (left ? "left" : "right") + " foot");
  }
  foot.ground_heights.assign(foot.joints.size(), 0.0);
  return foot;
}

// World positions of every joint in one frame, the roots hung from `pose.base` (a levelling),
// into caller-owned buffers.
void frame_positions(const Clip& clip, int frame, KinematicData<double>& pose, std::vector<Eigen::Vector3d>& positions) {
  clip.world_pose(frame, pose);
  for (std::size_t j = 0; j < positions.size(); ++j) positions[j] = pose.world[j].translation;
}

double percentile(std::vector<double> values, double fraction) {
  const auto nth = values.begin() + static_cast<std::ptrdiff_t>(fraction * static_cast<double>(values.size() - 1));
  std::nth_element(values.begin(), nth, values.end());
  return *nth;
}

// The toe of a one-joint foot from the rest mesh it carries (contacts.h): at the height of the
// sole's front-most vertex, as far ahead of the joint as it; no toe when the foot carries no mesh
// or nothing lies ahead of the joint.
void find_toe(const Character& target, const std::vector<RigidTransform<double>>& rest, double sole, Foot& foot) {
  const int joint = foot.joints[0];
  std::vector<Eigen::Vector3d> carried;
  for (const CharacterMesh& mesh : target.meshes) {
    const std::vector<Eigen::Vector3d> vertices = skin_mesh_reference(mesh, rest);
    for (std::size_t v = 0; v < vertices.size(); ++v) {
      const auto& weights = mesh.influence_weights[v];
      const int strongest = static_cast<int>(std::max_element(weights.begin(), weights.end()) - weights.begin());
      if (is_ancestor(target.skeleton, joint, mesh.skin_joints[mesh.influence_slots[v][strongest]])) carried.push_back(vertices[v]);
    }
  }
  if (carried.empty()) return;
  const Eigen::Vector3d& at = rest[joint].translation;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  double low = std::numeric_limits<double>::infinity(), high = -low;
  for (const Eigen::Vector3d& p : carried) {
    centroid += p;
    low = std::min(low, p.z());
    high = std::max(high, p.z());
  }
  centroid /= static_cast<double>(carried.size());
  Eigen::Vector3d ahead(centroid.x() - at.x(), centroid.y() - at.y(), 0.0);
  if (ahead.norm() < 1e-6 * (high - low + 1e-9)) return;
  ahead.normalize();
  const Eigen::Vector3d* toe = nullptr;
  for (const Eigen::Vector3d& p : carried) {
    if (p.z() <= low + 0.1 * (high - low) && (!toe || ahead.dot(p - at) > ahead.dot(*toe - at))) toe = &p;
  }
  const double reach = ahead.dot(*toe - at);
  if (reach <= 0) return;
  // Straight ahead of the joint (not at a corner of the sole), so the foot pitches about its
  // lateral axis.
  const Eigen::Vector3d front(at.x() + reach * ahead.x(), at.y() + reach * ahead.y(), toe->z());
  foot.has_toe = true;
  foot.toe = rest[joint].rotation.transpose() * (front - at);
  foot.toe_ground_height = toe->z() - sole;
}

}  // namespace

int FootContacts::planted_count() const {
  int count = 0;
  for (const auto& foot : planted) count += static_cast<int>(std::count(foot.begin(), foot.end(), 1));
  return count;
}

int lowest_foot_joint(const Foot& foot, std::span<const Eigen::Vector3d> joint_positions) {
  int lowest = 0;
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < foot.joints.size(); ++k) {
    const double height = joint_positions[foot.joints[k]].z() - foot.ground_heights[k];
    if (height < best) {
      best = height;
      lowest = static_cast<int>(k);
    }
  }
  return lowest;
}

double foot_clearance(const Foot& foot, std::span<const Eigen::Vector3d> joint_positions) {
  const int k = lowest_foot_joint(foot, joint_positions);
  return joint_positions[foot.joints[k]].z() - foot.ground_heights[k];
}

int lowest_foot_point(const Foot& foot, std::span<const Eigen::Vector3d> joint_positions, const Eigen::Matrix3d& first_rotation) {
  int lowest = 0;
  double best = std::numeric_limits<double>::infinity();
  for (int k = 0; k < foot.point_count(); ++k) {
    const double height = foot.point(k, joint_positions, first_rotation).z() - foot.point_ground_height(k);
    if (height < best) {
      best = height;
      lowest = k;
    }
  }
  return lowest;
}

double foot_clearance(const Foot& foot, std::span<const Eigen::Vector3d> joint_positions, const Eigen::Matrix3d& first_rotation) {
  const int k = lowest_foot_point(foot, joint_positions, first_rotation);
  return foot.point(k, joint_positions, first_rotation).z() - foot.point_ground_height(k);
}

Feet source_feet(const Clip& source, const BoneMap& map, const ContactOptions& options) {
  const int frames = source.frame_count();
  if (frames == 0) throw std::invalid_argument("the source clip has no frames");
  Feet feet{{foot_joints(map, true), foot_joints(map, false)}};

  // Every foot joint's track: positions and horizontal speeds (step to the next frame; the last
  // frame repeats the step before).
  struct Track {
    Foot* foot;
    std::size_t index;
    std::vector<Eigen::Vector3d> position;
    std::vector<double> speed;
  };
  std::vector<Track> tracks;
  for (Foot& foot : feet.sides) {
    for (std::size_t k = 0; k < foot.joints.size(); ++k) tracks.push_back({&foot, k, {}, {}});
  }
  {
    KinematicData<double> pose(source.skeleton.kinematics());
    std::vector<Eigen::Vector3d> positions(source.joint_count());
    for (int f = 0; f < frames; ++f) {
      frame_positions(source, f, pose, positions);
      for (Track& track : tracks) track.position.push_back(positions[track.foot->joints[track.index]]);
    }
  }
  for (Track& track : tracks) {
    track.speed.resize(frames, 0.0);
    for (int f = 0; f + 1 < frames; ++f) track.speed[f] = (track.position[f + 1] - track.position[f]).head<2>().norm() * source.fps;
    if (frames > 1) track.speed[frames - 1] = track.speed[frames - 2];
  }

  // Plane fit: unknowns (b, c, h_1 .. h_K), z = h_k + b x + c y over the stance samples. K is at
  // most 4 (ankle and ball, two feet); fixed-size systems, unused heights pinned by identity rows.
  using System = Eigen::Matrix<double, 6, 6>;
  using Unknowns = Eigen::Matrix<double, 6, 1>;
  const int k_count = static_cast<int>(tracks.size());
  Unknowns solution = Unknowns::Zero();
  for (int k = 0; k < k_count; ++k) {
    std::vector<double> heights;
    for (const Eigen::Vector3d& p : tracks[k].position) heights.push_back(p.z());
    solution[2 + k] = percentile(heights, kGroundPercentile);
  }
  const auto is_stance = [&](int k, int f, double height) {
    return tracks[k].speed[f] < options.max_speed && std::abs(height - solution[2 + k]) < options.max_height;
  };
  for (int iteration = 0; iteration < kFloorIterations; ++iteration) {
    System normal = System::Zero();
    Unknowns right = Unknowns::Zero();
    long samples = 0;
    for (int k = 0; k < k_count; ++k) {
      for (int f = 0; f < frames; ++f) {
        const Eigen::Vector3d& p = tracks[k].position[f];
        if (!is_stance(k, f, p.z() - solution[0] * p.x() - solution[1] * p.y())) continue;
        Unknowns row = Unknowns::Zero();
        row[0] = p.x();
        row[1] = p.y();
        row[2 + k] = 1.0;
        normal += row * row.transpose();
        right += row * p.z();
        ++samples;
      }
    }
    if (samples < static_cast<long>(kMinimumStanceSamples)) break;
    // Each joint needs its own samples for its height; one without keeps its current height.
    for (int k = 0; k < 4; ++k) {
      if (normal(2 + k, 2 + k) == 0) {
        normal(2 + k, 2 + k) = 1;
        right[2 + k] = solution[2 + k];
      }
    }
    const double ridge = static_cast<double>(samples) * kSlopeRidgeSpread * kSlopeRidgeSpread;
    normal(0, 0) += ridge;
    normal(1, 1) += ridge;
    solution = normal.ldlt().solve(right);
  }

  const Eigen::Vector3d normal = Eigen::Vector3d(-solution[0], -solution[1], 1.0).normalized();
  feet.levelling = shortest_rotation(normal, Eigen::Vector3d::UnitZ());
  for (int k = 0; k < k_count; ++k) {
    std::vector<double> stance, all;
    for (int f = 0; f < frames; ++f) {
      const Eigen::Vector3d& p = tracks[k].position[f];
      const double levelled = (feet.levelling * p).z();
      all.push_back(levelled);
      if (is_stance(k, f, p.z() - solution[0] * p.x() - solution[1] * p.y())) stance.push_back(levelled);
    }
    Foot& foot = *tracks[k].foot;
    foot.ground_heights[tracks[k].index] = stance.size() >= kMinimumStanceSamples
                                               ? percentile(stance, kGroundPercentile)
                                               : *std::min_element(all.begin(), all.end());
  }
  return feet;
}

Feet target_feet(const Character& target, const BoneMap& map) {
  Feet feet{{foot_joints(map, true), foot_joints(map, false)}};
  const double sole = target.rest_bounds().min().z();
  const std::vector<RigidTransform<double>> rest = target.skeleton.rest_world();
  for (Foot& foot : feet.sides) {
    for (std::size_t k = 0; k < foot.joints.size(); ++k) foot.ground_heights[k] = rest[foot.joints[k]].translation.z() - sole;
    find_toe(target, rest, sole, foot);
  }
  return feet;
}

FootContacts detect_contacts(const Clip& source, const Feet& feet, const ContactOptions& options) {
  const int frames = source.frame_count();
  const int joints = source.joint_count();
  FootContacts contacts;
  for (auto& foot : contacts.planted) foot.assign(frames, 0);
  if (frames == 0) return contacts;
  KinematicData<double> pose(source.skeleton.kinematics());
  pose.base.rotation = feet.levelling.toRotationMatrix();
  std::vector<Eigen::Vector3d> current(joints), next(joints);
  frame_positions(source, 0, pose, current);
  for (int f = 0; f < frames; ++f) {
    // The step used for the speed: t -> t+1, or t-1 -> t for the last frame (after the swap
    // below, `next` then holds frame t-1).
    const bool last = f + 1 == frames;
    if (!last) frame_positions(source, f + 1, pose, next);
    for (int side = 0; side < 2; ++side) {
      const Foot& foot = feet[side];
      const int k = lowest_foot_joint(foot, current);
      const double clearance = current[foot.joints[k]].z() - foot.ground_heights[k];
      double speed = 0.0;
      if (frames > 1) {
        const Eigen::Vector3d step = last ? Eigen::Vector3d(current[foot.joints[k]] - next[foot.joints[k]])
                                          : Eigen::Vector3d(next[foot.joints[k]] - current[foot.joints[k]]);
        speed = step.head<2>().norm() * source.fps;
      }
      contacts.planted[side][f] = clearance < options.max_height && speed < options.max_speed ? 1 : 0;
    }
    if (!last) std::swap(current, next);
  }
  return contacts;
}

}  // namespace odyssey::retarget
