// DepthBuffer: exact depths of frontal and slanted planes (perspective-correct, watertight along a
// shared diagonal, both windings), one square hiding another exactly up to its outline, the reach
// of the ray test at its boundary (absolute and relative), silhouettes (a bar's edge and a sub-pixel
// sliver beside a face) against brute-force ray casting, closed meshes (a sphere and a cube,
// frontal and oblique) whose front points are all visible and whose back points are hidden, a steep
// slant that a depth comparison at the nearest centre would hide, triangles crossing the near
// plane, points outside the image or behind the camera or before any render, and error cases.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "test_support.h"
#include "scene_layouts/visibility.h"
#include "skeleton/camera.h"

using odyssey::CameraPose;
using odyssey::intrinsics_from_hfov;
using odyssey::PinholeIntrinsics;
using odyssey::PixelProjection;
using odyssey::project;
using odyssey::scene::DepthBuffer;
using Eigen::Vector3d;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// The dataset's default camera: 960x540, 60 degrees across, f = 480 / tan(30 deg) = 831.4 px.
const PinholeIntrinsics kCamera = intrinsics_from_hfov(960, 540, 60);

struct Mesh {
  std::vector<float> positions;
  std::vector<std::uint32_t> triangles;

  std::uint32_t add(const Vector3d& p) {
    for (int k = 0; k < 3; ++k) positions.push_back(static_cast<float>(p[k]));
    return static_cast<std::uint32_t>(positions.size() / 3 - 1);
  }
  // As the rasteriser sees it: the float32 position, back in double.
  Vector3d vertex(std::uint32_t i) const { return {positions[3 * i], positions[3 * i + 1], positions[3 * i + 2]}; }
  void add_triangle(std::uint32_t a, std::uint32_t b, std::uint32_t c) { triangles.insert(triangles.end(), {a, b, c}); }
  // Corners in order around the quadrilateral; split along the diagonal 0-2.
  void add_quad(const Vector3d& a, const Vector3d& b, const Vector3d& c, const Vector3d& d) {
    const std::uint32_t i = add(a), j = add(b), k = add(c), l = add(d);
    add_triangle(i, j, k);
    add_triangle(i, k, l);
  }
};

// The world point that identity camera pose projects to pixel (u, v) at depth z.
Vector3d unproject(double u, double v, double z) {
  return {(u - kCamera.cx) / kCamera.fx * z, (v - kCamera.cy) / kCamera.fy * z, z};
}

// A frontal square at depth z covering the screen rectangle [u0, u1] x [v0, v1] (identity pose).
Mesh frontal_square(double u0, double v0, double u1, double v1, double z) {
  Mesh mesh;
  mesh.add_quad(unproject(u0, v0, z), unproject(u1, v0, z), unproject(u1, v1, z), unproject(u0, v1, z));
  return mesh;
}

Mesh merged(const Mesh& a, const Mesh& b) {
  Mesh mesh = a;
  const auto offset = static_cast<std::uint32_t>(a.positions.size() / 3);
  mesh.positions.insert(mesh.positions.end(), b.positions.begin(), b.positions.end());
  for (const std::uint32_t i : b.triangles) mesh.triangles.push_back(i + offset);
  return mesh;
}

DepthBuffer rendered(const Mesh& mesh, const CameraPose& pose = {}) {
  DepthBuffer buffer(kCamera.width, kCamera.height);
  buffer.render(pose, kCamera, mesh.positions, mesh.triangles);
  return buffer;
}

bool visible_point(const DepthBuffer& buffer, const CameraPose& pose, const Vector3d& world) {
  return buffer.visible(pose.to_camera(world));
}

// The buffer's reach: an occluder this far or nearer in front of a point along its ray does not hide it.
double reach(const Vector3d& camera_point) {
  return DepthBuffer::kRelativeDepthTolerance * camera_point.norm();
}

