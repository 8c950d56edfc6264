// The physics module: props fall and rest on the ground, are pushed by kinematic colliders at the
// collider's speed, survive a minute of random kicks without sinking or interpenetrating, and come
// out byte-identical run after run; bad input names the prop.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numbers>
#include <stdexcept>
#include <string>
#include <thread>

#include "physics/bone_colliders.h"
#include "physics/convex_hull.h"
#include "physics/rigid_scene.h"
#include "physics/sampling.h"

namespace odyssey::physics {
namespace {

std::vector<Eigen::Vector3d> box_corners(const Eigen::Vector3d& half) {
  std::vector<Eigen::Vector3d> corners;
  for (int i = 0; i < 8; ++i) corners.emplace_back(i & 1 ? half.x() : -half.x(), i & 2 ? half.y() : -half.y(), i & 4 ? half.z() : -half.z());
  return corners;
}

std::vector<Eigen::Vector3d> icosahedron(double radius) {
  const double phi = (1 + std::sqrt(5.0)) / 2;
  std::vector<Eigen::Vector3d> v;
  for (double a : {-1.0, 1.0})
    for (double b : {-phi, phi}) {
      v.emplace_back(0, a, b);
      v.emplace_back(a, b, 0);
      v.emplace_back(b, 0, a);
    }
  for (auto& p : v) p *= radius / std::sqrt(1 + phi * phi);
  return v;
}

// The corner points of a prop's shape in its own frame (what can touch the ground first).
std::vector<Eigen::Vector3d> corners_of(const Shape& shape) {
  if (shape.kind == Shape::Kind::box) return box_corners(shape.half_extents);
  std::vector<Eigen::Vector3d> all;
  for (const auto& part : shape.parts) all.insert(all.end(), part.begin(), part.end());
  return all;
}

double lowest_z(const PropMotion& motion, int frame, int prop, const std::vector<Eigen::Vector3d>& corners) {
  const Pose pose = motion.pose(frame, prop);
  double low = INFINITY;
  for (const auto& c : corners) low = std::min(low, (pose.rotation * c + pose.position).z());
  return low;
}

double frame_speed(const PropMotion& motion, int frame, int prop) {
  return (motion.pose(frame, prop).position - motion.pose(frame - 1, prop).position).norm() * motion.fps;
}

double frame_turn(const PropMotion& motion, int frame, int prop) {
  return motion.pose(frame, prop).rotation.angularDistance(motion.pose(frame - 1, prop).rotation) * motion.fps;
}

Eigen::Quaterniond tilt(double x_degrees, double y_degrees) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(x_degrees * std::numbers::pi / 180, Eigen::Vector3d::UnitX()) *
                            Eigen::AngleAxisd(y_degrees * std::numbers::pi / 180, Eigen::Vector3d::UnitY()));
}

// Drops one prop with its lowest point 1 m up and checks it comes to rest on the plane z = rest_z.
void expect_settles(const Shape& shape, double rest_z, PhysicsScene scene = {}) {
  const auto corners = corners_of(shape);
  DynamicProp prop;
  prop.shape = shape;
  prop.mass = 2;
  prop.pose.rotation = tilt(12, 7);
  double low = INFINITY;
  for (const auto& c : corners) low = std::min(low, (prop.pose.rotation * c).z());
  prop.pose.position = Eigen::Vector3d(0.1, -0.2, rest_z + 1.0 - low);
  scene.frame_count = 91;  // 3 s at 30 fps
  scene.props = {prop};
  const PropMotion motion = simulate(PhysicsModel(scene));
  // Settled within 2 s: from frame 60 on, the prop moves under 1 cm/s and turns under 0.01 rad/s.
  for (int f = 61; f < motion.frame_count; ++f) {
    EXPECT_LT(frame_speed(motion, f, 0), 0.01) << "frame " << f;
    EXPECT_LT(frame_turn(motion, f, 0), 0.01) << "frame " << f;
  }
  // It lies on the surface: its lowest corner within 5 mm below (penetration) and no higher than
  // a hull's 1 mm collision margin plus 0.5 mm above (a thick margin would show as a gap).
  const double bottom = lowest_z(motion, motion.frame_count - 1, 0, corners) - rest_z;
  EXPECT_GT(bottom, -0.005);
  EXPECT_LT(bottom, kCollisionMargin + 0.0005);
  std::printf("resting gap %.5f m\n", bottom);
  // While it lands, a prop can sink no deeper than one substep's travel at the impact speed:
  // sqrt(2 g 1 m) / 240 Hz = 1.85 cm.
  EXPECT_LT(motion.reports[0].deepest_penetration, std::sqrt(2 * 9.81) / 240);
  EXPECT_GE(motion.reports[0].contact_events, 1);
  // It fell for sqrt(2 / 9.81) = 0.45 s (13.5 frames), then touched the ground in every frame
  // except while a bounce lifted it clear.
  EXPECT_GE(motion.reports[0].contact_frames, 90 - 16 - 10);
}

