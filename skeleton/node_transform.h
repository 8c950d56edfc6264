// glTF node transforms, the one place the loader, the animated-GLB writer and node animation
// take them from: a node's local matrix, world matrices down a hierarchy, and the depth-first
// walk that orders a hierarchy given by parent indices and finds the nodes on a cycle.
//
// Local matrix. A node is a matrix M, or a translation t, rotation q and scale s (defaults 0,
// identity, 1) composed as glTF defines them:
//   L = T R S = [R(q / |q|) diag(s) | t; 0 0 0 1]  (q normalised here; M as it is).
// World matrices. G(n) = G(parent(n)) L(n), G(root) = L(root), evaluated in an order that lists
// every node after its parent, so each product reads a finished parent.
// Hierarchy. parents[n] is n's parent or -1 for a root. Following parents from a node either
// reaches a root or, since every node has one parent, loops: a node the walk from the roots never
// reaches is on a cycle or hangs below one. Joint skeletons given in any order use the same walk.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <span>
#include <vector>

namespace odyssey {

struct NodeTransform {
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();  // normalised by local_matrix
  Eigen::Vector3d scale = Eigen::Vector3d::Ones();
  std::optional<Eigen::Matrix4d> matrix;  // a node given as a matrix (glTF never animates it)
};

// L of the node: its matrix, or T R S. Inline, so that each caller compiles it as it compiled the
// code this replaced: GCC fuses the rotation matrix's products into FMAs by context (-march=native),
// and out of line it rounded some entries differently in the last bit.
inline Eigen::Matrix4d local_matrix(const NodeTransform& node) {
  if (node.matrix) return *node.matrix;
  Eigen::Matrix4d local = Eigen::Matrix4d::Identity();
  local.topLeftCorner<3, 3>() = node.rotation.normalized().toRotationMatrix() * node.scale.asDiagonal();
  local.topRightCorner<3, 1>() = node.translation;
  return local;
}

// G(n) of every node in `order` from the local matrices L(n); `world` is resized to the node
// count. Non-finite values propagate (callers that must refuse an overflow check the result).
void world_matrices(std::span<const int> parents, std::span<const int> order, std::span<const Eigen::Matrix4d> local,
                    std::vector<Eigen::Matrix4d>& world);

struct HierarchyOrder {
  std::vector<int> order;  // the nodes reached from the roots, every node after its parent
  int unreached = -1;      // the lowest-numbered node never reached (on or below a cycle), or -1
};

// Depth-first from the roots in index order, each node's children in the order `children` lists
// them (children[n] holds exactly the nodes whose parent is n). With no cycle, `order` has every
// node.
HierarchyOrder depth_first_order(std::span<const int> parents, std::span<const std::vector<int>> children);

}  // namespace odyssey