// The exact answer by brute force: whether the segment from the camera centre to the camera point
// crosses any triangle of the mesh (its float vertices, in double) more than the reach before the
// point. Moller-Trumbore for the ray s P from the origin: with e1 = b - a, e2 = c - a, w = -a,
// det = e1 . (P x e2), beta = w . (P x e2) / det, gamma = P . (w x e1) / det, s = e2 . (w x e1) / det,
// with triangles grown by 1e-9 in barycentric units so that rays through shared edges or vertices
// do not slip between the triangles by rounding.
bool hidden_by_ray(const Mesh& mesh, const CameraPose& pose, const Vector3d& camera_point) {
  constexpr double kSlack = 1e-9;
  for (std::size_t t = 0; t < mesh.triangles.size(); t += 3) {
    const Vector3d a = pose.to_camera(mesh.vertex(mesh.triangles[t]));
    const Vector3d e1 = pose.to_camera(mesh.vertex(mesh.triangles[t + 1])) - a;
    const Vector3d e2 = pose.to_camera(mesh.vertex(mesh.triangles[t + 2])) - a;
    const Vector3d p = camera_point.cross(e2), w = -a, q = w.cross(e1);
    const double det = e1.dot(p);
    if (det == 0) continue;
    const double beta = w.dot(p) / det, gamma = camera_point.dot(q) / det, s = e2.dot(q) / det;
    if (beta >= -kSlack && gamma >= -kSlack && beta + gamma <= 1 + kSlack && s > 0 &&
        (1 - s) * camera_point.norm() > reach(camera_point))
      return true;
  }
  return false;
}

using odyssey::test_support::contains;
using odyssey::test_support::message_of;

// A frontal square whose corners sit on pixel corners (100, 100) and (300, 300), so its diagonal
// u = v runs exactly through the centres (i + 0.5, i + 0.5): the two triangles must share them
// without a gap. Every centre inside reads d (float 1/z: within a few 1e-8), every other +inf, and
// the reversed winding draws the same.
TEST(DepthBuffer, FrontalPlaneReadsItsDepthEverywhereItCovers) {
  const double d = 2.7;
  Mesh mesh = frontal_square(100, 100, 300, 300, d);
  for (const bool reversed : {false, true}) {
    if (reversed) {
      for (std::size_t t = 0; t < mesh.triangles.size(); t += 3) std::swap(mesh.triangles[t + 1], mesh.triangles[t + 2]);
    }
    const DepthBuffer buffer = rendered(mesh);
    int covered = 0, wrong = 0;
    for (int y = 0; y < kCamera.height; ++y) {
      for (int x = 0; x < kCamera.width; ++x) {
        const bool inside = x >= 100 && x < 300 && y >= 100 && y < 300;
        const double z = buffer.depth(x, y);
        covered += inside;
        wrong += inside ? !(std::abs(z - d) <= 1e-5 * d) : z != kInf;
      }
    }
    EXPECT_EQ(covered, 200 * 200);
    EXPECT_EQ(wrong, 0) << (reversed ? "reversed winding" : "original winding");
    EXPECT_NEAR(buffer.depth(150, 150), d, 1e-5 * d);  // on the diagonal
    EXPECT_NEAR(buffer.depth(299, 100), d, 1e-5 * d);  // the far corners of each triangle
    EXPECT_NEAR(buffer.depth(100, 299), d, 1e-5 * d);
  }
}

// A plane slanted 60 degrees about the camera's y axis, n = (sin 60, 0, -cos 60), through (0, 0, 3):
// along the ray through pixel (u, v), direction r = ((u - cx)/fx, (v - cy)/fy, 1), it is met at
// z = (n . p0) / (n . r). Linear interpolation of z instead of 1/z would be off by percents here.
TEST(DepthBuffer, SlantedPlaneDepthIsPerspectiveCorrect) {
  const double angle = 60 * std::numbers::pi / 180;
  const Vector3d normal(std::sin(angle), 0, -std::cos(angle)), p0(0, 0, 3);
  const Vector3d along(std::cos(angle), 0, std::sin(angle)), down(0, 1, 0);  // in the plane
  Mesh mesh;
  mesh.add_quad(p0 - 2 * along - down, p0 + 2 * along - down, p0 + 2 * along + down, p0 - 2 * along + down);
  const DepthBuffer buffer = rendered(mesh);
  int checked = 0, wrong = 0;
  double nearest = kInf, farthest = 0;
  for (int y = 0; y < kCamera.height; ++y) {
    for (int x = 0; x < kCamera.width; ++x) {
      const double z = buffer.depth(x, y);
      if (z == kInf) continue;
      const Vector3d ray((x + 0.5 - kCamera.cx) / kCamera.fx, (y + 0.5 - kCamera.cy) / kCamera.fy, 1);
      const double expected = normal.dot(p0) / normal.dot(ray);
      wrong += !(std::abs(z - expected) <= 1e-5 * expected);
      ++checked;
      nearest = std::min(nearest, z);
      farthest = std::max(farthest, z);
    }
  }
  EXPECT_GT(checked, 50000);
  EXPECT_EQ(wrong, 0);
  EXPECT_GT(farthest / nearest, 3);  // a real slant: from z = 1.5 at the left edge to 4.7 at the quad's end
}

