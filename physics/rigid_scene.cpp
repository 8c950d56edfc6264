#include "physics/rigid_scene.h"

#include <BulletCollision/CollisionShapes/btBoxShape.h>
#include <BulletCollision/CollisionShapes/btBvhTriangleMeshShape.h>
#include <BulletCollision/CollisionShapes/btCompoundShape.h>
#include <BulletCollision/CollisionShapes/btConvexHullShape.h>
#include <BulletCollision/CollisionShapes/btStaticPlaneShape.h>
#include <BulletCollision/CollisionShapes/btTriangleMesh.h>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <btBulletDynamicsCommon.h>
#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>

#include "physics/convex_hull.h"

namespace odyssey::physics {
namespace {

constexpr double kUnitTolerance = 1e-6;

[[noreturn]] void fail(const std::string& who, const std::string& what) { throw std::invalid_argument(who + ": " + what); }

std::string number(double x) {
  char text[32];
  std::snprintf(text, sizeof text, "%.9g", x);
  return text;
}

void check_pose(Pose& pose, const std::string& who, const std::string& what) {
  if (!pose.position.allFinite()) fail(who, what + " position is not finite");
  if (!pose.rotation.coeffs().allFinite()) fail(who, what + " rotation is not finite");
  const double norm = pose.rotation.norm();
  if (std::abs(norm - 1) > kUnitTolerance) fail(who, what + " rotation is not a unit quaternion (norm " + number(norm) + ")");
  pose.rotation.normalize();
}

void check_surface(double friction, double restitution, const std::string& who) {
  if (!(friction >= 0 && friction <= kMaximumFriction))
    fail(who, "friction must be in [0, " + number(kMaximumFriction) + "], got " + number(friction));
  if (!(restitution >= 0 && restitution <= 1)) fail(who, "restitution must be in [0, 1], got " + number(restitution));
}

// The pieces of a hull or compound with their mass properties at unit density, every error named.
std::vector<ConvexHull> hulls_of(const Shape& shape, const std::string& who) {
  if (shape.parts.empty()) fail(who, "shape has no convex parts");
  if (shape.kind == Shape::Kind::hull && shape.parts.size() != 1)
    fail(who, "a hull shape has exactly one part, got " + std::to_string(shape.parts.size()) + " (use a compound)");
  std::vector<ConvexHull> hulls;
  for (std::size_t p = 0; p < shape.parts.size(); ++p) {
    try {
      hulls.push_back(convex_hull(shape.parts[p]));
    } catch (const std::invalid_argument& error) {
      fail(who, shape.parts.size() > 1 ? "part " + std::to_string(p) + ": " + error.what() : error.what());
    }
  }
  return hulls;
}

// Convex pieces' corners moved into the body frame: x_body = to_body * x.
PreparedShape prepare_convex(const Shape& shape, const std::vector<ConvexHull>& hulls, const Eigen::Isometry3d& to_body) {
  PreparedShape prepared;
  prepared.kind = shape.kind;
  double thickness = INFINITY;
  for (const auto& hull : hulls) {
    thickness = std::min(thickness, hull.thickness);
    std::vector<Eigen::Vector3d> corners;
    for (const auto& v : hull.vertices) corners.push_back(to_body * v);
    prepared.parts.push_back(std::move(corners));
  }
  prepared.inner_size = 0.5 * thickness;
  return prepared;
}

void check_box(const Shape& shape, const std::string& who) {
  if (!shape.half_extents.allFinite() || !(shape.half_extents.minCoeff() >= 0.5 * kMinimumHullThickness))
    fail(who, "box half extents must be finite and at least " + number(0.5 * kMinimumHullThickness) + " m, got (" +
                  number(shape.half_extents.x()) + ", " + number(shape.half_extents.y()) + ", " + number(shape.half_extents.z()) + ")");
}

PreparedShape prepare_box(const Shape& shape) {
  PreparedShape prepared;
  prepared.kind = Shape::Kind::box;
  prepared.half_extents = shape.half_extents;
  prepared.inner_size = shape.half_extents.minCoeff();
  return prepared;
}

PreparedShape prepare_static(const Shape& shape, const std::string& who) {
  switch (shape.kind) {
    case Shape::Kind::box:
      check_box(shape, who);
      return prepare_box(shape);
    case Shape::Kind::hull:
    case Shape::Kind::compound:
      return prepare_convex(shape, hulls_of(shape, who), Eigen::Isometry3d::Identity());
    case Shape::Kind::triangle_mesh: {
      if (shape.triangles.empty()) fail(who, "triangle mesh has no triangles");
      for (std::size_t v = 0; v < shape.vertices.size(); ++v)
        if (!shape.vertices[v].allFinite()) fail(who, "mesh vertex " + std::to_string(v) + " is not finite");
      for (std::size_t t = 0; t < shape.triangles.size(); ++t)
        for (int index : shape.triangles[t])
          if (index < 0 || static_cast<std::size_t>(index) >= shape.vertices.size())
            fail(who, "triangle " + std::to_string(t) + " names vertex " + std::to_string(index) + " of " + std::to_string(shape.vertices.size()));
      PreparedShape prepared;
      prepared.kind = shape.kind;
      prepared.vertices = shape.vertices;
      prepared.triangles = shape.triangles;
      return prepared;
    }
  }
  fail(who, "unknown shape kind");
}

PreparedProp prepare_prop(const DynamicProp& prop) {
  PreparedProp prepared;
  if (prop.shape.kind == Shape::Kind::box) {
    prepared.shape = prepare_box(prop.shape);
    const Eigen::Vector3d h2 = prop.shape.half_extents.cwiseAbs2();
    prepared.principal_inertia = prop.mass / 3.0 * Eigen::Vector3d(h2.y() + h2.z(), h2.x() + h2.z(), h2.x() + h2.y());
    return prepared;
  }
  const std::vector<ConvexHull> hulls = hulls_of(prop.shape, "shape");
  // Combined centroid and inertia at unit density (parallel axis theorem per part).
  double volume = 0;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& hull : hulls) {
    volume += hull.volume;
    centroid += hull.volume * hull.centroid;
  }
  centroid /= volume;
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();
  for (const auto& hull : hulls) {
    const Eigen::Vector3d d = hull.centroid - centroid;
    inertia += hull.unit_inertia + hull.volume * (d.squaredNorm() * Eigen::Matrix3d::Identity() - d * d.transpose());
  }
  inertia *= prop.mass / volume;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(inertia);
  Eigen::Matrix3d axes = solver.eigenvectors();
  if (axes.determinant() < 0) axes.col(2) = -axes.col(2);
  prepared.principal.position = centroid;
  prepared.principal.rotation = Eigen::Quaterniond(axes).normalized();
  prepared.principal_inertia = solver.eigenvalues();
  Eigen::Isometry3d to_body = Eigen::Isometry3d::Identity();
  to_body.linear() = axes.transpose();
  to_body.translation() = -axes.transpose() * centroid;
  prepared.shape = prepare_convex(prop.shape, hulls, to_body);
  return prepared;
}

}  // namespace

