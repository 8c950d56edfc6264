// Props that react: rigid bodies falling, resting, kicked and pushed by actors, simulated by Bullet.
//
// Plain data in, plain data out. A PhysicsScene describes the world of one shot (Z up, metres,
// seconds, kilograms): an optional infinite ground plane z = 0, static bodies, dynamic props,
// kinematic colliders that follow given tracks or are posed frame by frame by a function (an
// actor's bones, KinematicSet) and timed impulses. PhysicsModel validates it once (a set's poses
// as they come) and prepares every shape (hulls, mass properties, principal frames); it is
// constant. simulate() builds a fresh Bullet world from the model on every call, so the same model
// always gives byte-identical output (Bullet single-threaded is deterministic for a given
// insertion order, and no state survives between calls), and threads may simulate one model at
// once (Bullet's only globals that a step writes are diagnostic counters).
//
// Time. Output frame f is the state at t = f / fps; frame 0 is the initial state. Between frames
// the world advances by n = ceil(min_substep_rate / fps) equal substeps of dt = 1 / (fps n), so
// every frame is a whole number of substeps whatever the frame rate (30 fps: 8 substeps of
// 1/240 s; 25 fps: 10 of 1/250 s). A kinematic collider's pose at substep k of frame f is
// interpolated between its track's frames f and f + 1 with s = (k + 1) / n: position lerped,
// rotation slerped; Bullet derives the collider's velocity from the pose change over the substep,
// so a foot sweeping through a prop pushes it at the foot's speed, and is never pushed back.
//
// Contact materials. Bullet combines two bodies' coefficients by product (as PyBullet, which
// Kubric drives): friction mu = mu_a mu_b, restitution e = e_a e_b. The defaults are Kubric's MOVi
// values: floor friction 0.3 and restitution 0.5, objects 0.5 and 0.5. Restitution only acts
// above Bullet's 0.2 m/s approach speed, so resting contacts do not jitter.
//
// Collision margins. Bullet keeps a thin shell (margin m) around convex shapes for robust contact.
// Here m = kCollisionMargin = 1 mm, as PyBullet sets for meshes: boxes hold it inside their half
// extents (exact faces, corners rounded by m); hulls get it outside their corners (the surface is
// the hull grown by 1 mm, so a hull rests at most 1 mm high). Hulls are not shrunk by the margin
// instead: that would pull a sharp edge of angle a in by m (1 / sin(a / 2) - 1), centimetres for
// a thin wedge. Boxes and hulls also carry their polyhedral faces, so contacts between them are
// found by separating axes and face clipping (whole faces touch at once) rather than by one GJK
// point per substep. Contacts are tracked from 2 cm apart for every pair of shapes, so a prop
// closing in at up to 2 cm a substep (4.8 m/s at 240 Hz) is stopped at the surface instead of a
// substep's travel inside it.
//
// Solver. Sequential impulses, a fixed number of iterations (Bullet's default 10; PyBullet uses
// 50), warm starting on, order not randomised. Deactivation (sleeping) is disabled for every prop:
// a resting prop costs a few contacts per substep, and nothing wakes or freezes depending on
// thresholds. Continuous collision detection is on for every prop (swept sphere inside the prop)
// so a fast small prop cannot tunnel through the ground within one substep. No damping.
//
// Collision filtering: props collide with everything; static bodies and kinematic colliders only
// with props (an actor's overlapping bone shapes never generate contacts among themselves).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <functional>
#include <span>
#include <vector>

namespace odyssey::physics {

inline constexpr double kDefaultGroundFriction = 0.3;     // Kubric MOVi --floor_friction
inline constexpr double kDefaultGroundRestitution = 0.5;  // Kubric MOVi --floor_restitution
inline constexpr double kDefaultFriction = 0.5;           // Kubric MOVi dynamic objects
inline constexpr double kDefaultRestitution = 0.5;        // Kubric MOVi dynamic objects
inline constexpr double kMaximumFriction = 2.0;           // above any real dry pair (rubber on concrete ~1)
inline constexpr double kCollisionMargin = 1e-3;          // m, see "Collision margins"
// Two bodies touch when their collision surfaces are closer than this (contact statistics only).
inline constexpr double kContactDistance = 1e-3;

// A rigid frame: x_world = rotation * x_local + position. The rotation must be a unit quaternion
// (norm within 1e-6 of 1; it is renormalised).
struct Pose {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
};

// A shape in its own frame.
struct Shape {
  enum class Kind { box, hull, compound, triangle_mesh };
  Kind kind = Kind::box;
  Eigen::Vector3d half_extents = Eigen::Vector3d::Zero();  // box: centred on the frame's origin
  // hull: one part, the convex hull of its points; compound: the union of each part's hull (mass
  // is shared out by volume at one density; overlaps count twice).
  std::vector<std::vector<Eigen::Vector3d>> parts;
  std::vector<Eigen::Vector3d> vertices;      // triangle_mesh (static bodies only)
  std::vector<std::array<int, 3>> triangles;  // triangle_mesh: indices into vertices