TEST(PhysicsTest, SubstepsMakeWholeFrames) {
  EXPECT_EQ(substeps_per_frame(30, 240), 8);
  EXPECT_EQ(substeps_per_frame(24, 240), 10);
  EXPECT_EQ(substeps_per_frame(25, 240), 10);  // 250 Hz: 1/25 s is 9.6 substeps of 1/240 s
  EXPECT_EQ(substeps_per_frame(60, 240), 4);
  EXPECT_EQ(substeps_per_frame(240, 240), 1);
  EXPECT_EQ(substeps_per_frame(1000, 240), 1);
  EXPECT_THROW(substeps_per_frame(0, 240), std::invalid_argument);
}

TEST(PhysicsTest, HullOfBoxCornersHasTheBoxMassProperties) {
  // Two routes to the same numbers: the hull integral against the box formula.
  const Eigen::Vector3d half(0.1, 0.15, 0.25), offset(1, 2, 3);
  std::vector<Eigen::Vector3d> points;
  for (const auto& c : box_corners(half)) points.push_back(c + offset);
  points.push_back(offset + Eigen::Vector3d(0.01, -0.02, 0.03));  // an interior point changes nothing
  const ConvexHull hull = convex_hull(points);
  EXPECT_EQ(hull.vertices.size(), 8u);
  EXPECT_NEAR(hull.volume, 8 * half.prod(), 1e-12);
  EXPECT_LT((hull.centroid - offset).norm(), 1e-12);
  const double m = hull.volume;  // unit density
  const Eigen::Vector3d h2 = half.cwiseAbs2();
  const Eigen::Matrix3d expected = (m / 3 * Eigen::Vector3d(h2.y() + h2.z(), h2.x() + h2.z(), h2.x() + h2.y())).asDiagonal();
  EXPECT_LT((hull.unit_inertia - expected).norm(), 1e-12);

  PhysicsScene scene;
  scene.frame_count = 1;
  DynamicProp prop;
  prop.shape = Shape::hull(points);
  prop.mass = 3;
  scene.props = {prop};
  const PhysicsModel model(scene);
  const PreparedProp& prepared = model.props()[0];
  EXPECT_LT((prepared.principal.position - offset).norm(), 1e-12);
  Eigen::Vector3d inertia = prepared.principal_inertia;
  std::sort(inertia.data(), inertia.data() + 3);
  EXPECT_NEAR(inertia[0], 3.0 / 3 * (h2.x() + h2.y()), 1e-12);
  EXPECT_NEAR(inertia[1], 3.0 / 3 * (h2.x() + h2.z()), 1e-12);
  EXPECT_NEAR(inertia[2], 3.0 / 3 * (h2.y() + h2.z()), 1e-12);
}

TEST(PhysicsTest, BoxDroppedFromOneMetreSettles) { expect_settles(Shape::box(Eigen::Vector3d::Constant(0.15)), 0); }

TEST(PhysicsTest, IcosahedronHullDroppedFromOneMetreSettles) { expect_settles(Shape::hull(icosahedron(0.2)), 0); }

TEST(PhysicsTest, CompoundDroppedFromOneMetreSettles) {
  // An L of two boxes: a 0.4 x 0.1 x 0.1 bar and a 0.1 x 0.1 x 0.3 post on its end.
  std::vector<Eigen::Vector3d> bar, post;
  for (const auto& c : box_corners({0.2, 0.05, 0.05})) bar.push_back(c);
  for (const auto& c : box_corners({0.05, 0.05, 0.15})) post.push_back(c + Eigen::Vector3d(0.15, 0, 0.2));
  expect_settles(Shape::compound({bar, post}), 0);
}

