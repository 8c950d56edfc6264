// Occlusion for tracked surface points: a software depth buffer that rasterises meshes seen by one
// pinhole camera (skeleton/camera.h conventions), and the test of whether a point on those meshes
// is visible in it. Trajectory files store the result as `visibs` (mocap_io/trajectory_file.h).
//
// Rasterisation
// -------------
// A world vertex goes to the camera, x_cam = R x_world + t, and a camera point (x, y, z) with
// z >= near projects to (u, v) = (fx x/z + cx, fy y/z + cy). Pixel (i, j) is sampled at its centre
// (i + 0.5, j + 0.5) only; the buffer keeps, per pixel, the nearest camera depth z of the triangles
// covering that centre, +infinity where none does.
//
// Near plane: triangles are clipped in camera space against z = kNearDepth = 1 mm (a fixed depth:
// the scenes are people and props in metres, and 1 mm keeps projected coordinates below about
// 1e3 fx px per metre of x, far inside what the double setup resolves). Clipping
// against z >= near keeps a convex polygon of 3 or 4 corners (drawn as 1 or 2 triangles), each new
// corner where an edge crosses the plane, p = a + (near - z_a) / (z_b - z_a) (b - a), so a triangle
// reaching behind the camera still occludes what its part in front covers.
//
// Coverage: with screen corners p0, p1, p2 and signed doubled area
//   A = (p1 - p0) x (p2 - p0)    (2-D cross product a x b = a.x b.y - a.y b.x),
// the edge function opposite corner i (corners cyclic) is E_i(p) = (p_{i+2} - p_{i+1}) x (p - p_{i+1}),
// affine in p, with E_i(p_i) = A, so lambda_i = E_i / A are the screen barycentric coordinates. A
// centre is covered when sign(A) E_i >= -|p_{i+2} - p_{i+1}| / 1024 for all i: within 1/1024 px of
// the triangle. Both windings are drawn (meshes need not be closed, and both sides occlude); a
// triangle with A = 0 covers nothing. Along a row of the triangle's bounding box each E_i is affine
// in the column n, E_i = e_i + n du_i, so the three tests solve to one run of columns
// [max over du_i > 0 of (limit_i - e_i) / du_i, min over du_i < 0 of the same], computed per row
// in double; the inner loop over that run is float depth arithmetic alone. The 1/1024 px slack
// makes edges shared by two triangles watertight whatever the rounding: the double setup is
// accurate to about 2^-52 times the corners' pixel coordinates, so a centre exactly on a shared
// edge is covered by at least one of the two even for corners 1e9 px away (near-plane clipping
// makes such corners), and a triangle grows by at most 1/1024 px.
//
// Perspective-correct depth: on a plane n . X = d in camera space, a point seen at screen position
// (u, v) is X = z ((u - cx)/fx, (v - cy)/fy, 1), so
//   1/z = (n_x (u - cx)/fx + n_y (v - cy)/fy + n_z) / d,
// which is affine in (u, v) (z itself is not). Hence 1/z interpolates linearly in screen space with
// the screen barycentrics: 1/z(p) = sum_i lambda_i(p) / z_i. The rasteriser sets up the plane
// 1/z(u, v) = a u + b v + c in double per triangle, evaluates it in float per pixel, and clamps it
// to the corners' range [min 1/z_i, max 1/z_i] (the true value on the triangle lies in it; the
// clamp only bounds the error of the slack and of sliver triangles whose plane is ill-conditioned).
// The buffer stores 1/z (0 for +infinity): the nearest surface is the largest 1/z, and clearing is
// a fill with zeros.
//
// Visibility tolerance
// --------------------
// A surface point at (u, v) with camera depth z is tested against the 2x2 pixel centres nearest
// (u, v), c_kl = (i0 + k + 0.5, j0 + l + 0.5) with i0 = floor(u - 0.5), j0 = floor(v - 0.5), k, l in
// {0, 1} (clamped into the image within half a pixel of its border):
//   visible  <=>  z <= (1 + kRelativeDepthTolerance) max_kl D(c_kl),
// D the buffer's depth (+infinity where nothing was drawn, which makes the point visible).
// Why the maximum: the point lies on a triangle of plane P; on P, 1/z is affine in screen space, and
// (u, v) lies in the convex hull of the four centres, so 1/z_P(u, v) >= min_kl 1/z_P(c_kl), that is
// z <= max_kl z_P(c_kl). For a convex mesh seen from outside, every ray that meets P in front of the
// camera enters the mesh at or beyond P (the mesh lies on the inner side of each face plane), so
// D(c_kl) >= z_P(c_kl), or D = +infinity where the ray misses; hence z <= max D: no front point is
// ever hidden by its own surface, however slanted, which sampling a single centre would not give
// (on a slanted face the nearest centre may be up to 0.7 px away, i.e. nearer by
// 0.7 px * z / f * tan(slant)). A nearer occluder that covers all four centres still hides the point.
// The relative tolerance 1e-3 covers what the convexity argument leaves out:
//   - rounding: float 1/z in the buffer and its float evaluation (~1e-7 relative, up to ~1e-4 on
//     grazing triangles whose depth spans 1000:1 across one bounding box);
//   - concave creases, where a neighbouring face comes nearer than P's extension: a face whose depth
//     slope differs from P's by s (metres of depth per metre across, at depth z, focal f px) comes
//     nearer by at most s z / f per pixel, which the tolerance absorbs up to s = 1e-3 f (s = 0.83,
//     about 40 degrees of crease, at the dataset's 960 px wide 60 degree view, f = 831 px).
// The price: a surface less than 0.1% of its depth behind an occluder (3 mm at 3 m) counts as
// visible, below what pixel-resolution annotations resolve anyway.
// Within half a pixel of the image border the block is clamped onto the last row or column of
// centres, so (u, v) lies up to 0.5 px outside its hull and only the relative tolerance remains.
//
// Performance: one 960x540 frame of a 20k-triangle closed mesh covering 15% of the image takes
// about 1.4 ms of CPU time (50% of the image: 2.3 ms), on one core of a shared AMD EPYC, built
// Release with -march=native; most of it is per-triangle and per-row setup, as the triangles
// of such meshes span a few pixels. The buffer reuses its memory from frame to frame.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "skeleton/camera.h"

