// Kinematic colliders for an actor: one convex hull per bone, fitted once to the rest mesh and then
// carried along by the bone's world transform frame after frame.
//
// A bone's hull is the convex hull of the rest vertices it dominates (its weight is the largest
// of the vertex's influences), expressed in the bone's rest frame: p_local = R_b^T (p - t_b).
// Posed, the hull follows the bone rigidly; skinning bends the surface between bones, so hulls of
// neighbours overlap at joints and miss a little of the bent skin, which is fine for pushing props.
// A bone that dominates fewer than 4 vertices, or a set thinner than kMinimumHullThickness (a flat
// patch, a line), gets no collider: it has no volume to push with, and its neighbours' hulls cover
// the region around it.
#pragma once

#include <Eigen/Core>
#include <span>
#include <vector>

#include "physics/rigid_scene.h"

namespace odyssey::physics {

// Per bone, the hull's corners in the bone's frame (empty: no collider). rest_vertices and
// dominant_bone have one entry per vertex (dominant_bone -1: no influence); bone_rest_world has
// one pose per bone. Throws std::invalid_argument on mismatched sizes, a bone index out of range
// or non-finite data, naming the vertex or bone.
std::vector<std::vector<Eigen::Vector3d>> fit_bone_colliders(std::span<const Eigen::Vector3d> rest_vertices, std::span<const int> dominant_bone,
                                                             std::span<const Pose> bone_rest_world);

// Appends one KinematicCollider per fitted bone to `scene`: bone_world_track holds the bones'
// world frames frame-major, [frame][bone] (scene.frame_count x bone count). Returns how many were
// added. Throws std::invalid_argument when the track's size is not frame_count times the bone count.
int add_actor_colliders(PhysicsScene& scene, const std::vector<std::vector<Eigen::Vector3d>>& bone_hulls, std::span<const Pose> bone_world_track,
                        double friction = kDefaultFriction, double restitution = kDefaultRestitution);
// The same posed frame by frame (a KinematicSet): bone_world(f, out) writes every bone's world
// frame at output frame f (out.size() is the bone count). Returns how many colliders were added.
int add_actor_colliders(PhysicsScene& scene, const std::vector<std::vector<Eigen::Vector3d>>& bone_hulls,
                        std::function<void(int frame, std::span<Pose> bone_world)> bone_world, double friction = kDefaultFriction,
                        double restitution = kDefaultRestitution);

}  // namespace odyssey::physics
