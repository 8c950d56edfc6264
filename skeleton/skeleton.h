// A skeleton: joint names, parents stored so that every parent precedes its children, and the
// rest pose as local transforms (offset from the parent joint, rotation relative to the parent).
// Immutable once built; construction validates, so code that holds a Skeleton can rely on it.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <span>
#include <string>
#include <vector>

#include "skeleton/fk.h"

namespace odyssey {

class Skeleton {
 public:
  Skeleton() = default;
  // Requires parents[i] < i (or -1 for a root) and equal sizes; throws std::invalid_argument
  // naming the joint otherwise. Rest rotations default to identity when empty.
  Skeleton(std::vector<std::string> names, std::vector<int> parents, std::vector<Eigen::Vector3d> rest_offsets,
           std::vector<Eigen::Quaterniond> rest_rotations = {});

  // Builds from joints in any order: sorts them so parents come first (stable, depth-first
  // from each root in input order) and reports the new position of each input joint in
  // `new_index_of` when given. Throws std::invalid_argument on a parent index out of range or a
  // cycle (naming a joint on it).
  static Skeleton from_unordered(std::vector<std::string> names, std::vector<int> parents,
                                 std::vector<Eigen::Vector3d> rest_offsets, std::vector<Eigen::Quaterniond> rest_rotations,
                                 std::vector<int>* new_index_of = nullptr);

  int joint_count() const { return static_cast<int>(parents_.size()); }
  const std::vector<std::string>& names() const { return names_; }
  const std::vector<int>& parents() const { return parents_; }
  const std::vector<Eigen::Vector3d>& rest_offsets() const { return rest_offsets_; }
  const std::vector<Eigen::Quaterniond>& rest_rotations() const { return rest_rotations_; }
  const std::string& name(int joint) const { return names_[joint]; }
  int parent(int joint) const { return parents_[joint]; }

  // Index of the joint with this exact name, or -1.
  int find(const std::string& name) const;
  std::vector<int> children(int joint) const;

  // The tree and its rest pose as forward kinematics reads them (fk.h): parents, rest local
  // transforms, joints in index order.
  const KinematicModel& kinematics() const { return kinematics_; }

  // Rest pose: local transforms and their world transforms (parents chained from the origin).
  void rest_local(std::span<RigidTransform<double>> local) const;
  std::vector<RigidTransform<double>> rest_world() const;

 private:
  std::vector<std::string> names_;
  std::vector<int> parents_;
  std::vector<Eigen::Vector3d> rest_offsets_;
  std::vector<Eigen::Quaterniond> rest_rotations_;
  KinematicModel kinematics_;
};

}  // namespace odyssey
