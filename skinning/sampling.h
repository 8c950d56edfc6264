// Surface points of a character for trajectories: N points chosen once (seeded, reproducible),
// then moved with the skinned mesh every frame.
//
// A point is a triangle of one mesh and barycentric coordinates on its corners,
//   p(t) = b0 v0(t) + b1 v1(t) + b2 v2(t),
// with v_i(t) the corners skinned at frame t, so a point inside a triangle moves with the
// triangle's skinned corners. A vertex sample is its vertex three times with (1, 0, 0).
//
// Sampling modes:
// - vertices: N distinct vertices, uniform without replacement among the eligible ones (vertices
//   on at least one triangle, in the region), by a partial Fisher-Yates shuffle of their list
//   (meshes in order, vertices in order): step i swaps item i with a uniform item of [i, M).
// - surface: N points uniform over the area of the eligible triangles at the rest pose (areas of
//   the rest-skinned mesh in world units, so every mesh is measured alike). A triangle is drawn by
//   inverse CDF: u uniform in [0, A) finds the first triangle whose running area sum exceeds u;
//   inside it, with r1, r2 uniform in [0, 1) and s = sqrt(r1),
//     (b0, b1, b2) = (1 - s, s (1 - r2), s r2)
//   is uniform over the triangle (Osada et al., Shape distributions, 2002). Triangles of zero area
//   or with a repeated corner are never drawn.
// Points come in the order drawn.
//
// Randomness: std::mt19937_64 seeded with the seed (the standard fixes its output sequence); the
// uniform draws are derived here rather than with std::uniform_*_distribution, whose algorithms
// differ between standard libraries, so a seed gives the same points with any compiler:
//   integer in [0, n): draw x until x >= 2^64 mod n, return x mod n   (unbiased)
//   real in [0, 1):    (x >> 11) 2^-53                               (53 random bits)
//
// Regions. A vertex belongs to a joint's influence region when that joint carries its largest
// weight (the first listed on a tie): dominant_joint(). Sampling can be restricted to the regions
// of a JointSet: a vertex is eligible when its dominant joint is in the set, a triangle when all
// three of its corners are, so no point ever refers to a vertex outside the set. Example, the body
// without hands on a rig whose wrists are joints lw and rw:
//   JointSet::all(skeleton) - JointSet::below(skeleton, std::array{lw, rw})
// (the wrist joints keep the palms; the fingers go).
//
// Ownership: sampling returns plain values; SurfacePointSkinner copies what it needs from the
// character and the points.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "skeleton/character.h"
#include "skinning/lbs.h"

namespace odyssey::skinning {

// A set of joints of one skeleton (a membership flag per joint).
class JointSet {
 public:
  // The empty set over `joint_count` joints.
  explicit JointSet(int joint_count = 0);

  static JointSet all(const Skeleton& skeleton);
  // Exactly these joints. Throws std::invalid_argument naming a joint index outside the skeleton.
  static JointSet of(const Skeleton& skeleton, std::span<const int> joints);
  // These joints and every joint below them.
  static JointSet subtrees(const Skeleton& skeleton, std::span<const int> roots);
  // Every joint strictly below these (their descendants, not themselves).
  static JointSet below(const Skeleton& skeleton, std::span<const int> joints);

  // Set difference. Throws std::invalid_argument when the sets are over different joint counts.
  JointSet operator-(const JointSet& other) const;

  int joint_count() const { return static_cast<int>(member_.size()); }
  bool contains(int joint) const { return joint >= 0 && joint < joint_count() && member_[joint]; }
  bool empty() const;

 private:
  std::vector<bool> member_;
};

// The skeleton joint that carries vertex `vertex`'s largest weight (the first listed on a tie).
// The mesh must be consistent (as the loader builds it); the vertex must exist.
int dominant_joint(const CharacterMesh& mesh, std::size_t vertex);

enum class SamplingMode { vertices, surface };

struct SamplingOptions {
  SamplingMode mode = SamplingMode::surface;
  int count = 0;                   // N, at least 1
  std::uint64_t seed = 0;
  std::optional<JointSet> region = std::nullopt;  // none: the whole character
};

struct SurfacePoint {
  std::uint32_t mesh = 0;
  std::array<std::uint32_t, 3> vertices{};  // triangle corners, or the vertex three times
  std::array<float, 3> barycentric{};       // sum to 1 within float rounding; (1, 0, 0) for a vertex
};

// Throws std::invalid_argument, saying which, when count < 1, the region's joint count is not the
// skeleton's, the region is empty or holds no eligible vertex (or no triangle of non-zero area for
// surface sampling), or vertex sampling asks for more points than there are eligible vertices.
std::vector<SurfacePoint> sample_surface_points(const Character& character, const SamplingOptions& options);

// Moves sampled points with the character: the skinning engine runs on the union of the points'
// corner vertices only (never the full mesh), then each point interpolates its corners in float32,
// in blocks of points on the engine's threads.
class SurfacePointSkinner {
 public:
  // Throws std::invalid_argument as LinearBlendSkinner does for a point naming a mesh or vertex
  // that does not exist.
  SurfacePointSkinner(const Character& character, std::span<const SurfacePoint> points, int threads = 1);

  std::size_t point_count() const { return barycentric_.size(); }
  // The vertices skinned each frame: the points' corners, sorted, each once.
  const std::vector<MeshVertex>& skinned_vertices() const { return corners_skinned_; }
  std::size_t skinned_vertex_count() const { return skinner_.vertex_count(); }
  int joint_count() const { return skinner_.joint_count(); }

  // joint_world as for LinearBlendSkinner; points: 3 point_count() floats a frame, (x, y, z) of
  // point i at 3i, frame after frame.
  void skin(std::span<const RigidTransform<double>> joint_world, std::span<float> points);
  void skin_frames(std::size_t frames, std::span<const RigidTransform<double>> joint_world, std::span<float> points);

 private:
  std::vector<MeshVertex> corners_skinned_;  // before skinner_, which is built from it
  LinearBlendSkinner skinner_;
  std::vector<std::array<std::uint32_t, 3>> corner_rows_;  // rows of the corners in skinner_'s output
  std::vector<std::array<float, 3>> barycentric_;
  std::vector<float> corners_;  // scratch: skinned corners of a chunk of frames
};

}  // namespace odyssey::skinning
