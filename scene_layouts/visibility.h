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
// a fill with zeros. Beside it, an ID buffer keeps per pixel the index (in render's `triangles`,
// whatever pieces clipping cut it into) of the triangle that wrote the nearest 1/z; a strictly
// larger 1/z replaces it, so at equal depth the first triangle drawn stays. IDs are read only
// where 1/z > 0, so clearing leaves them alone.
//
// Visibility
// ----------
// A point P (camera coordinates, z > 0, projecting to (u, v) inside the image) is hidden exactly
// when the segment from the camera centre O = 0 to P crosses a triangle before P. Every triangle
// crossing the ray s P at a depth of at least the near plane projects over (u, v) itself, so its
// screen box (the bounding box of the projection of its part before the near plane, grown by
// 1/64 px) holds (u, v). The test casts the ray against exactly those triangles:
//   hidden  <=>  some triangle whose box holds (u, v) meets the ray at s P with s > 0 and
//                (1 - s) |P| > reach,
//   reach = kRelativeDepthTolerance |P| = 1e-4 |P|,
// with s from Moller-Trumbore in double on the kept camera-space vertices, each triangle grown by
// 1e-9 in barycentric units so that a ray through a shared edge or vertex cannot slip between the
// triangles holding it by rounding (see ray_parameter in visibility.cpp). The occluder named is the
// nearest such triangle (smallest s). This is a brute-force ray cast restricted to the triangles
// that can matter: no depth sampled at a pixel centre is compared with the point's, so a front
// point is never hidden by its own surface however slanted, a point beside a silhouette is judged
// by its own ray, and sub-pixel triangles (slivers seen edge on, meshes finer than the pixels,
// small separate objects) hide what they cover.
// Finding the boxes: render() bins every box into square tiles of the image. A box goes to the
// fine grid (kFineTilePixels = 2 px tiles) when it spans at most kMaxTilesPerBox = 16 of them,
// else to the coarse grid (kCoarseTilePixels = 32 px) on the same condition, else to a list of
// large triangles; a point reads the fine and coarse tiles holding it and the large list. Each
// triangle costs at most 16 entries whatever its size, and a point tests the few boxes around it
// (the tiles are as small as the triangles of dense characters, whose many layers of sub-pixel
// triangles made an edge-connected search around the point's pixel cost thousands of tests).
// The boxes are stored as columns and compared 16 at a time without branches; each also keeps its
// triangle's nearest depth z_min, and a triangle with z_min >= P.z (1 - reach / |P|) is not cast
// against (any crossing that counts lies nearer than that), which skips the point's own surface
// and everything behind it.
// Why the reach: the point and the mesh are skinned in float32, so P lies off its own triangle's
// plane by ~6e-8 of its coordinates, which the ray turns into up to that / cos(incidence) along
// it; 1e-4 |P| covers incidence to within 0.03 degree of grazing when the coordinates are of the
// size of |P| (a camera near the scene), and to within a degree when they are 30 times larger.
// The price: an occluder less than the reach in front of the point does not hide it (0.5 mm at
// 5 m, against a pixel footprint of about 8 mm there); surfaces that close are in contact, not
// occluding. The reach is relative only, so a scene scaled as a whole (character, props and
// camera) is judged the same at every scale: a 1 cm character as a 100 m one.
// Known limit: a surface crossing the ray less than kNearDepth from the camera centre (closer than
// the near plane) does not hide the point, as it is not drawn either.
// Points outside the image, behind the camera (z <= 0) or not finite are not visible.
//
// Cost: render() rasterises and bins every triangle once per frame (binning is a counting sort
// over the tiles, two passes); a point costs the boxes of its two tiles and the large list. The
// buffer reuses its memory from frame to frame; classify() is const and may run on many threads.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "skeleton/camera.h"

namespace odyssey::scene {

// Why a point is or is not visible, and what hides it.
struct PointVisibility {
  enum class Reason : std::uint8_t { visible, occluded, outside_image, behind_camera };
  Reason reason = Reason::outside_image;
  std::uint32_t occluder = 0xffffffff;  // occluded: the index of the hiding triangle in render's list

  bool visible() const { return reason == Reason::visible; }
};

class DepthBuffer {
 public:
  static constexpr double kNearDepth = 1e-3;               // metres; the clipping plane z = near
  static constexpr double kRelativeDepthTolerance = 1e-4;  // see "Visibility" above

  // Throws std::invalid_argument when width or height < 1, or the image is too large to index.
  DepthBuffer(int width, int height);

  int width() const { return width_; }
  int height() const { return height_; }

  // Clears the buffer to +infinity and rasterises every triangle (3 vertex indices each into
  // `positions`, world xyz float32, 3 floats a vertex) seen by the camera, keeping the nearest
  // camera depth and the triangle holding it per pixel centre; keeps the intrinsics, a copy of
  // the triangles and the camera-space vertices for visible(), so the spans need not outlive the
  // call. Throws std::invalid_argument when the intrinsics' image size is not the buffer's or fx,
  // fy are not positive and finite, when positions is not a multiple of 3 long or holds a
  // non-finite value, when triangles is not a multiple of 3 long, or when an index is not a vertex
  // (naming the triangle); the buffer is then cleared and visible() false.
  void render(const CameraPose& pose, const PinholeIntrinsics& k, std::span<const float> positions,
              std::span<const std::uint32_t> triangles);

