#include "skinning/sampling.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <string>

namespace odyssey::skinning {
namespace {

// Uniform integer in [0, n), n >= 1: values below 2^64 mod n are the surplus that would make some
// residues more likely than others, so they are drawn again.
std::uint64_t uniform_below(std::mt19937_64& random, std::uint64_t n) {
  const std::uint64_t surplus = (0 - n) % n;  // 2^64 mod n
  for (;;) {
    const std::uint64_t x = random();
    if (x >= surplus) return x % n;
  }
}

// Uniform real in [0, 1) from the top 53 bits of one draw.
double uniform_unit(std::mt19937_64& random) { return double(random() >> 11) * 0x1.0p-53; }

// Per mesh, whether each vertex is in the region (all true without a region).
std::vector<std::vector<bool>> vertices_in_region(const Character& character, const std::optional<JointSet>& region) {
  std::vector<std::vector<bool>> inside(character.meshes.size());
  for (std::size_t m = 0; m < character.meshes.size(); ++m) {
    const CharacterMesh& mesh = character.meshes[m];
    inside[m].resize(mesh.positions.size(), true);
    if (!region) continue;
    for (std::size_t v = 0; v < mesh.positions.size(); ++v) inside[m][v] = region->contains(dominant_joint(mesh, v));
  }
  return inside;
}

void check_triangles(const CharacterMesh& mesh) {
  if (mesh.triangles.size() % 3 != 0) {
    throw std::invalid_argument("mesh '" + mesh.name + "' has " + std::to_string(mesh.triangles.size()) +
                                " triangle indices, not a multiple of 3");
  }
  for (const std::uint32_t index : mesh.triangles) {
    if (index >= mesh.positions.size()) {
      throw std::invalid_argument("mesh '" + mesh.name + "' has a triangle on vertex " + std::to_string(index) + " of " +
                                  std::to_string(mesh.positions.size()));
    }
  }
}

std::vector<SurfacePoint> sample_vertices(const Character& character, const std::vector<std::vector<bool>>& inside,
                                          int count, std::mt19937_64& random) {
  std::vector<SurfacePoint> candidates;
  for (std::size_t m = 0; m < character.meshes.size(); ++m) {
    const CharacterMesh& mesh = character.meshes[m];
    std::vector<bool> on_triangle(mesh.positions.size(), false);
    for (const std::uint32_t index : mesh.triangles) on_triangle[index] = true;
    for (std::uint32_t v = 0; v < mesh.positions.size(); ++v) {
      if (on_triangle[v] && inside[m][v]) candidates.push_back({std::uint32_t(m), {v, v, v}, {1.0f, 0.0f, 0.0f}});
    }
  }
  if (candidates.empty()) throw std::invalid_argument("sampling: the region holds no vertex on a triangle");
  if (std::size_t(count) > candidates.size()) {
    throw std::invalid_argument("sampling: " + std::to_string(count) + " vertex samples asked for, but the region has only " +
                                std::to_string(candidates.size()) + " vertices on triangles");
  }
  for (std::size_t i = 0; i < std::size_t(count); ++i) {
    std::swap(candidates[i], candidates[i + uniform_below(random, candidates.size() - i)]);
  }
  candidates.resize(std::size_t(count));
  return candidates;
}

std::vector<SurfacePoint> sample_surface(const Character& character, const std::vector<std::vector<bool>>& inside,
                                         int count, std::mt19937_64& random) {
  struct Triangle {
    std::uint32_t mesh;
    std::array<std::uint32_t, 3> corners;
  };
  std::vector<Triangle> triangles;
  std::vector<double> running_area;  // running_area[i]: area of triangles 0..i
  double total = 0.0;
  const std::vector<RigidTransform<double>> rest = character.skeleton.rest_world();
  for (std::size_t m = 0; m < character.meshes.size(); ++m) {
    const CharacterMesh& mesh = character.meshes[m];
    const std::vector<Eigen::Vector3d> world = skin_mesh_reference(mesh, rest);
    for (std::size_t t = 0; t < mesh.triangles.size(); t += 3) {
      const std::array<std::uint32_t, 3> c = {mesh.triangles[t], mesh.triangles[t + 1], mesh.triangles[t + 2]};
      if (!inside[m][c[0]] || !inside[m][c[1]] || !inside[m][c[2]]) continue;
      const double area = 0.5 * (world[c[1]] - world[c[0]]).cross(world[c[2]] - world[c[0]]).norm();
      if (!(area > 0.0)) continue;  // zero area, a repeated corner, or not finite
      total += area;
      triangles.push_back({std::uint32_t(m), c});
      running_area.push_back(total);
    }
  }
  if (triangles.empty()) throw std::invalid_argument("sampling: the region holds no triangle of non-zero area");

  std::vector<SurfacePoint> points(static_cast<std::size_t>(count));
  for (SurfacePoint& point : points) {
    const double u = uniform_unit(random) * total;
    const std::size_t t = std::min<std::size_t>(
        std::size_t(std::upper_bound(running_area.begin(), running_area.end(), u) - running_area.begin()),
        triangles.size() - 1);
    const double s = std::sqrt(uniform_unit(random)), r2 = uniform_unit(random);
    point.mesh = triangles[t].mesh;
    point.vertices = triangles[t].corners;
    point.barycentric = {float(1.0 - s), float(s * (1.0 - r2)), float(s * r2)};
  }
  return points;
}

}  // namespace

JointSet::JointSet(int joint_count) : member_(std::size_t(std::max(joint_count, 0)), false) {}

JointSet JointSet::all(const Skeleton& skeleton) {
  JointSet set(skeleton.joint_count());
  set.member_.assign(set.member_.size(), true);
  return set;
}

JointSet JointSet::of(const Skeleton& skeleton, std::span<const int> joints) {
  JointSet set(skeleton.joint_count());
  for (const int joint : joints) {
    if (joint < 0 || joint >= skeleton.joint_count()) {
      throw std::invalid_argument("joint set: joint " + std::to_string(joint) + " is not one of the skeleton's " +
                                  std::to_string(skeleton.joint_count()));
    }
    set.member_[joint] = true;
  }
  return set;
}

// Parents precede children, so one pass in joint order carries membership down every subtree.
JointSet JointSet::subtrees(const Skeleton& skeleton, std::span<const int> roots) {
  JointSet set = of(skeleton, roots);
  for (int j = 0; j < skeleton.joint_count(); ++j) {
    const int parent = skeleton.parent(j);
    if (parent >= 0 && set.member_[parent]) set.member_[j] = true;
  }
  return set;
}

JointSet JointSet::below(const Skeleton& skeleton, std::span<const int> joints) {
  const JointSet tops = of(skeleton, joints);
  JointSet set(skeleton.joint_count());
  for (int j = 0; j < skeleton.joint_count(); ++j) {
    const int parent = skeleton.parent(j);
    if (parent >= 0 && (tops.member_[parent] || set.member_[parent])) set.member_[j] = true;
  }
  return set;
}

JointSet JointSet::operator-(const JointSet& other) const {
  if (other.joint_count() != joint_count()) {
    throw std::invalid_argument("joint set difference over " + std::to_string(joint_count()) + " and " +
                                std::to_string(other.joint_count()) + " joints");
  }
  JointSet set(joint_count());
  for (std::size_t j = 0; j < member_.size(); ++j) set.member_[j] = member_[j] && !other.member_[j];
  return set;
}

bool JointSet::empty() const { return std::none_of(member_.begin(), member_.end(), [](bool m) { return m; }); }

int dominant_joint(const CharacterMesh& mesh, std::size_t vertex) {
  const std::array<float, 4>& weights = mesh.influence_weights[vertex];
  const int strongest = int(std::max_element(weights.begin(), weights.end()) - weights.begin());
  return mesh.skin_joints[mesh.influence_slots[vertex][strongest]];
}

std::vector<SurfacePoint> sample_surface_points(const Character& character, const SamplingOptions& options) {
  if (options.count < 1) {
    throw std::invalid_argument("sampling: the number of points must be at least 1, got " + std::to_string(options.count));
  }
  if (options.region) {
    if (options.region->joint_count() != character.skeleton.joint_count()) {
      throw std::invalid_argument("sampling: the region is a set over " + std::to_string(options.region->joint_count()) +
                                  " joints, but the character has " + std::to_string(character.skeleton.joint_count()));
    }
    if (options.region->empty()) throw std::invalid_argument("sampling: the region holds no joint");
  }
  for (const CharacterMesh& mesh : character.meshes) check_triangles(mesh);
  const std::vector<std::vector<bool>> inside = vertices_in_region(character, options.region);
  std::mt19937_64 random(options.seed);
  return options.mode == SamplingMode::vertices ? sample_vertices(character, inside, options.count, random)
                                                : sample_surface(character, inside, options.count, random);
}

namespace {

std::vector<MeshVertex> corner_union(std::span<const SurfacePoint> points) {
  std::vector<MeshVertex> corners;
  corners.reserve(3 * points.size());
  for (const SurfacePoint& point : points) {
    for (const std::uint32_t v : point.vertices) corners.push_back({point.mesh, v});
  }
  std::sort(corners.begin(), corners.end());
  corners.erase(std::unique(corners.begin(), corners.end()), corners.end());
  return corners;
}

}  // namespace

SurfacePointSkinner::SurfacePointSkinner(const Character& character, std::span<const SurfacePoint> points, int threads)
    : corners_skinned_(corner_union(points)), skinner_(character, corners_skinned_, {.threads = threads}) {
  corner_rows_.reserve(points.size());
  barycentric_.reserve(points.size());
  for (const SurfacePoint& point : points) {
    std::array<std::uint32_t, 3> rows{};
    for (int c = 0; c < 3; ++c) {
      const MeshVertex key{point.mesh, point.vertices[c]};
      rows[c] = std::uint32_t(std::lower_bound(corners_skinned_.begin(), corners_skinned_.end(), key) -
                              corners_skinned_.begin());
    }
    corner_rows_.push_back(rows);
    barycentric_.push_back(point.barycentric);
  }
}

void SurfacePointSkinner::skin(std::span<const RigidTransform<double>> joint_world, std::span<float> points) {
  skin_frames(1, joint_world, points);
}

void SurfacePointSkinner::skin_frames(std::size_t frames, std::span<const RigidTransform<double>> joint_world,
                                      std::span<float> points) {
  const std::size_t joints = std::size_t(joint_count()), corner_floats = 3 * skinned_vertex_count(),
                    point_floats = 3 * point_count();
  if (joint_world.size() != frames * joints || points.size() != frames * point_floats) {
    throw std::invalid_argument("surface points: " + std::to_string(frames) + " frames take " +
                                std::to_string(frames * joints) + " joint transforms and " +
                                std::to_string(frames * point_floats) + " output floats, got " +
                                std::to_string(joint_world.size()) + " and " + std::to_string(points.size()));
  }
  // Chunks of frames whose skinned corners fit in about 4 MB of scratch.
  const std::size_t chunk_frames =
      std::clamp<std::size_t>((std::size_t(1) << 20) / std::max<std::size_t>(corner_floats, 1), 1,
                              LinearBlendSkinner::kChunkFrames);
  for (std::size_t first = 0; first < frames; first += chunk_frames) {
    const std::size_t chunk = std::min(chunk_frames, frames - first);
    corners_.resize(chunk * corner_floats);
    skinner_.skin_frames(chunk, joint_world.subspan(first * joints, chunk * joints), corners_);
    // p = b0 v0 + b1 v1 + b2 v2, in blocks of points on the skinner's threads.
    constexpr std::size_t kBlockPoints = 4096;
    const std::size_t blocks = (point_count() + kBlockPoints - 1) / kBlockPoints;
    skinner_.parallel_for(chunk * blocks, chunk * point_count(), [&](std::size_t item) {
      const std::size_t f = item / blocks, begin = (item % blocks) * kBlockPoints;
      const std::size_t end = std::min(point_count(), begin + kBlockPoints);
      const float* __restrict corners = corners_.data() + f * corner_floats;
      float* __restrict out = points.data() + (first + f) * point_floats;
      for (std::size_t i = begin; i < end; ++i) {
        const std::array<std::uint32_t, 3>& rows = corner_rows_[i];
        const std::array<float, 3>& b = barycentric_[i];
        const float* __restrict v0 = corners + 3 * std::size_t(rows[0]);
        const float* __restrict v1 = corners + 3 * std::size_t(rows[1]);
        const float* __restrict v2 = corners + 3 * std::size_t(rows[2]);
        for (int c = 0; c < 3; ++c) out[3 * i + c] = b[0] * v0[c] + b[1] * v1[c] + b[2] * v2[c];
      }
    });
  }
}

}  // namespace odyssey::skinning