Shape Shape::box(const Eigen::Vector3d& half_extents) {
  Shape shape;
  shape.kind = Kind::box;
  shape.half_extents = half_extents;
  return shape;
}

Shape Shape::hull(std::vector<Eigen::Vector3d> points) {
  Shape shape;
  shape.kind = Kind::hull;
  shape.parts.push_back(std::move(points));
  return shape;
}

Shape Shape::compound(std::vector<std::vector<Eigen::Vector3d>> parts) {
  Shape shape;
  shape.kind = Kind::compound;
  shape.parts = std::move(parts);
  return shape;
}

Shape Shape::triangle_mesh(std::vector<Eigen::Vector3d> vertices, std::vector<std::array<int, 3>> triangles) {
  Shape shape;
  shape.kind = Kind::triangle_mesh;
  shape.vertices = std::move(vertices);
  shape.triangles = std::move(triangles);
  return shape;
}

int substeps_per_frame(double fps, double min_substep_rate) {
  if (!(std::isfinite(fps) && fps > 0)) throw std::invalid_argument("fps must be finite and > 0, got " + number(fps));
  if (!(std::isfinite(min_substep_rate) && min_substep_rate > 0))
    throw std::invalid_argument("min_substep_rate must be finite and > 0, got " + number(min_substep_rate));
  // The small allowance keeps 240 / 30 = 8 from becoming 9 through rounding of the quotient.
  const double ratio = min_substep_rate / fps;
  if (ratio > 1e5) throw std::invalid_argument("min_substep_rate / fps = " + number(ratio) + " substeps per frame is too many");
  return std::max(1, static_cast<int>(std::ceil(ratio - 1e-9)));
}

