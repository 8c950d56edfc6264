// Surface point sampling: a seed gives the same points (pinned to fixed values, so a change of
// algorithm or standard library cannot slip through) and other seeds other points; vertex samples
// never repeat; surface samples fall on triangles in proportion to their area and uniformly
// inside them; regions keep their points off the joints left out (the body without hands has no
// finger vertex); sampled points move with their triangles exactly as the reference-skinned
// corners interpolated; only the corners are skinned; bad requests are rejected.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"  // GCC 12 and AVX-512 intrinsics, see lbs.cpp
#include <Eigen/Core>
#pragma GCC diagnostic pop

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "mocap_io/gltf_character.h"
#include "skeleton/fk.h"
#include "skeleton/rotation.h"
#include "skinning/body_character.h"
#include "skinning/sampling.h"
#include "synthetic/synthetic_body.h"

namespace odyssey::skinning {
namespace {

using Eigen::Vector3d;
using Eigen::Vector3f;

const Character& body() {
  static const Character character = body_character(make_synthetic_body(1).model);
  return character;
}

const Character& cesium_man() {
  static const Character character =
      io::load_character(std::string(ODYSSEY_SHARED_DIR) + "/assets/characters/CesiumMan.glb");
  return character;
}

// A flat mesh on one joint: given positions and triangles, weight 1 on the root.
Character flat_character(std::vector<Vector3f> positions, std::vector<std::uint32_t> triangles) {
  Character character;
  character.skeleton = Skeleton({"root", "tip"}, {-1, 0}, {Vector3d::Zero(), Vector3d(0, 0, 1)});
  CharacterMesh mesh;
  mesh.name = "flat";
  mesh.positions = std::move(positions);
  mesh.triangles = std::move(triangles);
  mesh.skin_joints = {0, 1};
  mesh.inverse_bind = {Eigen::Matrix4d::Identity(), Eigen::Matrix4d::Identity()};
  mesh.influence_slots.assign(mesh.positions.size(), {0, 0, 0, 0});
  mesh.influence_weights.assign(mesh.positions.size(), {1.0f, 0.0f, 0.0f, 0.0f});
  character.meshes.push_back(std::move(mesh));
  return character;
}

// Two triangles of areas 1 and 3 (in the z = 0 plane), sharing no vertex.
const Character& two_triangles() {
  static const Character character =
      flat_character({{0, 0, 0}, {2, 0, 0}, {0, 1, 0}, {10, 0, 0}, {13, 0, 0}, {10, 2, 0}}, {0, 1, 2, 3, 4, 5});
  return character;
}

bool same_points(const std::vector<SurfacePoint>& a, const std::vector<SurfacePoint>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (a[i].mesh != b[i].mesh || a[i].vertices != b[i].vertices || a[i].barycentric != b[i].barycentric) return false;
  }
  return true;
}

TEST(SamplingTest, ASeedGivesTheSamePointsAndOtherSeedsOthers) {
  for (const SamplingMode mode : {SamplingMode::vertices, SamplingMode::surface}) {
    const SamplingOptions options{.mode = mode, .count = 500, .seed = 7};
    const std::vector<SurfacePoint> first = sample_surface_points(body(), options);
    EXPECT_TRUE(same_points(first, sample_surface_points(body(), options)));
    SamplingOptions other = options;
    other.seed = 8;
    const std::vector<SurfacePoint> second = sample_surface_points(body(), other);
    std::size_t shared = 0;
    for (std::size_t i = 0; i < first.size(); ++i) shared += first[i].vertices == second[i].vertices;
    EXPECT_LT(shared, 5u);
  }
}

// The draws are specified (sampling.h) down to the bit, so these values hold with any compiler
// and standard library; a change here changes every dataset made with a seed.
TEST(SamplingTest, DrawsArePinned) {
  const Character strip = flat_character(
      {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}, {0, 1, 0}, {1, 1, 0}, {2, 1, 0}, {3, 1, 0}},
      {0, 1, 5, 0, 5, 4, 1, 2, 6, 1, 6, 5, 2, 3, 7, 2, 7, 6});
  const std::vector<SurfacePoint> vertices =
      sample_surface_points(strip, {.mode = SamplingMode::vertices, .count = 4, .seed = 2024});
  std::vector<std::uint32_t> ids;
  for (const SurfacePoint& point : vertices) ids.push_back(point.vertices[0]);
  EXPECT_EQ(ids, (std::vector<std::uint32_t>{6, 3, 7, 2}));