  static Shape box(const Eigen::Vector3d& half_extents);
  static Shape hull(std::vector<Eigen::Vector3d> points);
  static Shape compound(std::vector<std::vector<Eigen::Vector3d>> parts);
  static Shape triangle_mesh(std::vector<Eigen::Vector3d> vertices, std::vector<std::array<int, 3>> triangles);
};

struct StaticBody {
  Shape shape;
  Pose pose;
  double friction = kDefaultGroundFriction;
  double restitution = kDefaultGroundRestitution;
};

struct DynamicProp {
  Shape shape;  // box, hull or compound
  double mass = 1;  // kg, > 0; uniform density over the shape's volume
  double friction = kDefaultFriction;        // [0, kMaximumFriction]
  double restitution = kDefaultRestitution;  // [0, 1]
  Pose pose;  // the shape's frame in the world at t = 0
  Eigen::Vector3d linear_velocity = Eigen::Vector3d::Zero();   // of the centre of mass, m/s
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();  // world axes, rad/s
};

// A convex shape moved along a track, with infinite mass (an actor's bone).
struct KinematicCollider {
  std::vector<Eigen::Vector3d> points;  // in the bone's frame; their convex hull collides
  std::vector<Pose> track;              // the bone's frame in the world, one pose per output frame
  double friction = kDefaultFriction;
  double restitution = kDefaultRestitution;
};

// Colliders posed frame by frame instead of by stored tracks (an actor's bones, posed from its
// clip as the simulation needs them, so a long shot holds no track): poses(f, out) writes the pose
// at output frame f of every collider of the set, colliders[k] at out[k] (their `track` is left
// empty). simulate() asks for each frame once, in order from 0; the function must give the same
// poses for the same frame whichever thread calls it. A pose that is not finite or not a unit
// rotation stops the simulation with std::invalid_argument naming the set, the collider and the
// frame.
struct KinematicSet {
  std::vector<KinematicCollider> colliders;
  std::function<void(int frame, std::span<Pose> poses)> poses;
};

// An instantaneous kick, applied at the start of the first substep at or after `time`.
struct Impulse {
  double time = 0;  // s, in [0, (frame_count - 1) / fps]
  int prop = 0;     // index into PhysicsScene::props
  Eigen::Vector3d impulse = Eigen::Vector3d::Zero();  // N s, world axes
  Eigen::Vector3d point = Eigen::Vector3d::Zero();    // where it acts, in the prop's frame
};

struct PhysicsScene {
  double fps = 30;
  int frame_count = 0;  // output frames, >= 1
  double min_substep_rate = 240;  // Hz; see "Time" above
  int solver_iterations = 20;     // [1, 1000]
  Eigen::Vector3d gravity{0, 0, -9.81};
  bool ground = true;  // the infinite plane z = 0
  double ground_friction = kDefaultGroundFriction;
  double ground_restitution = kDefaultGroundRestitution;
  std::vector<StaticBody> statics;
  std::vector<DynamicProp> props;
  std::vector<KinematicCollider> colliders;
  std::vector<KinematicSet> kinematic_sets;  // posed after `colliders`, set after set
  std::vector<Impulse> impulses;
};

// Substeps per output frame: ceil(min_substep_rate / fps), at least 1.
int substeps_per_frame(double fps, double min_substep_rate);

// A shape ready for Bullet: the corners of its convex pieces, expressed in the body's frame (a dynamic prop's principal frame: origin at the centre of mass, axes along the
// principal axes of inertia).
struct PreparedShape {
  Shape::Kind kind = Shape::Kind::box;
  Eigen::Vector3d half_extents = Eigen::Vector3d::Zero();
  std::vector<std::vector<Eigen::Vector3d>> parts;
  std::vector<Eigen::Vector3d> vertices;
  std::vector<std::array<int, 3>> triangles;
  double inner_size = 0;  // half the thinnest extent, m (sizes the swept sphere of CCD)
};

struct PreparedProp {
  PreparedShape shape;
  Pose principal;  // the principal frame in the prop's frame
  Eigen::Vector3d principal_inertia = Eigen::Vector3d::Zero();  // kg m^2
};

// The validated, prepared scene. Throws std::invalid_argument naming what is wrong: "prop 3: mass
// must be finite and > 0, got -1", "collider 7: track has 10 poses, the scene has 300 frames",
// "impulse 2: prop 40 does not exist (30 props)" (callers prefix their own path).
class PhysicsModel {
 public:
  explicit PhysicsModel(PhysicsScene scene);
  const PhysicsScene& scene() const { return scene_; }
  int substeps_per_frame() const { return substeps_; }
  const std::vector<PreparedShape>& statics() const { return statics_; }
  const std::vector<PreparedProp>& props() const { return props_; }
  // The colliders', then every kinematic set's, in order.
  const std::vector<PreparedShape>& colliders() const { return colliders_; }

 private:
  PhysicsScene scene_;
  int substeps_ = 1;
  std::vector<PreparedShape> statics_;
  std::vector<PreparedProp> props_;
  std::vector<PreparedShape> colliders_;
};

// What a prop did, for the shot's report.
struct PropReport {
  double path_length = 0;  // m, sum over frames of the prop origin's displacement
  double top_speed = 0;    // m/s, the largest displacement of the origin between frames times fps
  int contact_frames = 0;  // frames f >= 1 in whose substeps (from f - 1) the prop touched anything
  int contact_events = 0;  // times a touch with another body began (per body, at substep resolution)
  // Deepest overlaps Bullet saw at any substep (m, >= 0): against anything, and against other props.
  double deepest_penetration = 0;
  double deepest_prop_overlap = 0;
};

struct PropMotion {
  int frame_count = 0;
  int prop_count = 0;
  double fps = 0;
  int substeps_per_frame = 0;
  std::vector<double> positions;  // [frame][prop][x y z], the prop frame's origin
  std::vector<double> rotations;  // [frame][prop][x y z w], sign continuous along time
  std::vector<PropReport> reports;  // per prop

  Pose pose(int frame, int prop) const;  // throws std::out_of_range outside the arrays
};

PropMotion simulate(const PhysicsModel& model);

}  // namespace odyssey::physics