PhysicsModel::PhysicsModel(PhysicsScene scene) : scene_(std::move(scene)) {
  substeps_ = physics::substeps_per_frame(scene_.fps, scene_.min_substep_rate);
  if (scene_.frame_count < 1) throw std::invalid_argument("frame_count must be >= 1, got " + std::to_string(scene_.frame_count));
  if (scene_.solver_iterations < 1 || scene_.solver_iterations > 1000)
    throw std::invalid_argument("solver_iterations must be in [1, 1000], got " + std::to_string(scene_.solver_iterations));
  if (!scene_.gravity.allFinite()) throw std::invalid_argument("gravity is not finite");
  check_surface(scene_.ground_friction, scene_.ground_restitution, "ground");

  for (std::size_t i = 0; i < scene_.statics.size(); ++i) {
    const std::string who = "static body " + std::to_string(i);
    StaticBody& body = scene_.statics[i];
    check_pose(body.pose, who, "pose");
    check_surface(body.friction, body.restitution, who);
    statics_.push_back(prepare_static(body.shape, who));
  }
  for (std::size_t i = 0; i < scene_.props.size(); ++i) {
    const std::string who = "prop " + std::to_string(i);
    DynamicProp& prop = scene_.props[i];
    if (!(std::isfinite(prop.mass) && prop.mass > 0)) fail(who, "mass must be finite and > 0 kg, got " + number(prop.mass));
    check_surface(prop.friction, prop.restitution, who);
    check_pose(prop.pose, who, "initial");
    if (!prop.linear_velocity.allFinite()) fail(who, "initial linear velocity is not finite");
    if (!prop.angular_velocity.allFinite()) fail(who, "initial angular velocity is not finite");
    if (prop.shape.kind == Shape::Kind::triangle_mesh)
      fail(who, "a triangle mesh can only be static; give a moving prop as a hull or as convex parts");
    if (prop.shape.kind == Shape::Kind::box) check_box(prop.shape, who);
    try {
      props_.push_back(prepare_prop(prop));
    } catch (const std::invalid_argument& error) {
      fail(who, error.what());
    }
  }
  for (std::size_t i = 0; i < scene_.colliders.size(); ++i) {
    const std::string who = "collider " + std::to_string(i);
    KinematicCollider& collider = scene_.colliders[i];
    check_surface(collider.friction, collider.restitution, who);
    if (collider.track.size() != static_cast<std::size_t>(scene_.frame_count))
      fail(who, "track has " + std::to_string(collider.track.size()) + " poses, the scene has " + std::to_string(scene_.frame_count) + " frames");
    for (std::size_t f = 0; f < collider.track.size(); ++f) check_pose(collider.track[f], who, "frame " + std::to_string(f));
    Shape shape = Shape::hull(collider.points);
    colliders_.push_back(prepare_convex(shape, hulls_of(shape, who), Eigen::Isometry3d::Identity()));
  }
  for (std::size_t s = 0; s < scene_.kinematic_sets.size(); ++s) {
    const KinematicSet& set = scene_.kinematic_sets[s];
    if (!set.poses) fail("kinematic set " + std::to_string(s), "has no pose function");
    for (std::size_t i = 0; i < set.colliders.size(); ++i) {
      const std::string who = "kinematic set " + std::to_string(s) + ", collider " + std::to_string(i);
      const KinematicCollider& collider = set.colliders[i];
      check_surface(collider.friction, collider.restitution, who);
      if (!collider.track.empty()) fail(who, "a collider of a set is posed by the set, not by a track");
      Shape shape = Shape::hull(collider.points);
      colliders_.push_back(prepare_convex(shape, hulls_of(shape, who), Eigen::Isometry3d::Identity()));
    }
  }
  const double last_time = (scene_.frame_count - 1) / scene_.fps;
  for (std::size_t i = 0; i < scene_.impulses.size(); ++i) {
    const std::string who = "impulse " + std::to_string(i);
    const Impulse& impulse = scene_.impulses[i];
    if (impulse.prop < 0 || static_cast<std::size_t>(impulse.prop) >= scene_.props.size())
      fail(who, "prop " + std::to_string(impulse.prop) + " does not exist (" + std::to_string(scene_.props.size()) + " props)");
    if (!(impulse.time >= 0 && impulse.time <= last_time))
      fail(who, "time " + number(impulse.time) + " s is outside the shot [0, " + number(last_time) + "] s");
    if (!impulse.impulse.allFinite()) fail(who, "impulse vector is not finite");
    if (!impulse.point.allFinite()) fail(who, "application point is not finite");
  }
}