// A near square at z = 2 over [300, 500] x [150, 350] in front of a far square at z = 4 over
// [100, 800] x [50, 450]. A far point is hidden exactly when its pixel position lies inside the near
// square (the sample positions stay at least 0.25 px from its outline); every point of the near
// square is visible.
TEST(DepthBuffer, SquareHidesTheSquareBehindItUpToItsOutline) {
  const Mesh near = frontal_square(300, 150, 500, 350, 2);
  const DepthBuffer buffer = rendered(merged(near, frontal_square(100, 50, 800, 450, 4)));
  int hidden_checked = 0, visible_checked = 0, near_checked = 0;
  for (double u = 100.25; u < 800; u += 1.5) {
    for (double v = 50.25; v < 450; v += 1.5) {
      const bool inside = u > 300 && u < 500 && v > 150 && v < 350;
      EXPECT_EQ(buffer.visible(unproject(u, v, 4)), !inside) << u << ", " << v;
      ++(inside ? hidden_checked : visible_checked);
      if (u >= 300 && u <= 500 && v >= 150 && v <= 350) {
        // The point of the near square at this pixel, projected as the exporter does.
        EXPECT_TRUE(visible_point(buffer, {}, unproject(u, v, 2))) << u << ", " << v;
        ++near_checked;
      }
    }
  }
  EXPECT_GT(hidden_checked, 17000);
  EXPECT_GT(visible_checked, 100000);
  EXPECT_GT(near_checked, 15000);
}

// The reach: behind a frontal plane at depth d, a point whose ray crosses the plane half the reach
// before it is visible, one at twice the reach hidden, at every depth from 5 mm to 40 m. On the ray
// through (u, v) with direction r (r_z = 1), the point at depth z lies |r| (z - d) behind the
// plane's crossing, and the reach there is 1e-4 |r| z.
TEST(DepthBuffer, ReachDecidesNearlyCoincidentSurfaces) {
  for (const double d : {0.005, 0.05, 2.0, 40.0}) {
    const DepthBuffer buffer = rendered(frontal_square(200, 100, 700, 400, d));
    for (const double u : {200.6, 333.3, 699.4}) {
      const double r = unproject(u, 250, 1).norm();
      EXPECT_TRUE(buffer.visible(unproject(u, 250, d))) << d;
      for (const double factor : {0.5, 2.0}) {
        // |r| (z - d) = factor 1e-4 |r| z.
        const double z = d / (1 - factor * DepthBuffer::kRelativeDepthTolerance);
        const Vector3d point = unproject(u, 250, z);
        EXPECT_NEAR(r * (z - d) / reach(point), factor, 1e-6);
        EXPECT_EQ(buffer.visible(point), factor < 1) << d << " " << u << " " << factor;
      }
    }
  }
}

// A bar at z = 2 over [400.3, 402.7] x [100.2, 400.6] (edges between pixel centres) in front of a
// plane at z = 4 over [300, 500] x [50, 450]: points of the far plane within a pixel of the bar's
// outline are hidden exactly when their ray meets the bar, that is when their pixel position lies
// inside it; comparing depths at the nearest centres cannot tell, as two of them show the bar and
// two the plane the point lies on.
TEST(DepthBuffer, PointsBesideASilhouetteFollowTheirOwnRay) {
  const Mesh mesh = merged(frontal_square(400.3, 100.2, 402.7, 400.6, 2), frontal_square(300, 50, 500, 450, 4));
  const DepthBuffer buffer = rendered(mesh);
  int hidden = 0, shown = 0;
  auto check = [&](double u, double v) {
    const Vector3d point = unproject(u, v, 4);
    const bool inside = u > 400.3 && u < 402.7 && v > 100.2 && v < 400.6;
    ASSERT_EQ(hidden_by_ray(mesh, {}, point), inside) << u << ", " << v;
    EXPECT_EQ(buffer.visible(point), !inside) << u << ", " << v;
    ++(inside ? hidden : shown);
  };
  for (double offset = -0.995; offset < 1; offset += 0.01) {
    if (std::abs(offset) < 1e-3) continue;  // on the outline: float corners decide
    for (double v = 110.37; v < 390; v += 7.3) {
      check(400.3 + offset, v);
      check(402.7 + offset, v);
    }
    for (double u = 400.41; u < 402.7; u += 0.23) {
      check(u, 100.2 + offset);
      check(u, 400.6 + offset);
    }
  }
  EXPECT_GT(hidden, 4000);
  EXPECT_GT(shown, 4000);
}

