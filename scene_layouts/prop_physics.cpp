#include "scene_layouts/prop_physics.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <numbers>
#include <stdexcept>

#include "mocap_io/gltf_character.h"
#include "mocap_io/input_error.h"
#include "mocap_io/obj_mesh.h"
#include "physics/bone_colliders.h"
#include "physics/convex_hull.h"
#include "physics/sampling.h"
#include "scene_layouts/placement.h"
#include "skinning/sampling.h"

namespace odyssey::scene {
namespace {

// How far (m) from its start an actor's root must get for scattered props to go on its path.
constexpr double kMinimumScatterPath = 1.0;

std::string scene_file(const Scene& scene) { return scene.file.empty() ? std::string("scene") : scene.file; }

Eigen::Quaterniond yaw_quaternion(double degrees) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(degrees * std::numbers::pi / 180, Eigen::Vector3d::UnitZ()));
}

// The prop's physics frame and shape: a box about its centre, half its height above `position`;
// a mesh's hull in the prop's own frame.
physics::Pose physics_pose(const Prop& prop) {
  physics::Pose pose;
  pose.rotation = yaw_quaternion(prop.yaw_deg);
  pose.position = prop.position;
  if (prop.kind == Prop::Kind::box) pose.position += pose.rotation * Eigen::Vector3d(0, 0, prop.scale * prop.size.z() / 2);
  return pose;
}

// The connected pieces of a mesh, each as its scaled points: vertices are joined by the triangles
// they share and by equal positions (a file splits a vertex where its normals or UVs differ, not
// where the surface does). Vertices on no triangle belong to no piece.
std::vector<std::vector<Eigen::Vector3d>> mesh_pieces(const Prop& prop, const PropGeometry& geometry) {
  const std::size_t count = geometry.positions.size();
  std::vector<std::size_t> parent(count);
  for (std::size_t v = 0; v < count; ++v) parent[v] = v;
  const auto root = [&](std::size_t v) {
    while (parent[v] != v) v = parent[v] = parent[parent[v]];
    return v;
  };
  const auto join = [&](std::size_t a, std::size_t b) {
    a = root(a), b = root(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  };
  std::map<std::array<double, 3>, std::size_t> first_at;
  for (std::size_t v = 0; v < count; ++v) {
    const Eigen::Vector3d& p = geometry.positions[v];
    const auto [slot, added] = first_at.try_emplace({p.x(), p.y(), p.z()}, v);
    if (!added) join(slot->second, v);
  }
  std::vector<char> used(count, 0);
  for (std::size_t t = 0; t + 2 < geometry.triangles.size(); t += 3) {
    join(geometry.triangles[t], geometry.triangles[t + 1]);
    join(geometry.triangles[t], geometry.triangles[t + 2]);
    for (int c = 0; c < 3; ++c) used[geometry.triangles[t + c]] = 1;
  }
  // Pieces in the order of their first vertex, so the shape does not depend on a map's order.
  std::map<std::size_t, std::size_t> piece_of_root;
  std::vector<std::vector<Eigen::Vector3d>> pieces;
  for (std::size_t v = 0; v < count; ++v) {
    if (!used[v]) continue;
    const auto [slot, added] = piece_of_root.try_emplace(root(v), pieces.size());
    if (added) pieces.emplace_back();
    pieces[slot->second].push_back(prop.scale * geometry.positions[v]);
  }
  return pieces;
}

physics::Shape physics_shape(const Prop& prop, const PropGeometry& geometry) {
  if (prop.kind == Prop::Kind::box) return physics::Shape::box(prop.scale * prop.size / 2);
  if (prop.dynamics && prop.dynamics->pieces) return physics::Shape::compound(mesh_pieces(prop, geometry));
  std::vector<Eigen::Vector3d> points;
  points.reserve(geometry.positions.size());
  for (const Eigen::Vector3d& p : geometry.positions) points.push_back(prop.scale * p);
  return physics::Shape::hull(std::move(points));
}

// Where an actor's bones are, every frame: hulls fitted once to the rest mesh, tracks from the
// clip on the timeline.
int add_actor(const PlacedActor& actor, std::map<const ActorMotion*, std::vector<std::vector<Eigen::Vector3d>>>& hulls_of,
              physics::PhysicsScene& world) {
  const Character& character = actor.motion->character;
  const std::vector<RigidTransform<double>> rest = character.skeleton.rest_world();
  auto [slot, added] = hulls_of.try_emplace(actor.motion.get());
  if (added) {
    std::vector<Eigen::Vector3d> vertices;
    std::vector<int> dominant;
    for (const CharacterMesh& mesh : character.meshes) {
      const std::vector<Eigen::Vector3d> at_rest = skin_mesh_reference(mesh, rest);
      vertices.insert(vertices.end(), at_rest.begin(), at_rest.end());
      for (std::size_t v = 0; v < mesh.positions.size(); ++v) dominant.push_back(skinning::dominant_joint(mesh, v));
    }
    std::vector<physics::Pose> bones(rest.size());
    for (std::size_t j = 0; j < rest.size(); ++j) bones[j] = {rest[j].translation, Eigen::Quaterniond(rest[j].rotation).normalized()};
    slot->second = physics::fit_bone_colliders(vertices, dominant, bones);
  }
  // The bones are posed from the actor's clip as the simulation reaches each frame: no track.
  const TimedClip* clip = &actor.clip;
  return physics::add_actor_colliders(world, slot->second, [clip](int frame, std::span<physics::Pose> bones) {
    KinematicData<double> pose(clip->skeleton().kinematics());
    clip->world_pose(frame, pose);
    for (std::size_t j = 0; j < bones.size(); ++j) {
      bones[j] = {pose.world[j].translation, Eigen::Quaterniond(pose.world[j].rotation).normalized()};
    }
  });
}

}  // namespace