Pose PropMotion::pose(int frame, int prop) const {
  if (frame < 0 || frame >= frame_count || prop < 0 || prop >= prop_count)
    throw std::out_of_range("prop motion: frame " + std::to_string(frame) + " of " + std::to_string(frame_count) + ", prop " + std::to_string(prop) +
                            " of " + std::to_string(prop_count));
  const std::size_t at = static_cast<std::size_t>(frame) * prop_count + prop;
  Pose pose;
  pose.position = Eigen::Vector3d(positions[3 * at], positions[3 * at + 1], positions[3 * at + 2]);
  pose.rotation = Eigen::Quaterniond(rotations[4 * at + 3], rotations[4 * at], rotations[4 * at + 1], rotations[4 * at + 2]);
  return pose;
}

namespace {

btVector3 bt(const Eigen::Vector3d& v) { return btVector3(v.x(), v.y(), v.z()); }
btQuaternion bt(const Eigen::Quaterniond& q) { return btQuaternion(q.x(), q.y(), q.z(), q.w()); }
btTransform bt(const Pose& pose) { return btTransform(bt(pose.rotation), bt(pose.position)); }
Pose pose_of(const btTransform& t) {
  Pose pose;
  const btVector3& o = t.getOrigin();
  const btQuaternion q = t.getRotation();
  pose.position = Eigen::Vector3d(o.x(), o.y(), o.z());
  pose.rotation = Eigen::Quaterniond(q.w(), q.x(), q.y(), q.z());
  return pose;
}

enum CollisionGroup : int { kPropGroup = 1, kStaticGroup = 2, kKinematicGroup = 4 };

// One Bullet world built from a model. Everything Bullet keeps pointers to lives here, and the
// bodies are removed before the world is destroyed.
class BulletWorld {
 public:
  // `kinematic_start`: every kinematic collider's pose at frame 0, as model.colliders() lists them.
  BulletWorld(const PhysicsModel& model, std::span<const Pose> kinematic_start) {
    // Several contact points from the first touch (perturbed queries) rather than one per
    // substep accumulated over time: boxes settle flat at once, and a tumbling prop's next corner
    // is in the manifold before it reaches the floor (with 6 perturbations against the plane the
    // lowest corner of 30 kicked props over 60 s stays within 5 mm of it, with 3 within 9 mm,
    // over five seeds; the cost is about 15% more time).
    config_.setPlaneConvexMultipointIterations(6, 6);
    config_.setConvexConvexMultipointIterations(3, 3);
    // Contacts are kept from 2 cm apart (Bullet's default threshold) for every pair, rather than
    // from a fraction of the smaller shape's size: a prop falling at 4 m/s closes 1.7 cm per
    // substep, and a contact found before the touch lets the solver stop it at the surface
    // instead of a substep's travel inside.
    dispatcher_.setDispatcherFlags(dispatcher_.getDispatcherFlags() & ~btCollisionDispatcher::CD_USE_RELATIVE_CONTACT_BREAKING_THRESHOLD);
    // Box against box through the polyhedral (separating axis and clipping) path too: Bullet's
    // dedicated box-box test reports only overlaps, never a contact about to happen.
    dispatcher_.registerCollisionCreateFunc(BOX_SHAPE_PROXYTYPE, BOX_SHAPE_PROXYTYPE,
                                            config_.getCollisionAlgorithmCreateFunc(CONVEX_HULL_SHAPE_PROXYTYPE, CONVEX_HULL_SHAPE_PROXYTYPE));
    world_.setGravity(bt(model.scene().gravity));
    btContactSolverInfo& info = world_.getSolverInfo();
    info.m_numIterations = model.scene().solver_iterations;
    info.m_solverMode &= ~SOLVER_RANDMIZE_ORDER;
    // Every overlap is undone by split impulses (a position correction that leaves no velocity
    // behind), not only those deeper than Bullet's 4 cm: a prop caught between an actor's moving
    // bones, or pressed into the floor by a foot, is squeezed out instead of shot away.
    info.m_splitImpulse = 1;
    info.m_splitImpulsePenetrationThreshold = 0;
    const PhysicsScene& scene = model.scene();
    int id = 0;
    if (scene.ground) {
      auto* plane = own(std::make_unique<btStaticPlaneShape>(btVector3(0, 0, 1), 0));
      add_fixed(plane, btTransform::getIdentity(), scene.ground_friction, scene.ground_restitution, id++);
    }
    for (std::size_t i = 0; i < scene.statics.size(); ++i)
      add_fixed(shape(model.statics()[i]), bt(scene.statics[i].pose), scene.statics[i].friction, scene.statics[i].restitution, id++);
    for (std::size_t i = 0; i < scene.props.size(); ++i) {
      const DynamicProp& prop = scene.props[i];
      const PreparedProp& prepared = model.props()[i];
      btCollisionShape* collision = shape(prepared.shape);
      const btTransform body_pose = bt(prop.pose) * bt(prepared.principal);
      btRigidBody::btRigidBodyConstructionInfo info(prop.mass, nullptr, collision, bt(prepared.principal_inertia));
      info.m_startWorldTransform = body_pose;
      info.m_friction = prop.friction;
      info.m_restitution = prop.restitution;
      auto body = std::make_unique<btRigidBody>(info);
      body->setLinearVelocity(bt(prop.linear_velocity));
      body->setAngularVelocity(bt(prop.angular_velocity));
      body->setActivationState(DISABLE_DEACTIVATION);
      body->setCcdMotionThreshold(0.5 * prepared.shape.inner_size);
      body->setCcdSweptSphereRadius(0.4 * prepared.shape.inner_size);
      body->setUserIndex(static_cast<int>(i));
      body->setUserIndex2(id++);
      world_.addRigidBody(body.get(), kPropGroup, kPropGroup | kStaticGroup | kKinematicGroup);
      props_.push_back(body.get());
      bodies_.push_back(std::move(body));
    }
    std::vector<const KinematicCollider*> colliders;
    for (const KinematicCollider& collider : scene.colliders) colliders.push_back(&collider);
    for (const KinematicSet& set : scene.kinematic_sets) {
      for (const KinematicCollider& collider : set.colliders) colliders.push_back(&collider);
    }
    for (std::size_t i = 0; i < colliders.size(); ++i) {
      const KinematicCollider& collider = *colliders[i];
      auto motion = std::make_unique<btDefaultMotionState>(bt(kinematic_start[i]));
      btRigidBody::btRigidBodyConstructionInfo info(0, motion.get(), shape(model.colliders()[i]));
      info.m_friction = collider.friction;
      info.m_restitution = collider.restitution;
      auto body = std::make_unique<btRigidBody>(info);
      body->setCollisionFlags(body->getCollisionFlags() | btCollisionObject::CF_KINEMATIC_OBJECT);
      body->setActivationState(DISABLE_DEACTIVATION);
      body->setUserIndex(-1);
      body->setUserIndex2(id++);
      world_.addRigidBody(body.get(), kKinematicGroup, kPropGroup);
      kinematic_.push_back(motion.get());
      motions_.push_back(std::move(motion));
      bodies_.push_back(std::move(body));
    }
  }