// A silhouette seen edge-on: a frontal face at z = 2 over [380, 400.2] x [200, 300] whose right edge
// is shared by a triangle sloping away to an apex at (400.45, 250), z = 2.3. On screen that triangle
// is a sliver between the columns of centres 399.5 and 400.5 and covers none, so the ID buffer never
// names it: the points of a plane at z = 4 behind it are still found hidden by it. Checked against
// brute force, with both outcomes present.
TEST(DepthBuffer, SubPixelSliverThatCoversNoCentreStillHides) {
  Mesh mesh;
  const std::uint32_t a = mesh.add(unproject(380, 200, 2)), b = mesh.add(unproject(400.2, 200, 2)),
                      c = mesh.add(unproject(400.2, 300, 2)), d = mesh.add(unproject(380, 300, 2)),
                      apex = mesh.add(unproject(400.45, 250, 2.3));
  mesh.add_triangle(a, b, c);
  mesh.add_triangle(a, c, d);
  mesh.add_triangle(b, apex, c);
  mesh = merged(mesh, frontal_square(300, 100, 500, 400, 4));
  const DepthBuffer buffer = rendered(mesh);
  int hidden = 0, shown = 0, wrong = 0;
  for (double u = 400.205; u < 400.5; u += 0.01) {
    for (double v = 201.3; v < 300; v += 1.7) {
      const Vector3d point = unproject(u, v, 4);
      const bool expected_hidden = hidden_by_ray(mesh, {}, point);
      wrong += buffer.visible(point) == expected_hidden;
      ++(expected_hidden ? hidden : shown);
    }
  }
  EXPECT_EQ(wrong, 0);
  EXPECT_GT(hidden, 300);
  EXPECT_GT(shown, 300);
}

// Dense points on a closed mesh: every point on a face turned towards the camera must be visible
// (no false hides, at any slant); `hidden_expected` says which of the others must be hidden.
struct SurfaceCounts {
  int front = 0, front_hidden = 0, back_checked = 0, back_visible = 0, grazing = 0, grazing_wrong = 0;
};

// A UV sphere (poles as single vertices), outward normals from the centre.
Mesh sphere(const Vector3d& centre, double radius, int rings, int segments) {
  Mesh mesh;
  auto at = [&](double theta, double phi) {
    Vector3d p = centre;
    p.x() += radius * std::sin(theta) * std::cos(phi);
    p.y() += radius * std::sin(theta) * std::sin(phi);
    p.z() += radius * std::cos(theta);
    return p;
  };
  const std::uint32_t top = mesh.add(centre + Vector3d(0, 0, radius));
  for (int r = 1; r < rings; ++r) {
    for (int s = 0; s < segments; ++s) mesh.add(at(std::numbers::pi * r / rings, 2 * std::numbers::pi * s / segments));
  }
  const std::uint32_t bottom = mesh.add(centre - Vector3d(0, 0, radius));
  auto ring_vertex = [&](int r, int s) { return static_cast<std::uint32_t>(1 + (r - 1) * segments + s % segments); };
  for (int s = 0; s < segments; ++s) {
    mesh.add_triangle(top, ring_vertex(1, s), ring_vertex(1, s + 1));
    mesh.add_triangle(bottom, ring_vertex(rings - 1, s + 1), ring_vertex(rings - 1, s));
    for (int r = 1; r + 1 < rings; ++r) {
      mesh.add_triangle(ring_vertex(r, s), ring_vertex(r + 1, s), ring_vertex(r + 1, s + 1));
      mesh.add_triangle(ring_vertex(r, s), ring_vertex(r + 1, s + 1), ring_vertex(r, s + 1));
    }
  }
  return mesh;
}

