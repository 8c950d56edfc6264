// A denser copy of a glTF character, for checking and measuring what mesh density changes
// (visibility on fine meshes, skinning and rasterisation cost) on rigs the shared assets only hold
// in coarse versions.
//
// One level splits every triangle of every triangle-list primitive into four at its edge
// midpoints: for the triangle (a, b, c) with midpoints m_ab, m_bc, m_ca, the triangles
// (a, m_ab, m_ca), (m_ab, b, m_bc), (m_ca, m_bc, c) and (m_ab, m_bc, m_ca), so the winding is kept.
// A midpoint is made once per vertex pair {a, b}, so the mesh stays connected wherever it was
// (seams split by UVs or normals stay split). The surface is unchanged (midpoints lie on the
// edges: no smoothing), and the original vertices come first with their own skins, so every pose
// skins them where it skins the original's. Weights are written normalised to a sum of 1 (as glTF
// asks and readers assume).
// A midpoint's attributes are its ends' means: positions, texture coordinates, colours, tangents
// and morph-target displacements averaged; normals averaged then renormalised. Its skin is the
// ends' influences merged, joint by joint, w = (w_a(j) + w_b(j)) / 2, keeping the largest
// 4 x (the number of JOINTS_n sets) (equal weights in the order a, then b, lists them) and
// renormalising to a sum of 1.
// Vertex counts grow by one per edge a level (about 4x a level for closed meshes).
#pragma once

#include <string>

namespace odyssey::io {

struct SubdividedGltf {
  std::size_t vertices_before = 0, vertices_after = 0;
  std::size_t triangles_before = 0, triangles_after = 0;
};

// Reads the glTF/GLB at in_path, subdivides every indexed or non-indexed triangle-list primitive
// `levels` times (0 copies it), and writes a GLB to out_path (images kept as the source stores
// them: embedded ones travel in the GLB, files named by URI stay named relative to out_path).
// The old vertex data is dropped from the output. Throws InputError naming the file when it
// cannot be read or parsed, when a primitive's accessor is sparse or of a type not allowed for
// its attribute, or when the result would exceed 2^32 - 1 vertices; std::invalid_argument for
// levels outside 0..6.
SubdividedGltf write_subdivided_glb(const std::string& in_path, const std::string& out_path, int levels);

}  // namespace odyssey::io