namespace odyssey::scene {

class DepthBuffer {
 public:
  static constexpr double kNearDepth = 1e-3;               // metres; the clipping plane z = near
  static constexpr double kRelativeDepthTolerance = 1e-3;  // see "Visibility tolerance" above

  // Throws std::invalid_argument when width or height < 1, or the image is too large to index.
  DepthBuffer(int width, int height);

  int width() const { return width_; }
  int height() const { return height_; }

  // Clears the buffer to +infinity and rasterises every triangle (3 vertex indices each into
  // `positions`, world xyz float32, 3 floats a vertex) seen by the camera, keeping the nearest
  // camera depth per pixel centre. Throws std::invalid_argument when the intrinsics' image size is
  // not the buffer's or fx, fy are not positive and finite, when positions is not a multiple of 3
  // long or holds a non-finite value, when triangles is not a multiple of 3 long, or when an index
  // is not a vertex (naming the triangle); the buffer is then cleared.
  void render(const CameraPose& pose, const PinholeIntrinsics& k, std::span<const float> positions,
              std::span<const std::uint32_t> triangles);

  // The nearest camera depth at pixel (x, y), +infinity where nothing was drawn. Throws
  // std::out_of_range outside the image.
  float depth(int x, int y) const;

  // Whether a surface point at pixel (u, v) with camera depth `depth` (PixelProjection's u, v,
  // depth) is visible: (u, v) in [0, width) x [0, height), 0 < depth < infinity, and not behind the
  // buffer by more than the tolerance above.
  bool visible(double u, double v, double depth) const;

 private:
  struct ScreenVertex {
    double u, v, inverse_depth;
  };
  void rasterise(const ScreenVertex& p0, const ScreenVertex& p1, const ScreenVertex& p2);

  int width_, height_;
  std::vector<float> inverse_depth_;  // row-major, y * width + x; 0 where nothing was drawn
  // Per-vertex scratch, reused across frames so render() does not allocate in steady state.
  std::vector<Eigen::Vector3d> camera_;  // camera coordinates
  std::vector<ScreenVertex> screen_;     // projections, meaningful where camera z >= near
};

}  // namespace odyssey::scene