PropGeometry load_prop_geometry(const Prop& prop) {
  PropGeometry out;
  std::vector<Eigen::Vector3d>& positions = out.positions;
  std::vector<std::uint32_t>& triangles = out.triangles;
  if (prop.kind == Prop::Kind::ground) {
    const double x = prop.size.x() / 2, y = prop.size.y() / 2;
    if (!(x > 0 && y > 0 && std::isfinite(x) && std::isfinite(y))) {
      throw std::invalid_argument("prop '" + prop.name + "': a ground needs a positive size x, y");
    }
    positions = {{-x, -y, 0}, {x, -y, 0}, {x, y, 0}, {-x, y, 0}};
    triangles = {0, 1, 2, 0, 2, 3};
  } else if (prop.kind == Prop::Kind::box) {
    const Eigen::Vector3d h(prop.size.x() / 2, prop.size.y() / 2, prop.size.z());
    if (!((h.array() > 0).all() && h.allFinite())) {
      throw std::invalid_argument("prop '" + prop.name + "': a box needs a positive size x, y, z");
    }
    // Corner c of the box is (+-x, +-y, 0 or z) by its bits; two triangles per face, outward
    // winding. Each face gets its own four vertices, so a face's vertex normals are its own
    // normal: renderers shade the box flat and the normal maps (dense_maps.h) agree.
    constexpr std::array<std::uint32_t, 36> kFaces = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
                                                      2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5};
    for (std::size_t face = 0; face < 6; ++face) {
      std::map<std::uint32_t, std::uint32_t> vertex_of_corner;
      for (std::size_t k = 6 * face; k < 6 * face + 6; ++k) {
        const std::uint32_t c = kFaces[k];
        const auto [slot, added] = vertex_of_corner.try_emplace(c, static_cast<std::uint32_t>(positions.size()));
        if (added) positions.emplace_back(c & 1 ? h.x() : -h.x(), c & 2 ? h.y() : -h.y(), c & 4 ? h.z() : 0.0);
        triangles.push_back(slot->second);
      }
    }
  } else {
    std::string extension = std::filesystem::path(prop.path).extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if (extension == ".obj") {
      const io::ObjMesh mesh = io::load_obj(prop.path);
      for (const Eigen::Vector3f& p : mesh.positions) {
        // OBJ files from Blender's default export are Y up, -Z forward: (x, y, z) -> (x, -z, y).
        positions.push_back(prop.up_z ? p.cast<double>() : Eigen::Vector3d(p.x(), -p.z(), p.y()));
      }
      triangles = mesh.triangles;
    } else if (extension == ".glb" || extension == ".gltf") {
      const Character character = io::load_character(prop.path);
      const std::vector<RigidTransform<double>> rest = character.skeleton.rest_world();
      for (const CharacterMesh& mesh : character.meshes) {
        const auto offset = static_cast<std::uint32_t>(positions.size());
        const std::vector<Eigen::Vector3d> skinned = skin_mesh_reference(mesh, rest);
        positions.insert(positions.end(), skinned.begin(), skinned.end());
        for (const std::uint32_t corner : mesh.triangles) triangles.push_back(offset + corner);
      }
      if (triangles.empty()) throw io::InputError(prop.path, "no triangles: a prop mesh needs some");
    } else {
      throw io::InputError(prop.path, "unsupported prop mesh type '" + extension + "' (expected .glb, .gltf or .obj)");
    }
  }
  return out;
}