// Points on every triangle at barycentric (a, b, n - a - b) / n, vertices and edges included, as
// the exporter samples them (float vertices, double arithmetic). A face is in front when its
// outward normal m (oriented away from `centre`) has m . (camera - p) > 0; a back point with
// m^ . (camera - p)^ < -0.3 lies on a ray that crossed the front of the sphere at least
// 2 r 0.3 earlier and more than a pixel inside its outline, so it must be hidden. Points at grazing
// slants on either side of the outline (|m^ . (camera - p)^| < 0.05) must agree with brute-force
// ray casting over the whole mesh.
TEST(DepthBuffer, SphereShowsItsFrontAndHidesItsBack) {
  const Vector3d centre(0.2, 0.1, 1.0);
  const Mesh mesh = sphere(centre, 0.5, 32, 64);
  const CameraPose pose = CameraPose::look_at(Vector3d(3, -1, 1.6), centre);
  const DepthBuffer buffer = rendered(mesh, pose);
  const Vector3d camera = pose.centre();
  SurfaceCounts counts;
  double most_grazing = 1;
  const int n = 6;
  for (std::size_t t = 0; t < mesh.triangles.size(); t += 3) {
    const Vector3d a = mesh.vertex(mesh.triangles[t]), b = mesh.vertex(mesh.triangles[t + 1]),
                   c = mesh.vertex(mesh.triangles[t + 2]);
    Vector3d normal = (b - a).cross(c - a).normalized();
    if (normal.dot((a + b + c) / 3 - centre) < 0) normal = -normal;
    for (int i = 0; i <= n; ++i) {
      for (int j = 0; i + j <= n; ++j) {
        const Vector3d p = (i * a + j * b + (n - i - j) * c) / n;
        const double facing = normal.dot((camera - p).normalized());
        const bool shown = visible_point(buffer, pose, p);
        if (std::abs(facing) < 0.05) {
          ++counts.grazing;
          counts.grazing_wrong += shown == hidden_by_ray(mesh, pose, pose.to_camera(p));
        }
        if (facing > 0) {
          ++counts.front;
          counts.front_hidden += !shown;
          most_grazing = std::min(most_grazing, facing);
        } else if (facing < -0.3) {
          ++counts.back_checked;
          counts.back_visible += shown;
        }
      }
    }
  }
  EXPECT_EQ(counts.front_hidden, 0) << "of " << counts.front << " front points";
  EXPECT_EQ(counts.back_visible, 0) << "of " << counts.back_checked << " back points";
  EXPECT_GT(counts.front, 40000);
  EXPECT_GT(counts.back_checked, 40000);
  EXPECT_LT(most_grazing, 0.02);  // the front set reaches grazing slants at the outline
  EXPECT_EQ(counts.grazing_wrong, 0) << "of " << counts.grazing << " grazing points";
  EXPECT_GT(counts.grazing, 2000);
}

// A unit cube's six faces, each sampled on a (2m + 1)^2 grid over the whole face (edges and corners
// included) for faces towards the camera, and over the inner 80% for the others: those project
// inside the outline of the front faces and lie behind them, so they must be hidden.
SurfaceCounts cube_counts(const CameraPose& pose) {
  Mesh mesh;
  std::vector<std::array<Vector3d, 3>> faces;  // centre, two half-edge vectors
  for (int axis = 0; axis < 3; ++axis) {
    for (const double side : {-0.5, 0.5}) {
      Vector3d c = Vector3d::Zero(), e1 = Vector3d::Zero(), e2 = Vector3d::Zero();
      c[axis] = side;
      e1[(axis + 1) % 3] = 0.5;
      e2[(axis + 2) % 3] = 0.5;
      mesh.add_quad(c - e1 - e2, c + e1 - e2, c + e1 + e2, c - e1 + e2);
      faces.push_back({c, e1, e2});
    }
  }
  const DepthBuffer buffer = rendered(mesh, pose);
  SurfaceCounts counts;
  const int m = 60;
  for (const auto& [c, e1, e2] : faces) {
    const bool front = c.dot(pose.centre() - c) > 0;  // the outward normal is c / |c|
    for (int i = -m; i <= m; ++i) {
      for (int j = -m; j <= m; ++j) {
        const double s = double(i) / m, t = double(j) / m;
        const Vector3d p = c + s * e1 + t * e2;
        if (front) {
          ++counts.front;
          counts.front_hidden += !visible_point(buffer, pose, p);
        } else if (std::abs(s) <= 0.8 && std::abs(t) <= 0.8) {
          ++counts.back_checked;
          counts.back_visible += visible_point(buffer, pose, p);
        }
      }
    }
  }
  return counts;
}

