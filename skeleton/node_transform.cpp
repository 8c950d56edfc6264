#include "skeleton/node_transform.h"

#include <algorithm>

namespace odyssey {

void world_matrices(std::span<const int> parents, std::span<const int> order, std::span<const Eigen::Matrix4d> local,
                    std::vector<Eigen::Matrix4d>& world) {
  world.resize(parents.size());
  for (const int n : order) world[n] = parents[n] < 0 ? local[n] : Eigen::Matrix4d(world[parents[n]] * local[n]);
}

HierarchyOrder depth_first_order(std::span<const int> parents, std::span<const std::vector<int>> children) {
  const int n = static_cast<int>(parents.size());
  HierarchyOrder result;
  result.order.reserve(n);
  // Roots pushed last-first and children in reverse, so the stack pops them in their own order.
  std::vector<int> stack;
  for (int node = n - 1; node >= 0; --node) {
    if (parents[node] < 0) stack.push_back(node);
  }
  while (!stack.empty()) {
    const int node = stack.back();
    stack.pop_back();
    result.order.push_back(node);
    for (auto it = children[node].rbegin(); it != children[node].rend(); ++it) stack.push_back(*it);
  }
  if (static_cast<int>(result.order.size()) != n) {
    std::vector<bool> reached(n, false);
    for (const int node : result.order) reached[node] = true;
    result.unreached = static_cast<int>(std::find(reached.begin(), reached.end(), false) - reached.begin());
  }
  return result;
}

}  // namespace odyssey