// A static character of one joint at the identity whose meshes are the props in world
// coordinates, rigidly bound to it.
StreamProps build_props(const std::vector<Prop>& props, const std::vector<PropGeometry>& geometry) {
  StreamProps out;
  out.character.name = "props";
  out.character.skeleton = Skeleton({"props"}, {-1}, {Eigen::Vector3d::Zero()}, {Eigen::Quaterniond::Identity()});
  for (std::size_t k = 0; k < props.size(); ++k) {
    const Prop& prop = props[k];
    const Eigen::Matrix3d rotation = yaw_rotation(prop.yaw_deg) * prop.scale;
    CharacterMesh mesh;
    mesh.name = prop.name;
    for (const Eigen::Vector3d& p : geometry.at(k).positions) {
      const Eigen::Vector3d world = rotation * p + prop.position;
      if (!world.allFinite()) throw std::invalid_argument("prop '" + prop.name + "': a vertex is not finite");
      mesh.positions.push_back(world.cast<float>());
    }
    mesh.triangles = geometry[k].triangles;
    mesh.skin_joints = {0};
    mesh.inverse_bind = {Eigen::Matrix4d::Identity()};
    mesh.influence_slots.assign(mesh.positions.size(), {0, 0, 0, 0});
    mesh.influence_weights.assign(mesh.positions.size(), {1, 0, 0, 0});
    out.character.meshes.push_back(std::move(mesh));
    out.character.source_node_of_joint = {0};
    out.character.source_scale_of_joint = {1};
    out.names.push_back(prop.name);
  }
  return out;
}

void gather_props(const Scene& scene, const std::vector<PlacedActor>& actors, std::vector<Prop>& props, std::vector<PropGeometry>& geometry,
                  std::vector<std::string>& skipped) {
  props = scene.props;
  geometry.clear();
  for (const Prop& prop : props) geometry.push_back(load_prop_geometry(prop));
  if (!scene.scatter) return;
  const SceneScatter& scatter = *scene.scatter;
  // Templates: their geometry, footprint radius about their origin (scaled) and the height that
  // stands them on z = 0: a box's bottom face is its origin; a mesh's hull is grown by Bullet's
  // margin, so it is lifted by that much to start just touching.
  std::vector<PropGeometry> shapes;
  std::vector<double> radii, lift;
  for (std::size_t t = 0; t < scatter.props.size(); ++t) {
    const Prop& prop = scatter.props[t];
    shapes.push_back(load_prop_geometry(prop));
    double radius = 0, bottom = INFINITY;
    for (const Eigen::Vector3d& p : shapes.back().positions) {
      radius = std::max(radius, prop.scale * p.head<2>().norm());
      bottom = std::min(bottom, prop.scale * p.z());
    }
    if (!(radius > 0)) throw io::InputError(scene_file(scene), "scatter.props[" + std::to_string(t) + "]: the prop has no footprint on the ground");
    radii.push_back(radius);
    lift.push_back(prop.kind == Prop::Kind::box ? 0.0 : physics::kCollisionMargin - bottom);
  }
  physics::ScatterRequest request;
  request.seed = scene.seed + 6000;
  request.region_min = scatter.region.min();
  request.region_max = scatter.region.max();
  request.on_paths = scatter.on_paths;
  request.gap = scatter.gap;
  for (const PlacedActor& actor : actors) {
    const std::vector<Eigen::Vector2d> track = root_track(actor.clip, actor.motion->root_joint);
    request.keep_out.push_back({track.at(0), 0.15 * actor.motion->character.rest_bounds().sizes().z()});
    // Only paths that go somewhere: an actor walking on the spot (a cycle in place) sways about
    // its start, inside its own keep-out disc, however long its wiggling path.
    double reach = 0;
    for (const Eigen::Vector2d& at : track) reach = std::max(reach, (at - track[0]).norm());
    if (reach >= kMinimumScatterPath) request.paths.push_back(track);
  }
  if (scatter.on_paths > 0 && request.paths.empty()) {
    request.on_paths = 0;
    skipped.push_back("scatter.on_paths: no actor's root gets " + std::to_string(static_cast<int>(kMinimumScatterPath * 100)) +
                      " cm from its start, so the props meant for paths went in the region");
  }
  std::vector<int> chosen(scatter.count);
  for (int k = 0; k < scatter.count; ++k) {
    physics::PortableUniform draw(scene.seed + 7000, static_cast<std::uint64_t>(k));
    chosen[k] = std::min(static_cast<int>(draw.next() * static_cast<double>(scatter.props.size())), static_cast<int>(scatter.props.size()) - 1);
    request.footprint_radii.push_back(radii[chosen[k]]);
  }
  std::vector<physics::ScatterPlacement> placed;
  try {
    placed = physics::scatter_props(request);
  } catch (const std::invalid_argument& error) {
    const std::string message = error.what();
    throw io::InputError(scene_file(scene), message.starts_with("scatter") ? message : "scatter: " + message);
  }
  for (int k = 0; k < scatter.count; ++k) {
    Prop prop = scatter.props[chosen[k]];
    prop.name += "_" + std::to_string(k);
    prop.position = Eigen::Vector3d(placed[k].position.x(), placed[k].position.y(), lift[chosen[k]]);
    prop.yaw_deg = placed[k].yaw * 180 / std::numbers::pi;
    props.push_back(std::move(prop));
    geometry.push_back(shapes[chosen[k]]);
  }
}

