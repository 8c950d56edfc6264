// Linear blend skinning of any subset of a character's vertices (the whole mesh for a point cache,
// or only the corners of sampled surface points for trajectories), one frame or many at a time,
// following the character's definition (skeleton/character.h):
//
//   v_world = sum_k w_k M_k (v_mesh, 1),            M_k = W(joint_k) inverse_bind_k
//   n_world = normalise( sum_k w_k A_k n_mesh ),    A_k = the upper-left 3x3 of M_k
//
// with W(j) the world rigid transform of joint j from forward kinematics and n_mesh the rest
// vertex normal from the mesh's triangles (normals.h). The normal rule is exact where A_k is a
// rotation times one scale, as every inverse bind the glTF loader builds from uniform node scales
// is; under non-uniform scale the exact normal would need the inverse transpose of A_k.
//
// Built once per character and vertex subset (the constructor), used every frame:
// - The subset's vertices are regrouped by how many non-zero weights they have (1, 2, 3 or 4),
//   each group stored as parallel streams (rest position, palette entries, weights, output row),
//   so the inner loop of a group has a fixed trip count. A vertex with no non-zero weight is a
//   one-influence vertex of weight 0 and lands on the origin, as in skin_mesh_reference.
// - The palette has one entry per (mesh, skin slot) pair the subset uses. Per frame, each entry is
//   M_k = [R | t](joint_k) inverse_bind_k, multiplied in double and rounded to a float 4x4.
// - The kernel (lbs_kernel.h) blends the palette entries of a vertex and transforms its float32
//   rest position once; results go to the vertex's row, rows in the order the subset was given.
//
// Precision: float32 positions, palettes and sums, so a skinned position carries a relative error
// of a few 1e-7 of the character's size (tests hold it to 1e-5 m against the double reference on
// every shared character, scaled by the size of the characters larger than 1 m).
//
// Threads: a call splits its work into items of (frame, block of up to kBlockVertices vertices of
// one group) and runs them on options.threads threads (the caller and a pool owned by the
// skinner), when it has at least kMinSharedVertexFrames vertex-frames; smaller calls run on the
// caller alone. Each vertex is computed by the same instructions whichever thread takes it, so
// the output does not depend on the number of threads, bit for bit. Frames go through in chunks of
// kChunkFrames (palettes of a chunk first, then its items), so memory does not grow with a call's
// frame count.
//
// Ownership: the skinner copies what it needs from the character (it may be destroyed after
// construction); the caller owns every input and output span. skin() and skin_frames() reuse the
// skinner's scratch palettes and pool, so one skinner serves one calling thread at a time.
#pragma once

#include <array>
#include <compare>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <vector>

#include "skeleton/character.h"
#include "skeleton/fk.h"

namespace odyssey::skinning {

// Vertex `vertex` of mesh `mesh` of a character.
struct MeshVertex {
  std::uint32_t mesh = 0;
  std::uint32_t vertex = 0;
  auto operator<=>(const MeshVertex&) const = default;
};

// Every vertex of every mesh, meshes in order: the subset for full-mesh skinning.
std::vector<MeshVertex> all_vertices(const Character& character);

struct SkinningOptions {
  int threads = 1;        // threads a call runs on, the caller included; at least 1
  bool normals = false;   // prepare rest normals so that calls can also write skinned normals
};

class LinearBlendSkinner {
 public:
  static constexpr std::size_t kBlockVertices = 2048;
  static constexpr std::size_t kChunkFrames = 256;
  // A call shares its work with the other threads only from this many vertex-frames on (about
  // 100 us of work on one thread): waking a sleeping thread costs tens of microseconds.
  static constexpr std::size_t kMinSharedVertexFrames = 1 << 16;

  // Throws std::invalid_argument when options.threads < 1, a subset entry names a mesh or vertex
  // that does not exist, or a mesh the subset uses is inconsistent (array lengths, a skin joint
  // outside the skeleton, an influence slot outside the skin), naming the mesh.
  LinearBlendSkinner(const Character& character, std::span<const MeshVertex> vertices, SkinningOptions options = {});
  ~LinearBlendSkinner();
  LinearBlendSkinner(LinearBlendSkinner&&) noexcept;
  LinearBlendSkinner& operator=(LinearBlendSkinner&&) noexcept;
  LinearBlendSkinner(const LinearBlendSkinner&) = delete;
  LinearBlendSkinner& operator=(const LinearBlendSkinner&) = delete;

  const SkinningOptions& options() const;
  std::size_t vertex_count() const;    // rows of one frame's output: the subset's size
  int joint_count() const;             // joint transforms one frame takes: the skeleton's joints
  std::size_t palette_size() const;    // (mesh, skin slot) pairs the subset uses
  // How many of the subset's vertices have 1, 2, 3 and 4 non-zero weights.
  std::array<std::size_t, 4> influence_histogram() const;

  // One frame. joint_world: joint_count() world transforms; positions: 3 vertex_count() floats,
  // (x, y, z) of subset vertex i at 3i; normals: the same layout, or empty for none (needs
  // options.normals). Throws std::invalid_argument naming both sizes when a span is the wrong size.
  void skin(std::span<const RigidTransform<double>> joint_world, std::span<float> positions,
            std::span<float> normals = {});

  // `frames` frames: joint_world frame after frame (frames x joint_count()), positions and normals
  // frame after frame (frames x vertex_count() x 3).
  void skin_frames(std::size_t frames, std::span<const RigidTransform<double>> joint_world, std::span<float> positions,
                   std::span<float> normals = {});

  // Runs body(i) once for each i in [0, count), for work that goes with skinning, such as
  // interpolating sampled points between the skinned corners: on the skinner's threads (the pool
  // the calls above use) when `work`, in units of about one skinned vertex, reaches
  // kMinSharedVertexFrames, else on the caller. body must not throw.
  void parallel_for(std::size_t count, std::size_t work, const std::function<void(std::size_t)>& body);

 private:
  struct Layout;
  std::unique_ptr<Layout> layout_;
};

}  // namespace odyssey::skinning