  ~BulletWorld() {
    for (auto it = bodies_.rbegin(); it != bodies_.rend(); ++it) world_.removeRigidBody(it->get());
  }

  btDiscreteDynamicsWorld& world() { return world_; }
  btCollisionDispatcher& dispatcher() { return dispatcher_; }
  const std::vector<btRigidBody*>& props() const { return props_; }
  const std::vector<btDefaultMotionState*>& kinematic() const { return kinematic_; }

 private:
  template <class T>
  T* own(std::unique_ptr<T> shape) {
    T* raw = shape.get();
    shapes_.push_back(std::move(shape));
    return raw;
  }

  btConvexHullShape* hull(const std::vector<Eigen::Vector3d>& points) {
    auto* hull = own(std::make_unique<btConvexHullShape>());
    for (const auto& p : points) hull->addPoint(bt(p), false);
    hull->recalcLocalAabb();
    hull->setMargin(kCollisionMargin);
    hull->initializePolyhedralFeatures();
    return hull;
  }

  btCollisionShape* shape(const PreparedShape& prepared) {
    switch (prepared.kind) {
      case Shape::Kind::box: {
        auto* box = own(std::make_unique<btBoxShape>(bt(prepared.half_extents)));
        box->setMargin(kCollisionMargin);  // btBoxShape keeps its outer half extents when the margin changes
        box->initializePolyhedralFeatures();
        return box;
      }
      case Shape::Kind::hull:
        return hull(prepared.parts[0]);
      case Shape::Kind::compound: {
        auto* compound = own(std::make_unique<btCompoundShape>());
        for (const auto& part : prepared.parts) compound->addChildShape(btTransform::getIdentity(), hull(part));
        return compound;
      }
      case Shape::Kind::triangle_mesh: {
        auto mesh = std::make_unique<btTriangleMesh>(true, false);
        for (const auto& t : prepared.triangles)
          mesh->addTriangle(bt(prepared.vertices[t[0]]), bt(prepared.vertices[t[1]]), bt(prepared.vertices[t[2]]));
        auto* shape = own(std::make_unique<btBvhTriangleMeshShape>(mesh.get(), true));
        meshes_.push_back(std::move(mesh));
        return shape;
      }
    }
    throw std::logic_error("unknown prepared shape kind");
  }