TEST(PhysicsTest, BoxSettlesOnAStaticTableAndOnATriangleMeshFloor) {
  PhysicsScene table;
  StaticBody top;
  top.shape = Shape::box({0.6, 0.6, 0.25});
  top.pose.position = {0, 0, 0.25};
  table.statics = {top};
  expect_settles(Shape::box(Eigen::Vector3d::Constant(0.1)), 0.5, table);

  PhysicsScene floor;
  floor.ground = false;
  StaticBody mesh;
  mesh.shape = Shape::triangle_mesh({{-3, -3, 0}, {3, -3, 0}, {3, 3, 0}, {-3, 3, 0}}, {{{0, 1, 2}}, {{0, 2, 3}}});
  mesh.pose.position = {0, 0, 0.3};
  floor.statics = {mesh};
  expect_settles(Shape::box(Eigen::Vector3d::Constant(0.1)), 0.3, floor);
}

TEST(PhysicsTest, KinematicFootPushesAPropAtItsSpeed) {
  // A foot (a 0.2 x 0.1 x 0.08 box on the ground) walks along +x at 1.2 m/s from x = -1; a 0.2 m
  // cube of 1 kg waits at x = 0.5. The foot's front (x = -0.9 + 1.2 t) reaches the cube's back face
  // (x = 0.4) at t = 1.3 / 1.2 = 1.0833 s, between frames 32 and 33.
  const double speed = 1.2, fps = 30;
  PhysicsScene scene;
  scene.fps = fps;
  scene.frame_count = 76;  // 2.5 s
  KinematicCollider foot;
  foot.points = box_corners({0.1, 0.05, 0.04});
  for (int f = 0; f < scene.frame_count; ++f) {
    Pose pose;
    pose.position = {-1.0 + speed * f / fps, 0, 0.04};
    foot.track.push_back(pose);
  }
  scene.colliders = {foot};
  DynamicProp cube;
  cube.shape = Shape::box(Eigen::Vector3d::Constant(0.1));
  cube.mass = 1;
  cube.pose.position = {0.5, 0, 0.1};
  scene.props = {cube};
  const PropMotion motion = simulate(PhysicsModel(scene));
  const Eigen::Vector3d start = motion.pose(0, 0).position;
  for (int f = 0; f <= 32; ++f) EXPECT_LT((motion.pose(f, 0).position - start).norm(), 0.001) << "frame " << f;
  // Half a second after the touch the cube has moved ahead of the foot's path, along +x.
  const Eigen::Vector3d moved = motion.pose(48, 0).position - start;
  EXPECT_GT(moved.x(), 0.3);
  EXPECT_GT(moved.normalized().x(), 0.95);
  // Never faster than the foot bouncing it off: v <= v_foot (1 + e), e = 0.5 * 0.5, plus 10%.
  const double bound = speed * (1 + 0.25) * 1.1;
  for (int f = 1; f < motion.frame_count; ++f) EXPECT_LT(frame_speed(motion, f, 0), bound) << "frame " << f;
  EXPECT_GT(motion.reports[0].top_speed, 0.9 * speed);  // it was pushed at about the foot's speed
  EXPECT_GE(motion.reports[0].contact_events, 2);        // the ground, then the foot
  EXPECT_THROW(motion.pose(motion.frame_count, 0), std::out_of_range);
  EXPECT_THROW(motion.pose(0, 1), std::out_of_range);
}

