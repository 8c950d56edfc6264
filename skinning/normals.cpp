#include "skinning/normals.h"

#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Core/System/omstream.hh>
#include <cmath>
#include <stdexcept>
#include <string>

namespace odyssey::skinning {
namespace {

using NormalMesh = OpenMesh::TriMesh_ArrayKernelT<OpenMesh::DefaultTraitsDouble>;

// OpenMesh reports each face it refuses on its error stream; here a refused face is expected
// and handled, so the report is switched off while faces are added (and restored after).
class QuietOpenMeshErrors {
 public:
  QuietOpenMeshErrors() : was_enabled_(::omerr().is_enabled()) { ::omerr().disable(); }
  ~QuietOpenMeshErrors() {
    if (was_enabled_) ::omerr().enable();
  }
  QuietOpenMeshErrors(const QuietOpenMeshErrors&) = delete;
  QuietOpenMeshErrors& operator=(const QuietOpenMeshErrors&) = delete;

 private:
  bool was_enabled_;
};

}  // namespace

std::vector<Eigen::Vector3f> rest_vertex_normals(const CharacterMesh& mesh) {
  const std::size_t vertex_count = mesh.positions.size();
  if (mesh.triangles.size() % 3 != 0) {
    throw std::invalid_argument("mesh '" + mesh.name + "' has " + std::to_string(mesh.triangles.size()) +
                                " triangle indices, not a multiple of 3");
  }
  for (const std::uint32_t index : mesh.triangles) {
    if (index >= vertex_count) {
      throw std::invalid_argument("mesh '" + mesh.name + "' has a triangle on vertex " + std::to_string(index) + " of " +
                                  std::to_string(vertex_count));
    }
  }

  NormalMesh topology;
  topology.request_face_normals();
  // origin[h]: the mesh vertex that OpenMesh vertex h stands for (itself, or a copy's original).
  std::vector<std::uint32_t> origin;
  origin.reserve(vertex_count);
  const auto add_vertex = [&](std::uint32_t v) {
    const Eigen::Vector3f& p = mesh.positions[v];
    origin.push_back(v);
    return topology.add_vertex(NormalMesh::Point(p.x(), p.y(), p.z()));
  };
  for (std::uint32_t v = 0; v < vertex_count; ++v) add_vertex(v);
  {
    const QuietOpenMeshErrors quiet;
    for (std::size_t t = 0; t < mesh.triangles.size(); t += 3) {
      const std::uint32_t a = mesh.triangles[t], b = mesh.triangles[t + 1], c = mesh.triangles[t + 2];
      if (a == b || b == c || a == c) continue;
      const auto face = topology.add_face(topology.vertex_handle(a), topology.vertex_handle(b), topology.vertex_handle(c));
      if (!face.is_valid()) topology.add_face(add_vertex(a), add_vertex(b), add_vertex(c));
    }
  }
  topology.update_face_normals();

  // calc_vertex_normal_fast is OpenMesh's vertex normal before its normalisation: the sum of the
  // unit normals of the faces around the vertex.
  std::vector<Eigen::Vector3d> sums(vertex_count, Eigen::Vector3d::Zero());
  for (const auto vertex : topology.vertices()) {
    NormalMesh::Normal sum;
    topology.calc_vertex_normal_fast(vertex, sum);
    sums[origin[vertex.idx()]] += Eigen::Vector3d(sum[0], sum[1], sum[2]);
  }
  std::vector<Eigen::Vector3f> normals(vertex_count, Eigen::Vector3f::Zero());
  for (std::size_t v = 0; v < vertex_count; ++v) {
    const double length = sums[v].norm();
    if (length > 0.0) normals[v] = (sums[v] / length).cast<float>();
  }
  return normals;
}

}  // namespace odyssey::skinning
