#include "scene_layouts/dense_maps.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace odyssey::scene {

namespace {

constexpr int kRowsPerBlock = 16;  // rows a worker takes at a time

}  // namespace

void fill_dense_maps(const CameraFrame& frame, int actors, DenseMaps& maps, bool normals, skinning::WorkerPool* workers) {
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
  auto normalise = [&](std::size_t first, std::size_t last) {
    for (std::size_t v = first; v < last; ++v) {
      if (vertex_normals[v].squaredNorm() > 0) vertex_normals[v].normalize();
    }
  };

  maps.width = buffer.width();
  maps.height = buffer.height();
  const std::size_t pixels = std::size_t(maps.width) * maps.height;
  maps.depth.resize(pixels);
  maps.normals.resize(normals ? pixels * 3 : 0);
  maps.instances.resize(pixels);
  const Eigen::Matrix3d to_world = frame.pose->rotation.transpose();
  auto fill_rows = [&](int first_row, int last_row) {
    // The owner of the last triangle looked up: neighbouring pixels mostly share their owner, and
    // the lookup is a binary search over the owners' ranges.
    std::uint32_t last_triangle = 0xffffffff;
    int last_instance = 0;
    std::uint32_t cached = 0xffffffff;
    const Eigen::Vector3d *a = nullptr, *b = nullptr, *c = nullptr, *na = nullptr, *nb = nullptr, *nc = nullptr;
    Eigen::Vector3d face = Eigen::Vector3d::Zero(), g0 = face, g1 = face;
    double area = 0, plane = 0, k0 = 0, k1 = 0;
    for (int y = first_row; y < last_row; ++y) {
      for (int x = 0; x < maps.width; ++x) {
        const std::size_t pixel = std::size_t(y) * maps.width + x;
        const std::uint32_t triangle = buffer.triangle_at(x, y);
        if (triangle == 0xffffffff) {
          maps.depth[pixel] = std::numeric_limits<float>::infinity();
          maps.instances[pixel] = 0;
          if (normals) std::fill_n(maps.normals.begin() + 3 * pixel, 3, 0.0f);
          continue;
        }
        if (triangle != last_triangle) {
          last_triangle = triangle;
          last_instance = instance_id(frame.owner(triangle), actors);
        }
        maps.depth[pixel] = buffer.depth(x, y);
        maps.instances[pixel] = static_cast<std::uint16_t>(last_instance);
        if (!normals) continue;
        std::fill_n(maps.normals.begin() + 3 * pixel, 3, 0.0f);
        if (triangle != cached) {
          // What the triangle's pixels share (most neighbouring pixels show the same triangle).
          cached = triangle;
          const std::size_t t = 3 * std::size_t{triangle};
          a = &vertices[triangles[t]], b = &vertices[triangles[t + 1]], c = &vertices[triangles[t + 2]];
          na = &vertex_normals[triangles[t]], nb = &vertex_normals[triangles[t + 1]], nc = &vertex_normals[triangles[t + 2]];
          face = (*b - *a).cross(*c - *a);
          area = face.squaredNorm();
          plane = face.dot(*a);
          // With (e x q) . F = q . (F x e), the barycentric numerators below become affine in the
          // ray: (c - b) x (p - b) . F = s (r . g0) - k0 for p = s r, likewise for corner b.
          g0 = face.cross(*c - *b), k0 = (*c - *b).cross(*b).dot(face);
          g1 = face.cross(*a - *c), k1 = (*a - *c).cross(*c).dot(face);
        }
        const Eigen::Vector3d ray((x + 0.5 - k.cx) / k.fx, (y + 0.5 - k.cy) / k.fy, 1.0);
        const double along = face.dot(ray);
        Eigen::Vector3d normal = face;
        if (along != 0 && area > 0) {
          // Barycentrics of the ray's hit p = s r, s = (F . a) / (F . r): the areas of the
          // sub-triangles opposite each corner, (c - b) x (p - b) . F / |F|^2 for corner a.
          const double along_s = plane / along;
          double w[3] = {(along_s * ray.dot(g0) - k0) / area, (along_s * ray.dot(g1) - k1) / area, 0};
          w[0] = std::clamp(w[0], 0.0, 1.0);
          w[1] = std::clamp(w[1], 0.0, 1.0 - w[0]);
          w[2] = 1.0 - w[0] - w[1];
          const Eigen::Vector3d smooth = w[0] * *na + w[1] * *nb + w[2] * *nc;
          if (smooth.squaredNorm() > 0) normal = smooth;
        }
        if (normal.squaredNorm() == 0) continue;
        // Face the camera (the buffer draws both windings): the normal points against the ray.
        if (normal.dot(ray) > 0) normal = -normal;
        const Eigen::Vector3d world = to_world * normal.normalized();
        for (int i = 0; i < 3; ++i) maps.normals[3 * pixel + i] = static_cast<float>(world(i));
      }
    }
  };
  if (!workers) {
    normalise(0, vertex_normals.size());
    fill_rows(0, maps.height);
    return;
  }
  constexpr std::size_t kVerticesPerBlock = 4096;
  workers->run((vertex_normals.size() + kVerticesPerBlock - 1) / kVerticesPerBlock, [&](std::size_t block) {
    normalise(block * kVerticesPerBlock, std::min(vertex_normals.size(), (block + 1) * kVerticesPerBlock));
  });
  workers->run((maps.height + kRowsPerBlock - 1) / kRowsPerBlock, [&](std::size_t block) {
    const int first = static_cast<int>(block) * kRowsPerBlock;
    fill_rows(first, std::min(maps.height, first + kRowsPerBlock));
  });
}

}  // namespace odyssey::scene
