// Dense maps (scene_layouts/dense_maps.h) against a brute-force ray cast: for pixels of a shot with
// two people and a box seen by an orbiting camera, the nearest triangle along the ray through the
// pixel's centre, found by testing every triangle of the render, gives the depth, the instance and
// (up to interpolation) the normal the maps hold.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "scene_layouts/dense_maps.h"
#include "scene_layouts/frame_loop.h"
#include "scene_layouts/shot.h"
#include "scene_support.h"

namespace odyssey {
namespace {

// Moller-Trumbore: the ray's parameter s at its hit with the triangle (hit = s d), or infinity.
double hit(const Eigen::Vector3d& d, const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d e1 = b - a, e2 = c - a, p = d.cross(e2);
  const double det = e1.dot(p);
  if (std::abs(det) < 1e-15) return std::numeric_limits<double>::infinity();
  const Eigen::Vector3d t = -a;
  const double u = t.dot(p) / det;
  if (u < 0 || u > 1) return std::numeric_limits<double>::infinity();
  const Eigen::Vector3d q = t.cross(e1);
  const double v = d.dot(q) / det;
  if (v < 0 || u + v > 1) return std::numeric_limits<double>::infinity();
  const double s = e2.dot(q) / det;
  return s > 0 ? s : std::numeric_limits<double>::infinity();
}

TEST(DenseMapsTest, DepthInstancesAndNormalsMatchABruteForceRayCast) {
  scene::Scene description;
  description.seconds = 1;
  description.actors = {test_support::walker("figure", test_support::kSceneFigure, -0.7, 0, 90),
                        test_support::walker("cesium", test_support::kSceneCesium, 0.7, 0, 90)};
  scene::Prop box;
  box.kind = scene::Prop::Kind::box;
  box.name = "box";
  box.size = Eigen::Vector3d(0.5, 0.5, 0.6);
  box.position = Eigen::Vector3d(0, 1.2, 0);
  scene::Prop ground;
  ground.kind = scene::Prop::Kind::ground;
  ground.name = "ground";
  ground.size = Eigen::Vector3d(20, 20, 0);
  description.props = {box, ground};
  scene::SceneCamera orbit;
  orbit.name = "orbit";
  orbit.width = 240;
  orbit.height = 135;
  orbit.rig = scene::OrbitRig{};
  description.cameras = {orbit};
  const scene::Shot shot = scene::prepare_shot(description);
  const auto actors = scene::stream_actors(shot);
  const auto cameras = scene::stream_cameras(shot);
  scene::FrameLoop loop(actors, scene::stream_props(shot), cameras);

  long pixels = 0, surfaces = 0, depth_ok = 0, instance_ok = 0, normal_ok = 0, empty_ok = 0;
  std::vector<long> per_instance(5, 0);
  scene::DenseMaps maps;
  for (int first = 0; first < loop.frame_count(); first += loop.chunk_frames()) {
    const int count = std::min(loop.chunk_frames(), loop.frame_count() - first);
    loop.pose(first, count);
    loop.skin();
    loop.classify(0, [&](const scene::CameraFrame& frame) {
      if (frame.frame % 10 != 0) return;
      scene::fill_dense_maps(frame, 2, maps);
      const auto triangles = frame.depth->triangles();
      const auto vertices = frame.depth->camera_vertices();
      const PinholeIntrinsics& k = *frame.depth->intrinsics();
      const Eigen::Matrix3d to_world = frame.pose->rotation.transpose();
      for (int y = 1; y < maps.height; y += 4) {
        for (int x = 2; x < maps.width; x += 4) {
          ++pixels;
          const Eigen::Vector3d ray((x + 0.5 - k.cx) / k.fx, (y + 0.5 - k.cy) / k.fy, 1.0);
          double nearest = std::numeric_limits<double>::infinity();
          std::size_t which = 0;
          for (std::size_t t = 0; t < triangles.size(); t += 3) {
            const double s = hit(ray, vertices[triangles[t]], vertices[triangles[t + 1]], vertices[triangles[t + 2]]);
            if (s < nearest) {
              nearest = s;
              which = t / 3;
            }
          }
          const std::size_t p = std::size_t(y) * maps.width + x;
          if (!std::isfinite(nearest)) {
            empty_ok += maps.instances[p] == 0 && std::isinf(maps.depth[p]);
            continue;
          }
          ++surfaces;
          const int instance = scene::instance_id(frame.owner(static_cast<std::uint32_t>(which)), 2);
          ++per_instance.at(instance);
          depth_ok += std::abs(maps.depth[p] - nearest) < 1e-4 * nearest;
          instance_ok += maps.instances[p] == instance;
          // The face normal against the interpolated one: within 30 degrees on these meshes (the
          // box's faces have vertices of their own, so there they are equal), and facing the
          // camera.
          const Eigen::Vector3d& a = vertices[triangles[3 * which]];
          Eigen::Vector3d face = (vertices[triangles[3 * which + 1]] - a).cross(vertices[triangles[3 * which + 2]] - a).normalized();
          if (face.dot(ray) > 0) face = -face;
          const Eigen::Vector3d n(maps.normals[3 * p], maps.normals[3 * p + 1], maps.normals[3 * p + 2]);
          normal_ok += std::abs(n.norm() - 1) < 1e-5 && n.dot(to_world * face) > std::cos(30 * M_PI / 180) &&
                       n.dot(to_world * ray) < 0;
        }
      }
    });
  }
  std::printf("%ld pixels, %ld on surfaces (figure %ld, cesium %ld, box %ld, ground %ld)\n", pixels, surfaces, per_instance[1],
              per_instance[2], per_instance[3], per_instance[4]);
  ASSERT_GT(per_instance[1] + per_instance[2], 100);
  ASSERT_GT(per_instance[3], 20);
  ASSERT_GT(per_instance[4], 1000);
  // Pixel centres within 1/1024 px of an edge may go to either triangle: a handful of samples.
  EXPECT_GT(static_cast<double>(depth_ok) / surfaces, 0.995);
  EXPECT_GT(static_cast<double>(instance_ok) / surfaces, 0.995);
  EXPECT_GT(static_cast<double>(normal_ok) / surfaces, 0.99);
  EXPECT_EQ(empty_ok, pixels - surfaces);
}

}  // namespace
}  // namespace odyssey
