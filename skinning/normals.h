// Rest-pose vertex normals of a character mesh, from its triangle topology with OpenMesh, in the
// mesh's own space (the space of CharacterMesh::positions, before inverse_bind):
//
//   n_v = normalise( sum over triangles f around v of unit_normal(f) ),
//   unit_normal(a, b, c) = normalise( (b - a) x (c - a) )      (counter-clockwise is the front)
//
// which is OpenMesh's update_normals() on a TriMesh (vertex normal = normalised sum of the unit
// normals of the incident faces). Skinned normals (lbs.h) start from these.
//
// Topology OpenMesh cannot hold. A halfedge mesh takes only manifold faces; a triangle that would
// make an edge shared by three faces or a vertex joined at a point ("complex edge / vertex") is
// added on its own copies of its three vertices instead, the way OpenMesh's readers do, and the
// copies' face normals are summed back into the original vertex, so every triangle counts exactly
// as above. A triangle that repeats a vertex index has no normal and counts for nothing; so does
// one of zero area. A vertex on no triangle of non-zero area gets the zero vector, which skinning
// keeps at zero.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "skeleton/character.h"

namespace odyssey::skinning {

// One normal per vertex of `mesh`. Throws std::invalid_argument when the triangle list is not a
// multiple of 3 or names a vertex past the end.
std::vector<Eigen::Vector3f> rest_vertex_normals(const CharacterMesh& mesh);

}  // namespace odyssey::skinning