  void add_fixed(btCollisionShape* collision, const btTransform& pose, double friction, double restitution, int id) {
    btRigidBody::btRigidBodyConstructionInfo info(0, nullptr, collision);
    info.m_startWorldTransform = pose;
    info.m_friction = friction;
    info.m_restitution = restitution;
    auto body = std::make_unique<btRigidBody>(info);
    body->setUserIndex(-1);
    body->setUserIndex2(id);
    world_.addRigidBody(body.get(), kStaticGroup, kPropGroup);
    bodies_.push_back(std::move(body));
  }

  btDefaultCollisionConfiguration config_;
  btCollisionDispatcher dispatcher_{&config_};
  btDbvtBroadphase broadphase_;
  btSequentialImpulseConstraintSolver solver_;
  btDiscreteDynamicsWorld world_{&dispatcher_, &broadphase_, &solver_, &config_};
  std::vector<std::unique_ptr<btCollisionShape>> shapes_;
  std::vector<std::unique_ptr<btTriangleMesh>> meshes_;
  std::vector<std::unique_ptr<btDefaultMotionState>> motions_;
  std::vector<std::unique_ptr<btRigidBody>> bodies_;
  std::vector<btRigidBody*> props_;
  std::vector<btDefaultMotionState*> kinematic_;
};

Pose interpolate(const Pose& a, const Pose& b, double s) {
  Pose pose;
  pose.position = (1 - s) * a.position + s * b.position;
  pose.rotation = a.rotation.slerp(s, b.rotation);
  return pose;
}

// Every kinematic collider's pose at one frame, as model.colliders() lists them: the tracked ones
// from their tracks, then each set's from its function (checked as it comes).
void kinematic_poses(const PhysicsScene& scene, int frame, std::vector<Pose>& poses) {
  poses.resize(0);
  for (const KinematicCollider& collider : scene.colliders) poses.push_back(collider.track[frame]);
  for (std::size_t s = 0; s < scene.kinematic_sets.size(); ++s) {
    const KinematicSet& set = scene.kinematic_sets[s];
    const std::size_t first = poses.size();
    poses.resize(first + set.colliders.size());
    set.poses(frame, std::span(poses).subspan(first, set.colliders.size()));
    for (std::size_t i = 0; i < set.colliders.size(); ++i) {
      check_pose(poses[first + i], "kinematic set " + std::to_string(s) + ", collider " + std::to_string(i), "frame " + std::to_string(frame));
    }
  }
}

}  // namespace