// A scene scaled as a whole is judged the same at every scale: a sphere and, 2% of its radius in
// front of it, a plate covering part of it, seen by a camera at three radii; every vertex of both,
// and points 0.5% of the radius behind the plate, have the same visibility for a radius of 1 cm,
// 1 m and 100 m (an absolute tolerance of 1 mm, as the test once had, let 78 of the 773 hidden
// points of the 1 cm scene through).
TEST(DepthBuffer, VisibilityIsTheSameAtEveryScale) {
  std::vector<std::vector<bool>> shown;
  for (const double scale : {0.01, 1.0, 100.0}) {
    const Vector3d centre = Vector3d(0.1, -0.05, 3.0) * scale;
    Mesh mesh = sphere(centre, scale, 24, 48);
    const std::size_t sphere_vertices = mesh.positions.size() / 3;
    const double plate_z = centre.z() - 1.02 * scale;
    mesh = merged(mesh, frontal_square(300, 150, 520, 330, plate_z));
    const DepthBuffer buffer = rendered(mesh);
    std::vector<bool> flags;
    for (std::size_t i = 0; i < mesh.positions.size() / 3; ++i) flags.push_back(buffer.visible(mesh.vertex(i)));
    for (double u = 310; u < 520; u += 7.3) flags.push_back(buffer.visible(unproject(u, 240, plate_z + 0.005 * scale)));
    EXPECT_GT(std::count(flags.begin(), flags.begin() + sphere_vertices, false), 300) << scale;
    std::printf("scale %g: %ld hidden of %zu\n", scale, std::count(flags.begin(), flags.end(), false), flags.size());
    shown.push_back(std::move(flags));
  }
  EXPECT_EQ(shown[0], shown[1]);
  EXPECT_EQ(shown[2], shown[1]);
}

TEST(DepthBuffer, CubeSeenFaceOnShowsItsFrontFace) {
  // Straight at the face x = +0.5 from 2.5 m: one frontal face; the four side faces are seen
  // from behind (just), the face x = -0.5 from behind.
  const SurfaceCounts counts = cube_counts(CameraPose::look_at(Vector3d(3, 0, 0), Vector3d::Zero()));
  EXPECT_EQ(counts.front, 121 * 121);
  EXPECT_EQ(counts.front_hidden, 0);
  EXPECT_EQ(counts.back_checked, 5 * 97 * 97);
  EXPECT_EQ(counts.back_visible, 0);
}

TEST(DepthBuffer, CubeSeenObliquelyShowsItsThreeFrontFaces) {
  // From (2.1, 1.3, 1.7): faces x+, y+, z+ in front, at three different slants.
  const SurfaceCounts counts = cube_counts(CameraPose::look_at(Vector3d(2.1, 1.3, 1.7), Vector3d(0.05, -0.02, 0.1)));
  EXPECT_EQ(counts.front, 3 * 121 * 121);
  EXPECT_EQ(counts.front_hidden, 0);
  EXPECT_EQ(counts.back_checked, 3 * 97 * 97);
  EXPECT_EQ(counts.back_visible, 0);
}

