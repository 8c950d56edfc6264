#include "scene_layouts/dense_maps.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace odyssey::scene {

void fill_dense_maps(const CameraFrame& frame, int actors, DenseMaps& maps, bool normals) {
  const DepthBuffer& buffer = *frame.depth;
  if (!buffer.intrinsics()) throw std::invalid_argument("dense maps of a frame that was not rendered");
  const PinholeIntrinsics& k = *buffer.intrinsics();
  const std::span<const std::uint32_t> triangles = buffer.triangles();
  const std::span<const Eigen::Vector3d> vertices = buffer.camera_vertices();

  // Area-weighted vertex normals in camera space: the sum of the cross products (twice the area
  // times the unit normal) of the triangles using the vertex, made unit length, as a renderer
  // gets them from the GLB's NORMAL attribute and interpolates them (unnormalised sums would
  // weight the corners of a pixel's triangle by the area around each).
  std::vector<Eigen::Vector3d>& vertex_normals = maps.vertex_normals;
  vertex_normals.assign(normals ? vertices.size() : 0, Eigen::Vector3d::Zero());
  for (std::size_t t = 0; normals && t + 2 < triangles.size(); t += 3) {
    const Eigen::Vector3d& a = vertices[triangles[t]];
    const Eigen::Vector3d n = (vertices[triangles[t + 1]] - a).cross(vertices[triangles[t + 2]] - a);
    for (int c = 0; c < 3; ++c) vertex_normals[triangles[t + c]] += n;
  }
  for (Eigen::Vector3d& n : vertex_normals) {
    if (n.squaredNorm() > 0) n.normalize();
  }

  maps.width = buffer.width();
  maps.height = buffer.height();
  const std::size_t pixels = std::size_t(maps.width) * maps.height;
  maps.depth.assign(pixels, std::numeric_limits<float>::infinity());
  maps.normals.assign(normals ? pixels * 3 : 0, 0.0f);
  maps.instances.assign(pixels, 0);
  const Eigen::Matrix3d to_world = frame.pose->rotation.transpose();
  for (int y = 0; y < maps.height; ++y) {
    for (int x = 0; x < maps.width; ++x) {
      const std::uint32_t triangle = buffer.triangle_at(x, y);
      if (triangle == 0xffffffff) continue;
      const std::size_t pixel = std::size_t(y) * maps.width + x;
      maps.depth[pixel] = buffer.depth(x, y);
      maps.instances[pixel] = static_cast<std::uint16_t>(instance_id(frame.owner(triangle), actors));
      if (!normals) continue;
      const std::size_t t = 3 * std::size_t{triangle};
      const Eigen::Vector3d& a = vertices[triangles[t]];
      const Eigen::Vector3d& b = vertices[triangles[t + 1]];
      const Eigen::Vector3d& c = vertices[triangles[t + 2]];
      const Eigen::Vector3d face = (b - a).cross(c - a);
      const Eigen::Vector3d ray((x + 0.5 - k.cx) / k.fx, (y + 0.5 - k.cy) / k.fy, 1.0);
      const double along = face.dot(ray);
      Eigen::Vector3d normal = face;
      if (along != 0 && face.squaredNorm() > 0) {
        // Barycentrics of the ray's hit p: the areas of the sub-triangles opposite each corner.
        const Eigen::Vector3d p = ray * (face.dot(a) / along);
        const double area = face.squaredNorm();
        double w[3] = {(c - b).cross(p - b).dot(face) / area, (a - c).cross(p - c).dot(face) / area, 0};
        w[0] = std::clamp(w[0], 0.0, 1.0);
        w[1] = std::clamp(w[1], 0.0, 1.0 - w[0]);
        w[2] = 1.0 - w[0] - w[1];
        const Eigen::Vector3d smooth = w[0] * vertex_normals[triangles[t]] + w[1] * vertex_normals[triangles[t + 1]] +
                                       w[2] * vertex_normals[triangles[t + 2]];
        if (smooth.squaredNorm() > 0) normal = smooth;
      }
      if (normal.squaredNorm() == 0) continue;
      // Face the camera (the buffer draws both windings): the normal points against the ray.
      if (normal.dot(ray) > 0) normal = -normal;
      const Eigen::Vector3d world = to_world * normal.normalized();
      for (int i = 0; i < 3; ++i) maps.normals[3 * pixel + i] = static_cast<float>(world(i));
    }
  }
}

}  // namespace odyssey::scene