  const std::vector<SurfacePoint> surface =
      sample_surface_points(strip, {.mode = SamplingMode::surface, .count = 2, .seed = 2024});
  ASSERT_EQ(surface.size(), 2u);
  EXPECT_EQ(surface[0].vertices, (std::array<std::uint32_t, 3>{1, 6, 5}));
  EXPECT_EQ(surface[1].vertices, (std::array<std::uint32_t, 3>{1, 2, 6}));
  const std::array<std::array<float, 3>, 2> barycentric = {{{0.108531512f, 0.654643536f, 0.236824974f},
                                                             {0.92129612f, 0.0676690787f, 0.0110347979f}}};
  for (int i = 0; i < 2; ++i) {
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(surface[i].barycentric[c], barycentric[i][c], 1e-7f) << i << " " << c;
  }
}

TEST(SamplingTest, VertexSamplesNeverRepeat) {
  const std::vector<SurfacePoint> points =
      sample_surface_points(cesium_man(), {.mode = SamplingMode::vertices, .count = 3000, .seed = 1});
  std::set<std::pair<std::uint32_t, std::uint32_t>> seen;
  for (const SurfacePoint& point : points) {
    EXPECT_EQ(point.vertices[1], point.vertices[0]);
    EXPECT_EQ(point.vertices[2], point.vertices[0]);
    EXPECT_EQ(point.barycentric, (std::array<float, 3>{1.0f, 0.0f, 0.0f}));
    EXPECT_TRUE(seen.insert({point.mesh, point.vertices[0]}).second) << "vertex " << point.vertices[0] << " twice";
  }
  // Asking for every vertex gives every vertex.
  const std::size_t all = cesium_man().meshes[0].positions.size();
  EXPECT_EQ(sample_surface_points(cesium_man(), {.mode = SamplingMode::vertices, .count = int(all), .seed = 2}).size(), all);
}

// Counts against expectation: within 4 standard deviations of a binomial count.
void expect_share(std::size_t hits, std::size_t total, double share, const std::string& what) {
  const double sigma = std::sqrt(double(total) * share * (1.0 - share));
  EXPECT_NEAR(double(hits), double(total) * share, 4.0 * sigma) << what;
}

// Areas 1 : 3 get 25% : 75% of the points; inside a triangle, each of the four triangles cut by
// the edge midpoints (equal areas) gets a quarter.
TEST(SamplingTest, SurfacePointsAreUniformOverTheArea) {
  const std::size_t count = 40000;
  const std::vector<SurfacePoint> points =
      sample_surface_points(two_triangles(), {.mode = SamplingMode::surface, .count = int(count), .seed = 3});
  std::size_t on_small = 0;
  std::array<std::size_t, 4> quarters{};
  for (const SurfacePoint& point : points) {
    const std::array<float, 3>& b = point.barycentric;
    EXPECT_GE(std::min({b[0], b[1], b[2]}), 0.0f);
    EXPECT_NEAR(b[0] + b[1] + b[2], 1.0f, 2e-7f);
    if (point.vertices[0] != 0) continue;
    ++on_small;
    // Corner sub-triangle i holds the points with b_i > 1/2; the middle one the rest.
    const int corner = b[0] > 0.5f ? 0 : b[1] > 0.5f ? 1 : b[2] > 0.5f ? 2 : 3;
    ++quarters[corner];
  }
  expect_share(on_small, count, 0.25, "points on the triangle of area 1");
  for (int q = 0; q < 4; ++q) expect_share(quarters[q], on_small, 0.25, "sub-triangle " + std::to_string(q));
}

// World joint transforms of a random pose (every joint turned from its rest by up to ~1 rad).
std::vector<RigidTransform<double>> random_pose(const Character& character, std::mt19937& random) {
  const Skeleton& skeleton = character.skeleton;
  std::vector<RigidTransform<double>> local(skeleton.joint_count()), world(skeleton.joint_count());
  skeleton.rest_local(local);
  std::uniform_real_distribution<double> component(-0.6, 0.6);
  for (RigidTransform<double>& joint : local) {
    joint.rotation = joint.rotation * rodrigues(Vector3d(component(random), component(random), component(random)));
  }
  local[0].translation += Vector3d(component(random), component(random), component(random));
  forward_kinematics<double>(skeleton.parents(), local, world);
  return world;
}

