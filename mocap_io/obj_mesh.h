// Wavefront OBJ geometry for static props: `v x y z` vertices and `f` faces (any number of
// corners, each `i`, `i/t`, `i//n` or `i/t/n`, negative indices counting back from the last
// vertex), fanned into triangles. Everything else (normals, texture coordinates, groups,
// materials) is skipped. Coordinates are returned as stored.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

namespace odyssey::io {

struct ObjMesh {
  std::vector<Eigen::Vector3f> positions;
  std::vector<std::uint32_t> triangles;  // 3 vertex indices a triangle
};

// Throws InputError naming the file and line for a malformed number, a non-finite coordinate, a
// face of fewer than 3 corners or one naming a missing vertex, and for a file without triangles.
ObjMesh load_obj(const std::string& path);

}  // namespace odyssey::io