// 30 props of mixed shapes and sizes scattered on a 6 x 6 m floor, kicked at random.
PhysicsScene kicked_props(std::uint64_t seed, int count, double seconds) {
  PhysicsScene scene;
  scene.fps = 30;
  scene.frame_count = static_cast<int>(seconds * scene.fps) + 1;
  ScatterRequest scatter;
  scatter.seed = seed;
  scatter.region_min = {-3, -3};
  scatter.region_max = {3, 3};
  std::vector<Shape> shapes;
  PortableUniform size(seed, 999);
  for (int i = 0; i < count; ++i) {
    const Eigen::Vector3d half(size.between(0.05, 0.2), size.between(0.05, 0.2), size.between(0.05, 0.2));
    if (i % 3 == 0) {
      shapes.push_back(Shape::box(half));
      scatter.footprint_radii.push_back(half.head<2>().norm());
    } else if (i % 3 == 1) {
      shapes.push_back(Shape::hull(icosahedron(half.x() + 0.05)));
      scatter.footprint_radii.push_back(half.x() + 0.05);
    } else {
      std::vector<Eigen::Vector3d> wedge = box_corners(half);
      wedge.resize(6);  // drop two top corners: a wedge
      shapes.push_back(Shape::hull(wedge));
      scatter.footprint_radii.push_back(half.head<2>().norm());
    }
  }
  const auto placements = scatter_props(scatter);
  std::vector<double> masses;
  for (int i = 0; i < count; ++i) {
    DynamicProp prop;
    prop.shape = shapes[i];
    prop.mass = 600 * size.between(0.5, 1.5) * (i % 3 == 1 ? 0.5 : 1.0) * scatter.footprint_radii[i] * scatter.footprint_radii[i] * 0.2;
    prop.pose.rotation = Eigen::AngleAxisd(placements[i].yaw, Eigen::Vector3d::UnitZ());
    double low = INFINITY;
    for (const auto& c : corners_of(prop.shape)) low = std::min(low, (prop.pose.rotation * c).z());
    prop.pose.position = Eigen::Vector3d(placements[i].position.x(), placements[i].position.y(), 0.02 - low);
    masses.push_back(prop.mass);
    scene.props.push_back(prop);
  }
  ImpulseSampling kicks;
  kicks.seed = seed;
  kicks.rate = 0.2;
  kicks.min_speed_change = 0.5;
  kicks.max_speed_change = 2.0;
  kicks.max_upward = 0.5;
  kicks.lever_arm = 0.05;
  scene.impulses = sample_impulses(kicks, masses, (scene.frame_count - 1) / scene.fps);
  return scene;
}

TEST(PhysicsTest, ThirtyKickedPropsStayAboveGroundAndApart) {
  const PhysicsScene scene = kicked_props(7, 30, 60);
  ASSERT_GT(scene.impulses.size(), 200u);  // 0.2 kicks/s x 60 s x 30 props = 360 expected
  const PropMotion motion = simulate(PhysicsModel(scene));
  // A kick changes a velocity by at most 2 m/s; a prop hit by a heavier one or by two kicks in a row
  // can gain a little more, but nothing physical approaches 2 x 2 m/s x (1 + e).
  const double bound = 2 * 2.0 * (1 + 0.5);
  double top = 0, lowest = INFINITY, deepest = 0, overlap = 0;
  for (int i = 0; i < motion.prop_count; ++i) {
    const auto corners = corners_of(scene.props[i].shape);
    for (int f = 0; f < motion.frame_count; ++f) {
      lowest = std::min(lowest, lowest_z(motion, f, i, corners));
      if (f > 0) top = std::max(top, frame_speed(motion, f, i));
    }
    deepest = std::max(deepest, motion.reports[i].deepest_penetration);
    overlap = std::max(overlap, motion.reports[i].deepest_prop_overlap);
    EXPECT_GT(motion.reports[i].path_length, 0.1) << "prop " << i << " was never kicked away";
  }
  EXPECT_GT(lowest, -0.01);   // in every frame, no corner 1 cm under the floor
  EXPECT_LT(overlap, 0.01);   // at every substep, Bullet's contacts: no two props overlap by 1 cm
  // Nor does anything sink past the 2 cm within which contacts are tracked.
  EXPECT_LT(deepest, 0.02);
  EXPECT_LT(top, bound);      // no frame-to-frame jump beyond the speed bound / fps
  EXPECT_GT(top, 0.5);        // the kicks did act
  std::printf("30 kicked props, 60 s: lowest corner %.4f m, deepest prop overlap %.4f m, deepest contact %.4f m, top speed %.2f m/s\n", lowest,
              overlap, deepest, top);
}

