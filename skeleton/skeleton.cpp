#include "skeleton/skeleton.h"

#include <algorithm>
#include <stdexcept>

#include "skeleton/node_transform.h"

namespace odyssey {

Skeleton::Skeleton(std::vector<std::string> names, std::vector<int> parents, std::vector<Eigen::Vector3d> rest_offsets,
                   std::vector<Eigen::Quaterniond> rest_rotations)
    : names_(std::move(names)), parents_(std::move(parents)), rest_offsets_(std::move(rest_offsets)),
      rest_rotations_(std::move(rest_rotations)) {
  const std::size_t n = parents_.size();
  if (rest_rotations_.empty()) rest_rotations_.assign(n, Eigen::Quaterniond::Identity());
  if (names_.size() != n || rest_offsets_.size() != n || rest_rotations_.size() != n) {
    throw std::invalid_argument("skeleton arrays differ in length: " + std::to_string(names_.size()) + " names, " +
                                std::to_string(n) + " parents, " + std::to_string(rest_offsets_.size()) + " offsets, " +
                                std::to_string(rest_rotations_.size()) + " rotations");
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (parents_[i] < -1 || parents_[i] >= static_cast<int>(i)) {
      throw std::invalid_argument("joint " + std::to_string(i) + " '" + names_[i] + "' has parent " +
                                  std::to_string(parents_[i]) + ", which does not precede it");
    }
    if (!rest_offsets_[i].allFinite() || !rest_rotations_[i].coeffs().allFinite()) {
      throw std::invalid_argument("joint '" + names_[i] + "' has a non-finite rest transform");
    }
    rest_rotations_[i].normalize();
  }
  std::vector<RigidTransform<double>> rest(n);
  for (std::size_t i = 0; i < n; ++i) rest[i] = {rest_rotations_[i].toRotationMatrix(), rest_offsets_[i]};
  kinematics_ = KinematicModel(parents_, std::move(rest));
}

Skeleton Skeleton::from_unordered(std::vector<std::string> names, std::vector<int> parents,
                                  std::vector<Eigen::Vector3d> rest_offsets,
                                  std::vector<Eigen::Quaterniond> rest_rotations, std::vector<int>* new_index_of) {
  const int n = static_cast<int>(parents.size());
  if (rest_rotations.empty()) rest_rotations.assign(n, Eigen::Quaterniond::Identity());
  if (static_cast<int>(names.size()) != n || static_cast<int>(rest_offsets.size()) != n ||
      static_cast<int>(rest_rotations.size()) != n) {
    throw std::invalid_argument("skeleton arrays differ in length");
  }
  std::vector<std::vector<int>> children(n);
  for (int i = 0; i < n; ++i) {
    if (parents[i] < -1 || parents[i] >= n) {
      throw std::invalid_argument("joint '" + names[i] + "' has parent index " + std::to_string(parents[i]) +
                                  " outside 0.." + std::to_string(n - 1));
    }
    if (parents[i] >= 0) children[parents[i]].push_back(i);
  }
  // Depth-first from each root (node_transform.h); a joint never reached lies on a cycle (every
  // joint has one parent, so anything not hanging from a root loops back on itself).
  const HierarchyOrder walk = depth_first_order(parents, children);
  if (walk.unreached >= 0) {
    throw std::invalid_argument("joint '" + names[walk.unreached] + "' is on a parent cycle (it never reaches a root)");
  }
  const std::vector<int>& order = walk.order;
  std::vector<int> new_index(n);
  for (int k = 0; k < n; ++k) new_index[order[k]] = k;
  std::vector<std::string> sorted_names(n);
  std::vector<int> sorted_parents(n);
  std::vector<Eigen::Vector3d> sorted_offsets(n);
  std::vector<Eigen::Quaterniond> sorted_rotations(n);
  for (int k = 0; k < n; ++k) {
    const int old = order[k];
    sorted_names[k] = std::move(names[old]);
    sorted_parents[k] = parents[old] < 0 ? -1 : new_index[parents[old]];
    sorted_offsets[k] = rest_offsets[old];
    sorted_rotations[k] = rest_rotations[old];
  }
  if (new_index_of) *new_index_of = new_index;
  return Skeleton(std::move(sorted_names), std::move(sorted_parents), std::move(sorted_offsets),
                  std::move(sorted_rotations));
}

int Skeleton::find(const std::string& name) const {
  for (int i = 0; i < joint_count(); ++i) {
    if (names_[i] == name) return i;
  }
  return -1;
}

std::vector<int> Skeleton::children(int joint) const {
  std::vector<int> result;
  for (int i = joint + 1; i < joint_count(); ++i) {
    if (parents_[i] == joint) result.push_back(i);
  }
  return result;
}

void Skeleton::rest_local(std::span<RigidTransform<double>> local) const {
  std::copy(kinematics_.rest.begin(), kinematics_.rest.end(), local.begin());
}

std::vector<RigidTransform<double>> Skeleton::rest_world() const {
  KinematicData<double> rest(kinematics_);
  forward_kinematics(kinematics_, rest);
  return std::move(rest.world);
}

}  // namespace odyssey