PropMotion simulate(const PhysicsModel& model) {
  const PhysicsScene& scene = model.scene();
  const int props = static_cast<int>(scene.props.size());
  const int substeps = model.substeps_per_frame();
  const double dt = 1.0 / (scene.fps * substeps);
  PropMotion motion;
  motion.frame_count = scene.frame_count;
  motion.prop_count = props;
  motion.fps = scene.fps;
  motion.substeps_per_frame = substeps;
  motion.positions.resize(static_cast<std::size_t>(scene.frame_count) * props * 3);
  motion.rotations.resize(static_cast<std::size_t>(scene.frame_count) * props * 4);
  motion.reports.resize(props);

  // The kinematic colliders' poses at the previous frame and at the one being stepped to.
  std::vector<Pose> before, after;
  kinematic_poses(scene, 0, after);
  BulletWorld bullet(model, after);
  std::vector<btTransform> to_prop(props);  // body frame -> prop frame
  for (int i = 0; i < props; ++i) to_prop[i] = bt(model.props()[i].principal).inverse();

  const auto record = [&](int frame) {
    for (int i = 0; i < props; ++i) {
      const std::size_t at = static_cast<std::size_t>(frame) * props + i;
      Pose pose = frame == 0 ? scene.props[i].pose : pose_of(bullet.props()[i]->getWorldTransform() * to_prop[i]);
      if (frame > 0) {
        const double* previous = &motion.rotations[4 * (at - props)];
        const Eigen::Vector4d before(previous[0], previous[1], previous[2], previous[3]);
        if (pose.rotation.coeffs().dot(before) < 0) pose.rotation.coeffs() = -pose.rotation.coeffs();
        const Eigen::Vector3d step = pose.position - Eigen::Vector3d(&motion.positions[3 * (at - props)]);
        PropReport& report = motion.reports[i];
        report.path_length += step.norm();
        report.top_speed = std::max(report.top_speed, step.norm() * scene.fps);
      }
      std::copy_n(pose.position.data(), 3, &motion.positions[3 * at]);
      std::copy_n(pose.rotation.coeffs().data(), 4, &motion.rotations[4 * at]);
    }
  };
  record(0);

  // Impulses in the order they act: by substep, then as listed.
  std::vector<std::pair<long long, int>> kicks;
  for (std::size_t e = 0; e < scene.impulses.size(); ++e) {
    // The first substep starting at or after the event: ceil(t / dt), with the same allowance for
    // rounding as the substep count.
    const long long substep = static_cast<long long>(std::ceil(scene.impulses[e].time / dt - 1e-9));
    kicks.emplace_back(std::max(0LL, substep), static_cast<int>(e));
  }
  std::stable_sort(kicks.begin(), kicks.end());
  std::size_t next_kick = 0;

  // Touching (prop, other body id) pairs of the previous and current substeps, sorted.
  std::vector<std::pair<int, int>> touching, touched;
  std::vector<char> touched_this_frame(props);
  long long substep_index = 0;
  for (int frame = 1; frame < scene.frame_count; ++frame) {
    std::swap(before, after);
    kinematic_poses(scene, frame, after);
    std::fill(touched_this_frame.begin(), touched_this_frame.end(), 0);
    for (int k = 0; k < substeps; ++k, ++substep_index) {
      const double s = static_cast<double>(k + 1) / substeps;
      for (std::size_t c = 0; c < after.size(); ++c) bullet.kinematic()[c]->setWorldTransform(bt(interpolate(before[c], after[c], s)));
      for (; next_kick < kicks.size() && kicks[next_kick].first <= substep_index; ++next_kick) {
        const Impulse& impulse = scene.impulses[kicks[next_kick].second];
        btRigidBody* body = bullet.props()[impulse.prop];
        const btVector3 arm = body->getWorldTransform().getBasis() * (to_prop[impulse.prop].inverse() * bt(impulse.point));
        body->applyImpulse(bt(impulse.impulse), arm);
      }
      // maxSubSteps = 0: exactly one internal step of dt (no accumulator, no interpolation).
      bullet.world().stepSimulation(dt, 0);

      touched.clear();
      btCollisionDispatcher& dispatcher = bullet.dispatcher();
      for (int m = 0; m < dispatcher.getNumManifolds(); ++m) {
        const btPersistentManifold* manifold = dispatcher.getManifoldByIndexInternal(m);
        double closest = INFINITY;
        for (int p = 0; p < manifold->getNumContacts(); ++p) closest = std::min<double>(closest, manifold->getContactPoint(p).getDistance());
        if (!(closest <= kContactDistance)) continue;
        const btCollisionObject* a = manifold->getBody0();
        const btCollisionObject* b = manifold->getBody1();
        for (const auto& [self, other] : {std::pair{a, b}, std::pair{b, a}}) {
          const int prop = self->getUserIndex();
          if (prop < 0) continue;
          touched.emplace_back(prop, other->getUserIndex2());
          touched_this_frame[prop] = 1;
          PropReport& report = motion.reports[prop];
          report.deepest_penetration = std::max(report.deepest_penetration, -closest);
          if (other->getUserIndex() >= 0) report.deepest_prop_overlap = std::max(report.deepest_prop_overlap, -closest);
        }
      }
      std::sort(touched.begin(), touched.end());
      touched.erase(std::unique(touched.begin(), touched.end()), touched.end());
      for (const auto& pair : touched)
        if (!std::binary_search(touching.begin(), touching.end(), pair)) ++motion.reports[pair.first].contact_events;
      std::swap(touching, touched);
    }
    for (int i = 0; i < props; ++i) motion.reports[i].contact_frames += touched_this_frame[i];
    record(frame);
  }
  return motion;
}

}  // namespace odyssey::physics