TEST(PhysicsTest, SameSceneGivesByteIdenticalOutput) {
  PhysicsScene scene = kicked_props(11, 12, 8);
  KinematicCollider sweeper;
  sweeper.points = box_corners({0.1, 1.0, 0.1});
  for (int f = 0; f < scene.frame_count; ++f) {
    Pose pose;
    pose.position = {-3.0 + 6.0 * f / (scene.frame_count - 1), 0, 0.1};
    pose.rotation = Eigen::AngleAxisd(0.3 * f / scene.fps, Eigen::Vector3d::UnitZ());
    sweeper.track.push_back(pose);
  }
  scene.colliders = {sweeper};
  const PhysicsModel model(scene);
  const PropMotion a = simulate(model), b = simulate(model), c = simulate(PhysicsModel(scene));
  ASSERT_EQ(a.positions.size(), b.positions.size());
  EXPECT_EQ(std::memcmp(a.positions.data(), b.positions.data(), a.positions.size() * sizeof(double)), 0);
  EXPECT_EQ(std::memcmp(a.rotations.data(), b.rotations.data(), a.rotations.size() * sizeof(double)), 0);
  EXPECT_EQ(std::memcmp(a.positions.data(), c.positions.data(), a.positions.size() * sizeof(double)), 0);
  EXPECT_EQ(std::memcmp(a.rotations.data(), c.rotations.data(), a.rotations.size() * sizeof(double)), 0);
  for (int i = 0; i < a.prop_count; ++i) {
    EXPECT_EQ(a.reports[i].contact_events, b.reports[i].contact_events);
    EXPECT_EQ(a.reports[i].path_length, b.reports[i].path_length);
  }
  // Two threads simulating the one model at once get the same bytes as a lone run.
  PropMotion e, f;
  std::thread first([&] { e = simulate(model); }), second([&] { f = simulate(model); });
  first.join();
  second.join();
  EXPECT_EQ(std::memcmp(a.positions.data(), e.positions.data(), a.positions.size() * sizeof(double)), 0);
  EXPECT_EQ(std::memcmp(a.positions.data(), f.positions.data(), a.positions.size() * sizeof(double)), 0);
  EXPECT_EQ(std::memcmp(a.rotations.data(), f.rotations.data(), a.rotations.size() * sizeof(double)), 0);
  // Another seed scatters and kicks differently: the props end elsewhere.
  PhysicsScene other = kicked_props(12, 12, 8);
  other.colliders = scene.colliders;
  const PropMotion d = simulate(PhysicsModel(other));
  double moved = 0;
  for (std::size_t k = 0; k < a.positions.size(); ++k) moved = std::max(moved, std::abs(a.positions[k] - d.positions[k]));
  EXPECT_GT(moved, 0.1);
}

void expect_rejected(const PhysicsScene& scene, const std::string& who, const std::string& what) {
  try {
    PhysicsModel model(scene);
    ADD_FAILURE() << "accepted; expected '" << who << "' and '" << what << "'";
  } catch (const std::invalid_argument& error) {
    const std::string message = error.what();
    EXPECT_EQ(message.rfind(who + ":", 0), 0u) << message;
    EXPECT_NE(message.find(what), std::string::npos) << message;
  }
}

TEST(PhysicsTest, BadInputNamesTheProp) {
  PhysicsScene good;
  good.frame_count = 10;
  for (int i = 0; i < 3; ++i) {
    DynamicProp prop;
    prop.shape = Shape::box(Eigen::Vector3d::Constant(0.1));
    prop.pose.position = {i * 1.0, 0, 0.1};
    good.props.push_back(prop);
  }
  EXPECT_NO_THROW(PhysicsModel{good});
  auto scene = good;
  scene.props[2].mass = 0;
  expect_rejected(scene, "prop 2", "mass must be finite and > 0");
  scene = good;
  scene.props[1].mass = NAN;
  expect_rejected(scene, "prop 1", "mass");
  scene = good;
  scene.props[1].linear_velocity.y() = INFINITY;
  expect_rejected(scene, "prop 1", "linear velocity is not finite");
  scene = good;
  scene.props[0].angular_velocity.x() = NAN;
  expect_rejected(scene, "prop 0", "angular velocity is not finite");
  scene = good;
  scene.props[2].pose.position.z() = NAN;
  expect_rejected(scene, "prop 2", "position is not finite");
  scene = good;
  scene.props[2].pose.rotation = Eigen::Quaterniond(0.5, 0, 0, 0);
  expect_rejected(scene, "prop 2", "not a unit quaternion");
  scene = good;
  scene.props[1].friction = 3;
  expect_rejected(scene, "prop 1", "friction must be in [0, 2]");
  scene = good;
  scene.props[0].restitution = -0.1;
  expect_rejected(scene, "prop 0", "restitution must be in [0, 1]");
  scene = good;
  scene.props[1].shape = Shape::hull({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {0.5, 0.5, 1e-5}});
  expect_rejected(scene, "prop 1", "no volume");
  scene = good;
  scene.props[1].shape = Shape::hull({{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}});
  expect_rejected(scene, "prop 1", "no volume");
  scene = good;
  scene.props[2].shape = Shape::compound({box_corners({0.1, 0.1, 0.1}), {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}});
  expect_rejected(scene, "prop 2", "part 1: a convex hull needs at least 4 points");
  scene = good;
  scene.props[0].shape = Shape::box({0.1, 0, 0.1});
  expect_rejected(scene, "prop 0", "box half extents");
  scene = good;
  scene.props[0].shape = Shape::triangle_mesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{{0, 1, 2}}});
  expect_rejected(scene, "prop 0", "triangle mesh can only be static");
  scene = good;
  KinematicCollider foot;
  foot.points = box_corners({0.1, 0.1, 0.1});
  foot.track.resize(9);
  scene.colliders = {foot};
  expect_rejected(scene, "collider 0", "track has 9 poses, the scene has 10 frames");
  scene = good;
  scene.impulses = {Impulse{0.1, 3, {1, 0, 0}, {0, 0, 0}}};
  expect_rejected(scene, "impulse 0", "prop 3 does not exist (3 props)");
  scene = good;
  scene.impulses = {Impulse{0.1, 0, {1, 0, 0}, {0, 0, 0}}, Impulse{0.5, 0, {1, 0, 0}, {0, 0, 0}}};
  expect_rejected(scene, "impulse 1", "outside the shot");
  scene = good;
  StaticBody table;
  table.shape = Shape::triangle_mesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{{0, 1, 3}}});
  scene.statics = {table};
  expect_rejected(scene, "static body 0", "triangle 0 names vertex 3 of 3");
}