// On a plane slanted 85 degrees from frontal, depth changes by z tan(85 deg) / f, about 1.4% of z,
// per pixel: comparing a point's depth with its nearest centre's would hide many points of the
// surface they lie on; their rays meet no triangle before them, so the ray test hides none.
TEST(DepthBuffer, SteepSlantHidesNoPointOfItsOwnSurface) {
  const double angle = 85 * std::numbers::pi / 180;
  const Vector3d p0(0, 0, 3), along(std::cos(angle), 0, std::sin(angle)), down(0, 1, 0);
  Mesh mesh;
  mesh.add_quad(p0 - 2 * along - down, p0 + 2 * along - down, p0 + 2 * along + down, p0 - 2 * along + down);
  const DepthBuffer buffer = rendered(mesh);
  int points = 0, hidden = 0, hidden_by_nearest_centre = 0;
  for (double s = -2; s <= 2; s += 0.001) {
    for (double t = -1; t <= 1; t += 0.05) {
      const PixelProjection p = project({}, kCamera, p0 + s * along + t * down);
      if (!p.valid) continue;
      ++points;
      hidden += !buffer.visible(p0 + s * along + t * down);
      const double nearest = buffer.depth(static_cast<int>(p.u), static_cast<int>(p.v));
      hidden_by_nearest_centre += p.depth > (1 + 1e-3) * nearest;
    }
  }
  EXPECT_GT(points, 50000);
  EXPECT_EQ(hidden, 0);
  EXPECT_GT(hidden_by_nearest_centre, points / 4);
}

// The plane z = 2 + x (camera coordinates) over x, y in [-3, 3] reaches behind the camera (z = -1
// at x = -3): one of its triangles has one corner behind, the other two. Clipped at the near plane,
// it still covers the whole image at depth z = 2 / (1 - r_x) along the ray r = (r_x, r_y, 1), and
// hides a wall at z = 10 where it is nearer; a triangle wholly behind the camera draws nothing.
TEST(DepthBuffer, TrianglesCrossingTheNearPlaneStillOcclude) {
  Mesh plane;
  plane.add_quad(Vector3d(-3, -3, -1), Vector3d(3, -3, 5), Vector3d(3, 3, 5), Vector3d(-3, 3, -1));
  Mesh behind;
  behind.add_quad(Vector3d(-3, -3, -2), Vector3d(3, -3, -2), Vector3d(3, 3, -0.5), Vector3d(-3, 3, -0.5));
  const DepthBuffer buffer = rendered(merged(merged(plane, behind), frontal_square(0, 0, 960, 540, 10)));
  int wrong_depth = 0, wall_hidden = 0, wall_checked = 0;
  for (int y = 0; y < kCamera.height; ++y) {
    for (int x = 0; x < kCamera.width; ++x) {
      // Where the ray meets the plane: |x| <= 2.8 and |y| = |r_y| z <= 0.33 * 4.8 < 3, inside the quad.
      const double rx = (x + 0.5 - kCamera.cx) / kCamera.fx;
      const double z = 2 / (1 - rx);
      wrong_depth += !(std::abs(buffer.depth(x, y) - z) <= 1e-5 * z);
      // A wall point at this pixel centre is hidden (the plane is nearer than 10 everywhere here:
      // r_x < 0.58 gives z < 4.8).
      ++wall_checked;
      wall_hidden += !buffer.visible(unproject(x + 0.5, y + 0.5, 10));
    }
  }
  EXPECT_EQ(wrong_depth, 0);
  EXPECT_EQ(wall_hidden, wall_checked);
  // At the left edge the plane is met at z = 2 / (1 + 0.577) = 1.27 by the part whose triangles
  // cross the near plane.
  EXPECT_NEAR(buffer.depth(0, 270), 2 / (1 - (0.5 - kCamera.cx) / kCamera.fx), 1e-5);
}

TEST(DepthBuffer, PointsOutsideTheImageOrBehindTheCameraAreNotVisible) {
  DepthBuffer buffer(kCamera.width, kCamera.height);
  EXPECT_FALSE(buffer.visible(unproject(480, 270, 1)));  // no camera before the first render
  buffer.render({}, kCamera, {}, {});
  const double w = kCamera.width, h = kCamera.height;
  // An empty buffer hides nothing that is in the image and in front.
  for (const auto& [u, v] : std::vector<std::pair<double, double>>{{0, 0}, {w - 1e-9, h - 1e-9}, {480, 270}, {0.2, h - 0.2}})
    EXPECT_TRUE(buffer.visible(unproject(u, v, 1))) << u << ", " << v;
  for (const auto& [u, v] : std::vector<std::pair<double, double>>{{-1e-9, 10}, {w, 10}, {10, -0.5}, {10, h}, {NAN, 10}, {10, NAN}})
    EXPECT_FALSE(buffer.visible(unproject(u, v, 1))) << u << ", " << v;
  for (const Vector3d& point : {Vector3d(0, 0, 0), Vector3d(0.1, 0.1, -2), Vector3d(0, 0, kInf), Vector3d(kInf, 0, 1),
                                Vector3d(0, NAN, 1), Vector3d(0, 0, NAN)})
    EXPECT_FALSE(buffer.visible(point)) << point.transpose();
  EXPECT_EQ(buffer.depth(0, 0), kInf);
  // A render that throws leaves no camera either.
  PinholeIntrinsics bad = kCamera;
  bad.fx = -1;
  EXPECT_THROW(buffer.render({}, bad, {}, {}), std::invalid_argument);
  EXPECT_FALSE(buffer.visible(unproject(480, 270, 1)));
}

