#include "skeleton/fk.h"

#include <numeric>

namespace odyssey {

KinematicModel::KinematicModel(std::vector<int> parents_in, std::vector<RigidTransform<double>> rest_in,
                               std::vector<int> order_in, std::vector<std::uint8_t> rotation_in_world_in)
    : parents(std::move(parents_in)), rotation_in_world(std::move(rotation_in_world_in)), order(std::move(order_in)),
      rest(std::move(rest_in)) {
  const std::size_t n = parents.size();
  const auto fail = [](const std::string& what) { throw std::invalid_argument("kinematic model: " + what); };
  const auto sizes = [&](const char* what, std::size_t size) {
    if (size != n) fail(std::to_string(n) + " parents but " + std::to_string(size) + " " + what);
  };
  if (order.empty()) {
    order.resize(n);
    std::iota(order.begin(), order.end(), 0);
  }
  if (rotation_in_world.empty()) rotation_in_world.assign(n, 0);
  if (rest.empty()) rest.resize(n);
  sizes("rest transforms", rest.size());
  sizes("joints in the order", order.size());
  sizes("rotation_in_world flags", rotation_in_world.size());
  std::vector<std::uint8_t> placed(n, 0);
  for (const int j : order) {
    if (j < 0 || std::size_t(j) >= n) fail("joint " + std::to_string(j) + " in the order is out of range");
    if (placed[j]) fail("joint " + std::to_string(j) + " is twice in the order");
    const int parent = parents[j];
    if (parent < -1 || parent >= static_cast<int>(n)) {
      fail("joint " + std::to_string(j) + " has parent " + std::to_string(parent) + ", out of range");
    }
    if (parent >= 0 && !placed[parent]) {
      fail("joint " + std::to_string(j) + " comes before its parent " + std::to_string(parent) + " in the order");
    }
    placed[j] = 1;
  }
}

}  // namespace odyssey