  // The nearest camera depth at pixel (x, y), +infinity where nothing was drawn. Throws
  // std::out_of_range outside the image.
  float depth(int x, int y) const;
  // The triangle (index in the last render's list) drawn nearest at pixel (x, y), or 0xffffffff
  // where nothing was drawn or outside the image.
  std::uint32_t triangle_at(int x, int y) const;
  // The last render's triangles (3 corners each, as render() was given them) and its vertices in
  // camera coordinates: what the triangle IDs of triangle_at() index.
  std::span<const std::uint32_t> triangles() const { return triangles_; }
  std::span<const Eigen::Vector3d> camera_vertices() const { return camera_; }
  // The last render's intrinsics; empty before a successful render().
  const std::optional<PinholeIntrinsics>& intrinsics() const { return intrinsics_; }

  // |cos| of the angle between a triangle of the last render and the ray to its centre (1: seen
  // face on, 0: edge on or degenerate), for flat shading.
  double facing(std::uint32_t triangle) const;

  // Whether a surface point, in camera coordinates (pose.to_camera(world) for the pose of the last
  // render()), is visible: in front of the camera (z > 0), projecting into [0, width) x [0, height)
  // with the last render's intrinsics, and no triangle crossing its ray before it (see
  // "Visibility" above). False before the first render() and after one that threw.
  bool visible(const Eigen::Vector3d& point) const;
  // The same, with the reason: behind_camera for z <= 0, outside_image for a projection outside
  // the image, a non-finite point or before the first render, occluded naming the nearest triangle
  // crossing its ray.
  PointVisibility classify(const Eigen::Vector3d& point) const;

 private:
  struct ScreenVertex {
    double u, v, inverse_depth;
  };
  // A triangle's screen box (see "Visibility" above), in pixels.
  // nearest: at most the camera depth of its nearest point (0 for a triangle cut by the near
  // plane, which is always tested).
  struct BoxedTriangle {
    float u0, v0, u1, v1, nearest;
    std::uint32_t triangle;
  };
  // Boxes as columns, so that a point's scan over them compares 16 at a time; kScanBlock entries of
  // padding (empty boxes) follow the last one, so a block may always be read whole.
  struct BoxColumns {
    std::vector<float> u0, v0, u1, v1, nearest;
    std::vector<std::uint32_t> triangle;
    void resize(std::size_t count);  // count boxes plus the padding
    void set(std::size_t i, const BoxedTriangle& box);
  };
  static constexpr std::size_t kScanBlock = 16;
  // Screen boxes binned by the square tiles they meet, `size` pixels a side: tile (column, row)
  // holds boxes first[cell] .. first[cell + 1] - 1, cell = row * columns + column.
  struct TileGrid {
    int size = 0, columns = 0, rows = 0;
    std::vector<std::size_t> first, next;  // next: the fill position per cell while binning
    BoxColumns boxes;
    // The cell holding (u, v) (clamped to the grid).
    std::size_t cell(double u, double v) const;
  };
  static constexpr int kFineTilePixels = 2, kCoarseTilePixels = 32, kMaxTilesPerBox = 16;
  // Bins boxes_ into grids_ and large_.
  void bin_boxes();
  // Draws one (possibly clipped) piece of triangle `triangle` (its index in render's triangles).
  void rasterise(const ScreenVertex& p0, const ScreenVertex& p1, const ScreenVertex& p2, std::uint32_t triangle);

  int width_, height_;
  std::vector<float> inverse_depth_;     // row-major, y * width + x; 0 where nothing was drawn
  std::vector<std::uint32_t> triangle_;  // the nearest triangle per pixel, meaningful where 1/z > 0
  // The last render's camera and mesh, kept for visible(); reused across frames so render() does
  // not allocate in steady state.
  std::optional<PinholeIntrinsics> intrinsics_;  // empty before a successful render()
  std::vector<std::uint32_t> triangles_;         // a copy of render's triangles
  static constexpr std::uint32_t kNoTriangle = 0xffffffff;
  // The last render's screen boxes: all of them, then binned (fine grid, coarse grid, and the
  // large ones that span more than kMaxTilesPerBox coarse tiles), with the grid each went to.
  std::vector<BoxedTriangle> boxes_;
  std::array<TileGrid, 2> grids_;
  BoxColumns large_;
  std::size_t large_count_ = 0;
  std::vector<std::uint8_t> box_grid_;
  std::vector<std::array<int, 4>> box_tiles_;  // per box, its tile span in its grid: c0, r0, c1, r1
  std::vector<Eigen::Vector3d> camera_;          // vertices in camera coordinates
  std::vector<ScreenVertex> screen_;             // projections, meaningful where camera z >= near
};

}  // namespace odyssey::scene