// Each point against its corners skinned one by one by the reference and interpolated in double.
TEST(SamplingTest, PointsMoveWithTheirTriangles) {
  std::mt19937 random(13);
  for (const Character* character : {&cesium_man(), &body()}) {
    for (const SamplingMode mode : {SamplingMode::surface, SamplingMode::vertices}) {
      const std::vector<SurfacePoint> points =
          sample_surface_points(*character, {.mode = mode, .count = 800, .seed = 5});
      SurfacePointSkinner skinner(*character, points, 2);
      std::vector<float> skinned(3 * points.size());
      double worst = 0.0;
      for (int pose = 0; pose < 4; ++pose) {
        const std::vector<RigidTransform<double>> world = random_pose(*character, random);
        skinner.skin(world, skinned);
        std::vector<std::vector<Vector3d>> corners;
        for (const CharacterMesh& mesh : character->meshes) corners.push_back(skin_mesh_reference(mesh, world));
        for (std::size_t i = 0; i < points.size(); ++i) {
          Vector3d expected = Vector3d::Zero();
          for (int c = 0; c < 3; ++c) expected += points[i].barycentric[c] * corners[points[i].mesh][points[i].vertices[c]];
          worst = std::max(worst, (Vector3d(skinned[3 * i], skinned[3 * i + 1], skinned[3 * i + 2]) - expected).norm());
        }
      }
      EXPECT_LE(worst, 1e-5) << character->name;
    }
  }
}

// Only the points' corners are skinned: for vertex samples exactly the points, for surface samples
// the union of their corners; many frames in one call give the frames of single calls.
TEST(SamplingTest, OnlyTheCornersAreSkinned) {
  const std::vector<SurfacePoint> vertices =
      sample_surface_points(body(), {.mode = SamplingMode::vertices, .count = 300, .seed = 9});
  EXPECT_EQ(SurfacePointSkinner(body(), vertices).skinned_vertex_count(), 300u);

  const std::vector<SurfacePoint> points = sample_surface_points(body(), {.mode = SamplingMode::surface, .count = 300, .seed = 9});
  std::set<std::uint32_t> corners;
  for (const SurfacePoint& point : points) corners.insert(point.vertices.begin(), point.vertices.end());
  SurfacePointSkinner skinner(body(), points);
  EXPECT_EQ(skinner.skinned_vertex_count(), corners.size());
  EXPECT_LT(skinner.skinned_vertex_count(), body().meshes[0].positions.size() / 5);

  std::mt19937 random(1);
  const std::size_t frames = 5, joints = std::size_t(body().skeleton.joint_count());
  std::vector<RigidTransform<double>> world;
  for (std::size_t f = 0; f < frames; ++f) {
    const std::vector<RigidTransform<double>> pose = random_pose(body(), random);
    world.insert(world.end(), pose.begin(), pose.end());
  }
  std::vector<float> batch(frames * 3 * points.size()), single(3 * points.size());
  skinner.skin_frames(frames, world, batch);
  for (std::size_t f = 0; f < frames; ++f) {
    skinner.skin(std::span(world).subspan(f * joints, joints), single);
    EXPECT_TRUE(std::equal(single.begin(), single.end(), batch.begin() + std::ptrdiff_t(f * single.size()))) << f;
  }
}

// SMPL-X: wrists 20 and 21, fingers 25-54. The body without hands keeps the palms (wrist) and
// never touches a finger vertex; the hands alone are all finger or wrist vertices.
TEST(SamplingTest, RegionsKeepPointsOffTheJointsLeftOut) {
  const Skeleton& skeleton = body().skeleton;
  const std::array wrists = {skeleton.find("left_wrist"), skeleton.find("right_wrist")};
  ASSERT_EQ(wrists, (std::array{20, 21}));
  const JointSet fingers = JointSet::below(skeleton, wrists);
  for (int j = 0; j < skeleton.joint_count(); ++j) EXPECT_EQ(fingers.contains(j), j >= 25) << skeleton.name(j);
  const JointSet without_hands = JointSet::all(skeleton) - fingers;

  const CharacterMesh& mesh = body().meshes[0];
  std::size_t finger_vertices = 0;
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) finger_vertices += fingers.contains(dominant_joint(mesh, v));
  ASSERT_GT(finger_vertices, 500u);

  // Every vertex of the region, in vertex mode: all of them and only them.
  const int eligible = int(mesh.positions.size() - finger_vertices);
  const std::vector<SurfacePoint> vertices = sample_surface_points(
      body(), {.mode = SamplingMode::vertices, .count = eligible, .seed = 4, .region = without_hands});
  for (const SurfacePoint& point : vertices) EXPECT_FALSE(fingers.contains(dominant_joint(mesh, point.vertices[0])));
  EXPECT_THROW(sample_surface_points(body(), {.mode = SamplingMode::vertices, .count = eligible + 1, .region = without_hands}),
               std::invalid_argument);

  const std::vector<SurfacePoint> surface = sample_surface_points(
      body(), {.mode = SamplingMode::surface, .count = 20000, .seed = 4, .region = without_hands});
  for (const SurfacePoint& point : surface) {
    for (const std::uint32_t v : point.vertices) ASSERT_FALSE(fingers.contains(dominant_joint(mesh, v)));
  }
  const JointSet hands = JointSet::subtrees(skeleton, wrists);
  const std::vector<SurfacePoint> on_hands =
      sample_surface_points(body(), {.mode = SamplingMode::surface, .count = 2000, .seed = 4, .region = hands});
  for (const SurfacePoint& point : on_hands) {
    for (const std::uint32_t v : point.vertices) ASSERT_TRUE(hands.contains(dominant_joint(mesh, v)));
  }
}