TEST(DepthBuffer, RenderClearsThePreviousFrame) {
  DepthBuffer buffer(kCamera.width, kCamera.height);
  const Mesh square = frontal_square(0, 0, 960, 540, 1);
  buffer.render({}, kCamera, square.positions, square.triangles);
  EXPECT_NEAR(buffer.depth(5, 5), 1, 1e-6);
  const Mesh small = frontal_square(0, 0, 10, 10, 3);
  buffer.render({}, kCamera, small.positions, small.triangles);
  EXPECT_NEAR(buffer.depth(5, 5), 3, 3e-6);
  EXPECT_EQ(buffer.depth(20, 20), kInf);
}

TEST(DepthBuffer, RejectsBadInput) {
  EXPECT_THROW(DepthBuffer(0, 10), std::invalid_argument);
  EXPECT_THROW(DepthBuffer(10, 0), std::invalid_argument);
  EXPECT_THROW(DepthBuffer(-3, 10), std::invalid_argument);
  EXPECT_THROW(DepthBuffer(1 << 20, 1 << 20), std::invalid_argument);
  const DepthBuffer one(1, 1);
  EXPECT_EQ(one.depth(0, 0), kInf);

  DepthBuffer buffer(kCamera.width, kCamera.height);
  const Mesh square = frontal_square(100, 100, 200, 200, 2);
  std::string m = message_of<std::invalid_argument>(
      [&] { buffer.render({}, intrinsics_from_hfov(640, 480, 60), square.positions, square.triangles); });
  EXPECT_TRUE(contains(m, "640x480") && contains(m, "960x540")) << m;
  PinholeIntrinsics bad = kCamera;
  bad.fx = 0;
  m = message_of<std::invalid_argument>([&] { buffer.render({}, bad, square.positions, square.triangles); });
  EXPECT_TRUE(contains(m, "fx")) << m;
  m = message_of<std::invalid_argument>(
      [&] { buffer.render({}, kCamera, std::span(square.positions).first(11), square.triangles); });
  EXPECT_TRUE(contains(m, "11 floats")) << m;
  m = message_of<std::invalid_argument>(
      [&] { buffer.render({}, kCamera, square.positions, std::span(square.triangles).first(5)); });
  EXPECT_TRUE(contains(m, "5 indices")) << m;
  std::vector<std::uint32_t> triangles = square.triangles;
  triangles[4] = 4;
  m = message_of<std::invalid_argument>([&] { buffer.render({}, kCamera, square.positions, triangles); });
  EXPECT_TRUE(contains(m, "triangle 1 names vertex 4 of 4")) << m;
  std::vector<float> positions = square.positions;
  positions[7] = std::numeric_limits<float>::quiet_NaN();
  m = message_of<std::invalid_argument>([&] { buffer.render({}, kCamera, positions, square.triangles); });
  EXPECT_TRUE(contains(m, "vertex 2 is not finite")) << m;
  EXPECT_EQ(buffer.depth(150, 150), kInf);  // a rejected render leaves the buffer cleared
  EXPECT_FALSE(buffer.visible(unproject(150, 150, 1)));  // and no camera to test points against

  EXPECT_THROW(buffer.depth(-1, 0), std::out_of_range);
  EXPECT_THROW(buffer.depth(0, 540), std::out_of_range);
  EXPECT_THROW(buffer.depth(960, 0), std::out_of_range);
}

}  // namespace
