#include "physics/bone_colliders.h"

#include <stdexcept>
#include <string>

#include "physics/convex_hull.h"

namespace odyssey::physics {

std::vector<std::vector<Eigen::Vector3d>> fit_bone_colliders(std::span<const Eigen::Vector3d> rest_vertices, std::span<const int> dominant_bone,
                                                             std::span<const Pose> bone_rest_world) {
  if (rest_vertices.size() != dominant_bone.size())
    throw std::invalid_argument("bone colliders: " + std::to_string(rest_vertices.size()) + " rest vertices but " +
                                std::to_string(dominant_bone.size()) + " dominant bones");
  const std::size_t bones = bone_rest_world.size();
  for (std::size_t b = 0; b < bones; ++b)
    if (!bone_rest_world[b].position.allFinite() || !bone_rest_world[b].rotation.coeffs().allFinite() ||
        std::abs(bone_rest_world[b].rotation.norm() - 1) > 1e-6)
      throw std::invalid_argument("bone colliders: bone " + std::to_string(b) + " rest pose is not finite or not a unit rotation");
  std::vector<std::vector<Eigen::Vector3d>> local(bones);
  for (std::size_t v = 0; v < rest_vertices.size(); ++v) {
    const int b = dominant_bone[v];
    if (b == -1) continue;
    if (b < -1 || static_cast<std::size_t>(b) >= bones)
      throw std::invalid_argument("bone colliders: vertex " + std::to_string(v) + " names bone " + std::to_string(b) + " of " + std::to_string(bones));
    if (!rest_vertices[v].allFinite()) throw std::invalid_argument("bone colliders: rest vertex " + std::to_string(v) + " is not finite");
    const Pose& bone = bone_rest_world[b];
    local[b].push_back(bone.rotation.conjugate() * (rest_vertices[v] - bone.position));
  }
  std::vector<std::vector<Eigen::Vector3d>> hulls(bones);
  for (std::size_t b = 0; b < bones; ++b) {
    if (local[b].size() < 4) continue;
    try {
      hulls[b] = convex_hull(local[b]).vertices;  // corners only: a hull of thousands of skin vertices has tens of corners
    } catch (const std::invalid_argument&) {
      // Too thin to bound a solid (see the header): no collider for this bone.
    }
  }
  return hulls;
}

int add_actor_colliders(PhysicsScene& scene, const std::vector<std::vector<Eigen::Vector3d>>& bone_hulls, std::span<const Pose> bone_world_track,
                        double friction, double restitution) {
  const std::size_t bones = bone_hulls.size();
  if (bone_world_track.size() != static_cast<std::size_t>(scene.frame_count) * bones)
    throw std::invalid_argument("actor colliders: bone track holds " + std::to_string(bone_world_track.size()) + " poses, expected " +
                                std::to_string(scene.frame_count) + " frames x " + std::to_string(bones) + " bones");
  int added = 0;
  for (std::size_t b = 0; b < bones; ++b) {
    if (bone_hulls[b].empty()) continue;
    KinematicCollider collider;
    collider.points = bone_hulls[b];
    collider.friction = friction;
    collider.restitution = restitution;
    collider.track.reserve(scene.frame_count);
    for (int f = 0; f < scene.frame_count; ++f) collider.track.push_back(bone_world_track[static_cast<std::size_t>(f) * bones + b]);
    scene.colliders.push_back(std::move(collider));
    ++added;
  }
  return added;
}

int add_actor_colliders(PhysicsScene& scene, const std::vector<std::vector<Eigen::Vector3d>>& bone_hulls,
                        std::function<void(int frame, std::span<Pose> bone_world)> bone_world, double friction, double restitution) {
  KinematicSet set;
  std::vector<int> bone_of;  // collider k is bone bone_of[k]
  for (std::size_t b = 0; b < bone_hulls.size(); ++b) {
    if (bone_hulls[b].empty()) continue;
    KinematicCollider collider;
    collider.points = bone_hulls[b];
    collider.friction = friction;
    collider.restitution = restitution;
    set.colliders.push_back(std::move(collider));
    bone_of.push_back(static_cast<int>(b));
  }
  const int added = static_cast<int>(set.colliders.size());
  if (added == 0) return 0;
  set.poses = [bone_world = std::move(bone_world), bone_of, bones = bone_hulls.size()](int frame, std::span<Pose> poses) {
    std::vector<Pose> all(bones);
    bone_world(frame, all);
    for (std::size_t k = 0; k < bone_of.size(); ++k) poses[k] = all[bone_of[k]];
  };
  scene.kinematic_sets.push_back(std::move(set));
  return added;
}

}  // namespace odyssey::physics