void simulate_props(const Scene& scene, const std::vector<Prop>& props, const std::vector<PropGeometry>& geometry, Shot& shot) {
  shot.prop_reports.assign(props.size(), std::nullopt);
  if (std::none_of(props.begin(), props.end(), [](const Prop& p) { return p.dynamics.has_value(); })) return;
  const auto start = std::chrono::steady_clock::now();
  // The JSON path of prop k: the scene's own, then the scattered (from their template).
  const std::size_t own = scene.props.size();
  const auto json_path = [&](std::size_t k) {
    if (k < own) return "props[" + std::to_string(k) + "]";
    const std::string name = props[k].name.substr(0, props[k].name.rfind('_'));
    for (std::size_t t = 0; t < scene.scatter->props.size(); ++t) {
      if (scene.scatter->props[t].name == name) return "scatter.props[" + std::to_string(t) + "]";
    }
    return std::string("scatter");
  };
  const auto fail = [&](std::size_t k, const std::string& problem) { throw io::InputError(scene_file(scene), json_path(k) + ": " + problem); };

  physics::PhysicsScene world;
  world.fps = shot.fps;
  world.frame_count = shot.frames;
  std::vector<std::size_t> prop_of;  // physics prop -> shot prop
  std::vector<double> masses;
  for (std::size_t k = 0; k < props.size(); ++k) {
    const Prop& prop = props[k];
    if (prop.kind == Prop::Kind::ground) continue;
    if (!prop.dynamics) {
      physics::StaticBody body;
      if (prop.kind == Prop::Kind::box) {
        body.shape = physics_shape(prop, geometry[k]);
        body.pose = physics_pose(prop);
      } else {
        std::vector<Eigen::Vector3d> vertices;
        for (const Eigen::Vector3f& p : shot.props.character.meshes.at(k).positions) vertices.push_back(p.cast<double>());
        std::vector<std::array<int, 3>> triangles;
        const std::vector<std::uint32_t>& corners = geometry[k].triangles;
        for (std::size_t t = 0; t + 2 < corners.size(); t += 3) triangles.push_back({int(corners[t]), int(corners[t + 1]), int(corners[t + 2])});
        body.shape = physics::Shape::triangle_mesh(std::move(vertices), std::move(triangles));
      }
      world.statics.push_back(std::move(body));
      continue;
    }
    const Prop::Dynamics& d = *prop.dynamics;
    physics::DynamicProp body;
    if (prop.kind == Prop::Kind::mesh && d.pieces) {
      // Each piece's hull checked here, so the error names the prop's JSON path.
      const std::vector<std::vector<Eigen::Vector3d>> pieces = mesh_pieces(prop, geometry[k]);
      for (std::size_t p = 0; p < pieces.size(); ++p) {
        try {
          physics::convex_hull(pieces[p]);
        } catch (const std::invalid_argument& error) {
          fail(k, "collision pieces: piece " + std::to_string(p) + " of " + std::to_string(pieces.size()) +
                      " has no volume for its convex hull: " + error.what());
        }
      }
    } else if (prop.kind == Prop::Kind::mesh) {
      // The hull's own check, here so the error names the prop's JSON path.
      std::vector<Eigen::Vector3d> points;
      for (const Eigen::Vector3d& p : geometry[k].positions) points.push_back(prop.scale * p);
      try {
        physics::convex_hull(points);
      } catch (const std::invalid_argument& error) {
        fail(k, std::string("a dynamic mesh needs a volume for its convex hull: ") + error.what());
      }
    }
    body.shape = physics_shape(prop, geometry[k]);
    body.pose = physics_pose(prop);
    body.mass = d.mass;
    body.friction = d.friction;
    body.restitution = d.restitution;
    // The velocity given is the prop origin's; the physics frame (a box's centre) at offset r from
    // it moves at v + w x r.
    body.linear_velocity = d.velocity + d.angular_velocity.cross(body.pose.position - prop.position);
    body.angular_velocity = d.angular_velocity;
    world.props.push_back(std::move(body));
    prop_of.push_back(k);
    masses.push_back(d.mass);
  }
  std::map<const ActorMotion*, std::vector<std::vector<Eigen::Vector3d>>> hulls_of;  // actors of one source share theirs
  for (std::size_t a = 0; a < shot.actors.size(); ++a) {
    if (shot.actors[a].clip.vertex_animated()) {
      shot.skipped.push_back("actor '" + shot.actors[a].name + "': a vertex-animated mesh has no bones to collide with: the props pass through it");
      continue;
    }
    add_actor(shot.actors[a], hulls_of, world);
  }
  const double duration = (shot.frames - 1) / shot.fps;
  if (scene.forces && duration > 0) {
    const SceneForces& f = *scene.forces;
    physics::ImpulseSampling sampling;
    sampling.seed = scene.seed + 5000;
    sampling.rate = f.count ? *f.count / duration : f.rate;
    sampling.min_speed_change = f.min_speed_change;
    sampling.max_speed_change = f.max_speed_change;
    sampling.max_upward = f.max_upward;
    sampling.lever_arm = f.lever_arm;
    try {
      world.impulses = physics::sample_impulses(sampling, masses, duration);
    } catch (const std::invalid_argument& error) {
      throw io::InputError(scene_file(scene), std::string("forces: ") + error.what());
    }
  }
  std::optional<physics::PhysicsModel> model;
  try {
    model.emplace(std::move(world));
  } catch (const std::invalid_argument& error) {
    // "prop N: ..." names the physics prop; anything else is the shot's as a whole.
    const std::string message = error.what();
    std::size_t used = 0;
    if (message.starts_with("prop ")) {
      const int n = std::stoi(message.substr(5), &used);
      if (n >= 0 && static_cast<std::size_t>(n) < prop_of.size()) fail(prop_of[n], message.substr(5 + used + 2));
    }
    throw io::InputError(scene_file(scene), "props: " + message);
  }
  const physics::PropMotion motion = physics::simulate(*model);
  const std::size_t count = props.size();
  shot.props.motion.assign(static_cast<std::size_t>(shot.frames) * count, RigidTransform<double>{});
  for (std::size_t i = 0; i < prop_of.size(); ++i) {
    const std::size_t k = prop_of[i];
    const physics::Pose first = motion.pose(0, static_cast<int>(i));
    for (int f = 1; f < shot.frames; ++f) {
      // M(f) = P(f) P(0)^-1: R = R_f R_0^T, t = p_f - R p_0.
      const physics::Pose now = motion.pose(f, static_cast<int>(i));
      RigidTransform<double>& m = shot.props.motion[f * count + k];
      m.rotation = (now.rotation * first.rotation.conjugate()).normalized().toRotationMatrix();
      m.translation = now.position - m.rotation * first.position;
    }
    shot.prop_reports[k] = motion.reports[i];
  }
  shot.physics_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace odyssey::scene
