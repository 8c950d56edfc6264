// Props that react (issue 30): the scattered props of a scene and the simulation of its dynamic
// props, done once before the frame loop, single-threaded, by physics/ (Bullet).
//
// Geometry. A prop's shape lives in its own frame: the vertices as the file (or the box) gives
// them, scaled; the prop's frame in the world is (position, yaw about z). A box collides as a box
// (its bottom face on `position`, so its physics frame sits half its height above), a mesh as the
// convex hull of its scaled vertices, or, asked for (Prop::Dynamics::pieces), as the union of the
// hulls of its connected pieces (vertices joined by shared triangles and equal positions: a
// table's top and legs modelled apart leave room under it). Static boxes collide as boxes, static meshes as their
// triangles; a ground prop adds nothing: the ground is the infinite plane z = 0 in every physics
// scene (a ground's extent is no edge to fall off).
//
// Actors are kinematic colliders of infinite mass: per bone the convex hull of the rest vertices
// it dominates (skinning::dominant_joint: the largest weight), carried by the bone's world
// transform of every frame of the actor's clip on the timeline, so a foot passing through a prop
// pushes it at the foot's speed and a prop never pushes an actor. A vertex-animated actor (an
// .anime mesh) has no bones: it does not collide (the shot lists this under `skipped`).
//
// Motion. The simulation gives each dynamic prop its frame P(f) in every frame; the frame loop and
// the outputs need the rigid motion carrying the mesh as placed to frame f, M(f) = P(f) P(0)^-1
// (exactly the identity at frame 0 and for static props).
//
// Seeds (each its own stream, so adding one kind of draw never moves another): kicks seed + 5000
// (physics/sampling.h draws per prop), scatter places seed + 6000, the template of scattered prop
// k PortableUniform(seed + 7000, k).
//
// Errors are io::InputError naming the scene file (or "scene" for a scene built in code) and the
// JSON path of the prop: "props[2]: ..." for the scene's own, "scatter.props[0]: ..." for a
// template, "scatter: ..." for a region that cannot hold the props.
#pragma once

#include <optional>
#include <vector>

#include "physics/rigid_scene.h"
#include "scene_layouts/scene.h"
#include "scene_layouts/shot.h"

namespace odyssey::scene {

// A prop's triangles in its own frame, unscaled (box corners, or the mesh file's rest vertices
// turned Z up).
struct PropGeometry {
  std::vector<Eigen::Vector3d> positions;
  std::vector<std::uint32_t> triangles;
};

// Throws io::InputError for an unreadable mesh file, std::invalid_argument for a bad size.
PropGeometry load_prop_geometry(const Prop& prop);

// Every prop as one static character in world coordinates as placed (frame_loop.h, StreamProps).
StreamProps build_props(const std::vector<Prop>& props, const std::vector<PropGeometry>& geometry);

// The scene's props followed by its scattered ones (placed on the actors' paths and in the
// region), with their geometry. `actors` are placed on the timeline. When no actor's root goes
// 1 m from its start, the props meant for paths go in the region, and `skipped` says so.
void gather_props(const Scene& scene, const std::vector<PlacedActor>& actors, std::vector<Prop>& props,
                  std::vector<PropGeometry>& geometry, std::vector<std::string>& skipped);

// Simulates the dynamic props among `props` over the shot's frames (actors placed), filling
// shot.props.motion (left empty when no prop is dynamic), shot.prop_reports and shot.skipped.
void simulate_props(const Scene& scene, const std::vector<Prop>& props, const std::vector<PropGeometry>& geometry, Shot& shot);

}  // namespace odyssey::scene