TEST(SamplingTest, DominantJointIsTheLargestWeightFirstOnTies) {
  Character character = flat_character({{0, 0, 0}, {1, 0, 0}}, {});
  CharacterMesh& mesh = character.meshes[0];
  mesh.influence_slots[0] = {0, 1, 0, 0};
  mesh.influence_weights[0] = {0.3f, 0.7f, 0.0f, 0.0f};
  mesh.influence_slots[1] = {1, 0, 0, 0};
  mesh.influence_weights[1] = {0.5f, 0.5f, 0.0f, 0.0f};
  EXPECT_EQ(dominant_joint(mesh, 0), 1);
  EXPECT_EQ(dominant_joint(mesh, 1), 1);
}

template <class F>
void expect_invalid(F&& call, const std::string& expected_part) {
  try {
    call();
    ADD_FAILURE() << "no exception; expected one mentioning '" << expected_part << "'";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find(expected_part), std::string::npos) << error.what();
  }
}

TEST(SamplingTest, RejectsImpossibleRequests) {
  const Character& flat = two_triangles();
  const Skeleton& skeleton = flat.skeleton;
  expect_invalid([&] { sample_surface_points(flat, {.mode = SamplingMode::vertices, .count = 7}); },
                 "7 vertex samples asked for, but the region has only 6 vertices");
  for (const int count : {0, -3}) {
    expect_invalid([&] { sample_surface_points(flat, {.count = count}); }, "at least 1, got " + std::to_string(count));
  }
  expect_invalid([&] { sample_surface_points(flat, {.count = 5, .region = JointSet(skeleton.joint_count())}); },
                 "the region holds no joint");
  // The tip joint carries no vertex: its region is empty of vertices and of triangles.
  const JointSet tip = JointSet::of(skeleton, std::array{1});
  expect_invalid([&] { sample_surface_points(flat, {.mode = SamplingMode::vertices, .count = 1, .region = tip}); },
                 "no vertex on a triangle");
  expect_invalid([&] { sample_surface_points(flat, {.count = 1, .region = tip}); }, "no triangle of non-zero area");
  expect_invalid([&] { sample_surface_points(flat, {.count = 1, .region = JointSet(5)}); }, "over 5 joints");
  expect_invalid([&] { JointSet::of(skeleton, std::array{2}); }, "joint 2 is not one of the skeleton's 2");
  expect_invalid([&] { (void)(JointSet(2) - JointSet(3)); }, "over 2 and 3 joints");
  // Only degenerate triangles: nothing to sample on.
  const Character degenerate = flat_character({{0, 0, 0}, {1, 0, 0}, {2, 0, 0}}, {0, 1, 2, 0, 0, 1});
  expect_invalid([&] { sample_surface_points(degenerate, {.count = 1}); }, "no triangle of non-zero area");
  Character broken = flat;
  broken.meshes[0].triangles.push_back(9);
  expect_invalid([&] { sample_surface_points(broken, {.count = 1}); }, "not a multiple of 3");
  // A point on a vertex that does not exist cannot be skinned.
  SurfacePoint stray;
  stray.vertices = {0, 1, 6};
  expect_invalid([&] { SurfacePointSkinner(flat, std::vector<SurfacePoint>{stray}); }, "vertex 6 of mesh 'flat'");
}

}  // namespace
}  // namespace odyssey::skinning