TEST(PhysicsTest, ScatterKeepsFootprintsApartAndOnPaths) {
  ScatterRequest request;
  request.seed = 5;
  request.region_min = {-2, -1};
  request.region_max = {2, 1};
  request.footprint_radii.assign(20, 0.15);
  request.paths = {{{-5, 0.5}, {0, 0.5}, {0, 3}}};
  request.on_paths = 3;
  request.gap = 0.02;
  request.keep_out = {{{-1, 0}, 0.5}};
  const auto placed = scatter_props(request);
  ASSERT_EQ(placed.size(), 20u);
  for (std::size_t i = 0; i < placed.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) EXPECT_GE((placed[i].position - placed[j].position).norm(), 0.3 + 0.02 - 1e-12);
    EXPECT_GE((placed[i].position - Eigen::Vector2d(-1, 0)).norm(), 0.5 + 0.15 + 0.02 - 1e-12);
    if (i < 3) {
      EXPECT_EQ(placed[i].path, 0);
      const Eigen::Vector2d p = placed[i].position;
      const double off = std::min(std::abs(p.y() - 0.5) + std::max(0.0, p.x()), std::abs(p.x()) + std::max(0.0, 0.5 - p.y()));
      EXPECT_LT(off, 1e-12) << "prop " << i << " at " << p.transpose();
    } else {
      EXPECT_EQ(placed[i].path, -1);
      EXPECT_TRUE((placed[i].position.array() >= request.region_min.array() + 0.15).all());
      EXPECT_TRUE((placed[i].position.array() <= request.region_max.array() - 0.15).all());
    }
    EXPECT_GE(placed[i].yaw, 0);
    EXPECT_LT(placed[i].yaw, 2 * std::numbers::pi);
  }
  // Same seed, same placements, to the bit.
  const auto again = scatter_props(request);
  for (std::size_t i = 0; i < placed.size(); ++i) EXPECT_EQ(std::memcmp(placed[i].position.data(), again[i].position.data(), 16), 0);

  // 100 discs of 0.15 m cover 7.07 m^2; a 4 x 2 m region holds at most 7.26 m^2 of them, and random
  // placement gets nowhere near that: the draws run out, and the message says which prop stuck.
  request.on_paths = 0;
  request.gap = 0;
  request.keep_out.clear();
  request.footprint_radii.assign(100, 0.15);
  try {
    scatter_props(request);
    ADD_FAILURE() << "placed 100 props";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("after 1000 attempts"), std::string::npos) << error.what();
  }
  request.footprint_radii.assign(120, 0.15);
  try {
    scatter_props(request);
    ADD_FAILURE() << "placed 120 props";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("densest packing"), std::string::npos) << error.what();
  }
}

