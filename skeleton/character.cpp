#include "skeleton/character.h"

#include <stdexcept>

namespace odyssey {

std::vector<Eigen::Vector3d> skin_mesh_reference(const CharacterMesh& mesh,
                                                 const std::vector<RigidTransform<double>>& joint_world) {
  const std::size_t vertex_count = mesh.positions.size();
  const std::size_t slot_count = mesh.skin_joints.size();
  if (mesh.inverse_bind.size() != slot_count) {
    throw std::invalid_argument("mesh '" + mesh.name + "' has " + std::to_string(slot_count) + " skin joints but " +
                                std::to_string(mesh.inverse_bind.size()) + " inverse bind matrices");
  }
  if (mesh.influence_slots.size() != vertex_count || mesh.influence_weights.size() != vertex_count) {
    throw std::invalid_argument("mesh '" + mesh.name + "' has " + std::to_string(vertex_count) + " positions but " +
                                std::to_string(mesh.influence_slots.size()) + " influence slot rows and " +
                                std::to_string(mesh.influence_weights.size()) + " weight rows");
  }
  // One skinning matrix per slot, M_k = W(joints[k]) * inverse_bind[k]; only its top three rows
  // matter because W is rigid and the mesh's points have w = 1.
  std::vector<Eigen::Matrix<double, 3, 4>> skinning(slot_count);
  for (std::size_t k = 0; k < slot_count; ++k) {
    const int joint = mesh.skin_joints[k];
    if (joint < 0 || static_cast<std::size_t>(joint) >= joint_world.size()) {
      throw std::invalid_argument("mesh '" + mesh.name + "' skin slot " + std::to_string(k) + " names joint " +
                                  std::to_string(joint) + ", but there are " + std::to_string(joint_world.size()) +
                                  " joint transforms");
    }
    Eigen::Matrix<double, 3, 4> world;
    world << joint_world[joint].rotation, joint_world[joint].translation;
    skinning[k] = world * mesh.inverse_bind[k];
  }
  // v_world = sum_k w_k M_k [v; 1]
  std::vector<Eigen::Vector3d> skinned(vertex_count);
  for (std::size_t v = 0; v < vertex_count; ++v) {
    const Eigen::Vector4d point(mesh.positions[v].x(), mesh.positions[v].y(), mesh.positions[v].z(), 1.0);
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int i = 0; i < 4; ++i) {
      const std::size_t slot = mesh.influence_slots[v][i];
      if (slot >= slot_count) {
        throw std::invalid_argument("mesh '" + mesh.name + "' vertex " + std::to_string(v) + " uses skin slot " +
                                    std::to_string(slot) + " of " + std::to_string(slot_count));
      }
      const double weight = mesh.influence_weights[v][i];
      if (weight != 0.0) sum += weight * (skinning[slot] * point);
    }
    skinned[v] = sum;
  }
  return skinned;
}

Eigen::AlignedBox3d Character::rest_bounds() const {
  const std::vector<RigidTransform<double>> rest = skeleton.rest_world();
  Eigen::AlignedBox3d bounds;  // starts empty
  for (const CharacterMesh& mesh : meshes) {
    for (const Eigen::Vector3d& point : skin_mesh_reference(mesh, rest)) bounds.extend(point);
  }
  if (bounds.isEmpty()) {
    for (const RigidTransform<double>& joint : rest) bounds.extend(joint.translation);
  }
  return bounds;
}

}  // namespace odyssey