TEST(PhysicsTest, SampledImpulsesFollowTheirRanges) {
  ImpulseSampling sampling;
  sampling.seed = 3;
  sampling.rate = 0.2;
  sampling.max_upward = 0.3;
  sampling.lever_arm = 0.1;
  std::vector<double> masses(200);
  for (std::size_t i = 0; i < masses.size(); ++i) masses[i] = 0.5 + 0.01 * i;
  const auto kicks = sample_impulses(sampling, masses, 60);
  // 200 props x 0.2/s x 60 s = 2400 expected; the count per prop varies by less than one around
  // rate x duration = 12, so the total is within 200 of that.
  EXPECT_NEAR(static_cast<double>(kicks.size()), 2400, 200);
  for (std::size_t k = 0; k < kicks.size(); ++k) {
    const Impulse& kick = kicks[k];
    if (k > 0) {
      EXPECT_LE(kicks[k - 1].time, kick.time);
    }
    EXPECT_GE(kick.time, 0);
    EXPECT_LT(kick.time, 60);
    const double dv = kick.impulse.norm() / masses[kick.prop];
    EXPECT_GE(dv, 0.5 - 1e-12);
    EXPECT_LE(dv, 2.0 + 1e-12);
    EXPECT_GE(kick.impulse.z() / kick.impulse.norm(), -1e-12);
    EXPECT_LE(kick.impulse.z() / kick.impulse.norm(), 0.3 + 1e-12);
    EXPECT_LE(kick.point.norm(), 0.1);
  }
  EXPECT_THROW(sample_impulses(sampling, std::vector<double>{1.0, -1.0}, 60), std::invalid_argument);
}

TEST(PhysicsTest, BoneCollidersHoldTheirBonesVertices) {
  // Two bones: bone 0 at the origin dominates a 0.2 m cube of skin around it; bone 1 at z = 1,
  // turned 90 degrees about z, dominates a 0.4 x 0.2 x 0.6 block around (0, 0, 1.2); bone 2 only 3
  // vertices; bone 3 a flat patch.
  std::vector<Eigen::Vector3d> vertices;
  std::vector<int> dominant;
  for (const auto& c : box_corners({0.1, 0.1, 0.1})) {
    vertices.push_back(c);
    dominant.push_back(0);
  }
  vertices.emplace_back(0.01, 0.02, 0.03);  // inside bone 0's hull
  dominant.push_back(0);
  for (const auto& c : box_corners({0.2, 0.1, 0.3})) {
    vertices.push_back(c + Eigen::Vector3d(0, 0, 1.2));
    dominant.push_back(1);
  }
  for (int k = 0; k < 3; ++k) {
    vertices.emplace_back(k, 5, 5);
    dominant.push_back(2);
  }
  for (int k = 0; k < 6; ++k) {
    vertices.emplace_back(k % 3, k / 3, 7);
    dominant.push_back(3);
  }
  vertices.emplace_back(9, 9, 9);
  dominant.push_back(-1);
  std::vector<Pose> bones(4);
  bones[1].position = {0, 0, 1};
  bones[1].rotation = Eigen::AngleAxisd(std::numbers::pi / 2, Eigen::Vector3d::UnitZ());
  const auto hulls = fit_bone_colliders(vertices, dominant, bones);
  ASSERT_EQ(hulls.size(), 4u);
  EXPECT_EQ(hulls[0].size(), 8u);
  ASSERT_EQ(hulls[1].size(), 8u);
  EXPECT_TRUE(hulls[2].empty());
  EXPECT_TRUE(hulls[3].empty());
  // In bone 1's frame the block's x extent (0.2 half) lies along local -y/+y, its y along x.
  Eigen::Vector3d low = Eigen::Vector3d::Constant(INFINITY), high = -low;
  for (const auto& p : hulls[1]) {
    low = low.cwiseMin(p);
    high = high.cwiseMax(p);
  }
  EXPECT_LT((low - Eigen::Vector3d(-0.1, -0.2, -0.1)).norm(), 1e-12);
  EXPECT_LT((high - Eigen::Vector3d(0.1, 0.2, 0.5)).norm(), 1e-12);

  PhysicsScene scene;
  scene.frame_count = 2;
  std::vector<Pose> track(2 * 4);
  EXPECT_EQ(add_actor_colliders(scene, hulls, track), 2);
  EXPECT_EQ(scene.colliders.size(), 2u);
  EXPECT_THROW(add_actor_colliders(scene, hulls, std::vector<Pose>(7)), std::invalid_argument);
  dominant[0] = 4;
  try {
    fit_bone_colliders(vertices, dominant, bones);
    ADD_FAILURE() << "accepted bone 4 of 4";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("vertex 0 names bone 4 of 4"), std::string::npos) << error.what();
  }
}

}  // namespace
}  // namespace odyssey::physics
