#include "scene_layouts/visibility.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

namespace odyssey::scene {
namespace {

// Coverage slack, in pixels of distance from an edge (see the header: it keeps shared edges
// watertight under rounding).
constexpr double kEdgeSlackPixels = 1.0 / 1024;

// Growth of triangles in the ray test, in barycentric units (see ray_parameter).
constexpr double kBarycentricSlack = 1e-9;

// The grid's slack around each triangle's screen box, in pixels: more than the float rounding of
// the box's coordinates (at most 2^-24 of 2^24 px), so that no point on a triangle's projection
// falls outside its box; a larger box only costs a ray test.
constexpr double kBoxSlackPixels = 1.0 / 64;

// Moller-Trumbore for the ray s P (s real) from the origin through P and the triangle (a, b, c):
// solving a + beta (b - a) + gamma (c - a) = s P by Cramer's rule with e1 = b - a, e2 = c - a,
// w = -a gives det = e1 . (P x e2), beta = w . (P x e2) / det, gamma = P . (w x e1) / det and
// s = e2 . (w x e1) / det. Returns s where the ray meets the closed triangle grown by
// kBarycentricSlack (beta, gamma >= -slack, beta + gamma <= 1 + slack), NaN where it misses it or
// lies in its plane (det = 0: an edge-on triangle covers no area). The slack makes shared edges
// watertight: a ray through an edge (or a vertex) would otherwise miss every triangle holding it
// about half the time, by rounding of order 1e-16; 1e-9 of a triangle (a nanometre on a metre-sized
// one) hides nothing that the reach does not already let through.
double ray_parameter(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                     const Eigen::Vector3d& point) {
  constexpr double kMiss = std::numeric_limits<double>::quiet_NaN();
  const Eigen::Vector3d e1 = b - a, e2 = c - a, w = -a;
  const Eigen::Vector3d p = point.cross(e2);
  const double det = e1.dot(p);
  if (det == 0) return kMiss;
  const double beta = w.dot(p) / det;
  if (!(beta >= -kBarycentricSlack && beta <= 1 + kBarycentricSlack)) return kMiss;
  const Eigen::Vector3d q = w.cross(e1);
  const double gamma = point.dot(q) / det;
  if (!(gamma >= -kBarycentricSlack && beta + gamma <= 1 + kBarycentricSlack)) return kMiss;
  return e2.dot(q) / det;
}

}  // namespace

DepthBuffer::DepthBuffer(int width, int height) : width_(width), height_(height) {
  if (width < 1 || height < 1)
    throw std::invalid_argument("depth buffer: size must be at least 1x1 pixels, got " + std::to_string(width) + "x" +
                                std::to_string(height));
  // Pixel indices are int; the float column counter of the inner loop is exact below 2^24.
  if (width >= (1 << 24) || static_cast<long long>(width) * height > std::numeric_limits<int>::max())
    throw std::invalid_argument("depth buffer: " + std::to_string(width) + "x" + std::to_string(height) +
                                " pixels are too many");
  inverse_depth_.assign(static_cast<std::size_t>(width) * height, 0.0f);
  triangle_.resize(inverse_depth_.size());
}

float DepthBuffer::depth(int x, int y) const {
  if (x < 0 || x >= width_ || y < 0 || y >= height_)
    throw std::out_of_range("depth buffer: pixel (" + std::to_string(x) + ", " + std::to_string(y) + ") is outside the " +
                            std::to_string(width_) + "x" + std::to_string(height_) + " image");
  // 1/0 = +infinity in IEEE arithmetic: an empty pixel reads as infinitely far.
  return 1.0f / inverse_depth_[static_cast<std::size_t>(y) * width_ + x];
}

std::uint32_t DepthBuffer::triangle_at(int x, int y) const {
  if (x < 0 || x >= width_ || y < 0 || y >= height_) return kNoTriangle;
  const std::size_t pixel = static_cast<std::size_t>(y) * width_ + x;
  return inverse_depth_[pixel] > 0 ? triangle_[pixel] : kNoTriangle;
}

double DepthBuffer::facing(std::uint32_t triangle) const {
  if (std::size_t{triangle} * 3 + 2 >= triangles_.size()) return 0;
  const Eigen::Vector3d& a = camera_[triangles_[3 * std::size_t{triangle}]];
  const Eigen::Vector3d& b = camera_[triangles_[3 * std::size_t{triangle} + 1]];
  const Eigen::Vector3d& c = camera_[triangles_[3 * std::size_t{triangle} + 2]];
  const Eigen::Vector3d normal = (b - a).cross(c - a);
  const Eigen::Vector3d view = (a + b + c) / 3;
  const double scale = normal.norm() * view.norm();
  return scale > 0 ? std::abs(normal.dot(view)) / scale : 0;
}

bool DepthBuffer::visible(const Eigen::Vector3d& point) const { return classify(point).visible(); }

PointVisibility DepthBuffer::classify(const Eigen::Vector3d& point) const {
  using Reason = PointVisibility::Reason;
  if (!intrinsics_) return {Reason::outside_image, kNoTriangle};
  const PinholeIntrinsics& k = *intrinsics_;
  // Written so that NaN fails every test.
  if (!point.allFinite()) return {Reason::outside_image, kNoTriangle};
  if (!(point.z() > 0)) return {Reason::behind_camera, kNoTriangle};
  const double u = k.fx * point.x() / point.z() + k.cx, v = k.fy * point.y() / point.z() + k.cy;
  if (!(u >= 0 && u < width_ && v >= 0 && v < height_)) return {Reason::outside_image, kNoTriangle};

  // Hidden when the segment from the camera (the origin) to the point crosses a triangle more than
  // `reach` before the point: at s P with 0 < s and (1 - s) |P| > reach. Every such triangle
  // projects over (u, v), so only the triangles whose screen box holds (u, v) are tested: those
  // binned in the fine and the coarse tile holding it, and the large ones. The occluder named is
  // the nearest (smallest s).
  const double distance = point.norm();
  const double reach = kRelativeDepthTolerance * distance;
  double nearest = std::numeric_limits<double>::infinity();
  std::uint32_t occluder = kNoTriangle;
  const float uf = static_cast<float>(u), vf = static_cast<float>(v);  // within the boxes' slack of u, v
  // A triangle crossing the ray at s P with (1 - s) |P| > reach does so at a depth below
  // P.z (1 - reach / |P|), so one whose nearest point lies at or beyond that is not tested.
  // Rounded up (float's relative rounding error is 2^-24), so that no triangle that counts is skipped.
  const float beyond = static_cast<float>(point.z() * (1 - reach / distance)) * (1 + 0x1p-20f);
  // Boxes first .. last - 1 of `boxes`, kScanBlock at a time: the four comparisons of a block are
  // branch-free (vectorised), and a block with no box holding the point costs no more.
  auto scan = [&](const BoxColumns& boxes, std::size_t first, std::size_t last) {
    for (std::size_t block = first; block < last; block += kScanBlock) {
      std::array<std::uint8_t, kScanBlock> holds;
      for (std::size_t j = 0; j < kScanBlock; ++j) {
        const std::size_t i = block + j;
        holds[j] = (uf >= boxes.u0[i]) & (uf <= boxes.u1[i]) & (vf >= boxes.v0[i]) & (vf <= boxes.v1[i]) &
                   (boxes.nearest[i] < beyond);
      }
      std::uint64_t any[2];
      static_assert(sizeof any == kScanBlock, "a block's flags are read as two 64-bit words");
      std::memcpy(any, holds.data(), sizeof any);
      if ((any[0] | any[1]) == 0) continue;
      for (std::size_t j = 0; j < std::min(kScanBlock, last - block); ++j) {
        if (!holds[j]) continue;
        const std::uint32_t id = boxes.triangle[block + j];
        const std::size_t t = 3 * std::size_t{id};
        const double s =
            ray_parameter(camera_[triangles_[t]], camera_[triangles_[t + 1]], camera_[triangles_[t + 2]], point);
        if (s > 0 && (1 - s) * distance > reach && s < nearest) {
          nearest = s;
          occluder = id;
        }
      }
    }
  };
  for (const TileGrid& grid : grids_) {
    if (grid.first.empty()) continue;
    const std::size_t cell = grid.cell(u, v);
    scan(grid.boxes, grid.first[cell], grid.first[cell + 1]);
  }
  scan(large_, 0, large_count_);
  if (occluder != kNoTriangle) return {Reason::occluded, occluder};
  return {Reason::visible, kNoTriangle};
}

void DepthBuffer::render(const CameraPose& pose, const PinholeIntrinsics& k, std::span<const float> positions,
                         std::span<const std::uint32_t> triangles) {
  std::fill(inverse_depth_.begin(), inverse_depth_.end(), 0.0f);
  intrinsics_.reset();
  if (k.width != width_ || k.height != height_)
    throw std::invalid_argument("depth buffer: intrinsics are for a " + std::to_string(k.width) + "x" +
                                std::to_string(k.height) + " image, the buffer is " + std::to_string(width_) + "x" +
                                std::to_string(height_));
  if (!(k.fx > 0 && k.fy > 0 && std::isfinite(k.fx) && std::isfinite(k.fy) && std::isfinite(k.cx) && std::isfinite(k.cy)))
    throw std::invalid_argument("depth buffer: intrinsics fx, fy must be positive and finite and cx, cy finite");
  if (positions.size() % 3 != 0)
    throw std::invalid_argument("depth buffer: positions hold " + std::to_string(positions.size()) +
                                " floats, not a multiple of 3 (x, y, z a vertex)");
  if (triangles.size() % 3 != 0)
    throw std::invalid_argument("depth buffer: triangles hold " + std::to_string(triangles.size()) +
                                " indices, not a multiple of 3");
  const std::size_t vertices = positions.size() / 3;
  for (std::size_t i = 0; i < triangles.size(); ++i) {
    if (triangles[i] >= vertices)
      throw std::invalid_argument("depth buffer: triangle " + std::to_string(i / 3) + " names vertex " +
                                  std::to_string(triangles[i]) + " of " + std::to_string(vertices));
  }

  auto project = [&](const Eigen::Vector3d& c) {
    return ScreenVertex{k.fx * c.x() / c.z() + k.cx, k.fy * c.y() / c.z() + k.cy, 1 / c.z()};
  };
  camera_.resize(vertices);
  screen_.resize(vertices);
  for (std::size_t i = 0; i < vertices; ++i) {
    const Eigen::Vector3d world(positions[3 * i], positions[3 * i + 1], positions[3 * i + 2]);
    if (!world.allFinite())
      throw std::invalid_argument("depth buffer: vertex " + std::to_string(i) + " is not finite");
    const Eigen::Vector3d c = pose.to_camera(world);
    camera_[i] = c;
    if (c.z() >= kNearDepth) screen_[i] = project(c);
  }
  // Every input is valid from here on: keep the camera and the mesh for visible().
  intrinsics_ = k;
  if (!std::ranges::equal(triangles, triangles_)) triangles_.assign(triangles.begin(), triangles.end());
  boxes_.clear();
  // The screen box of the part of triangle `id` before the near plane (corners p), grown by the
  // slack and clamped to just around the image, kept when it meets the image.
  auto keep_box = [&](std::span<const ScreenVertex> p, std::uint32_t id, bool clipped) {
    double u0 = p[0].u, u1 = p[0].u, v0 = p[0].v, v1 = p[0].v, inverse_depth = p[0].inverse_depth;
    for (const ScreenVertex& q : p.subspan(1)) {
      u0 = std::min(u0, q.u), u1 = std::max(u1, q.u), v0 = std::min(v0, q.v), v1 = std::max(v1, q.v);
      inverse_depth = std::max(inverse_depth, q.inverse_depth);
    }
    // Rounded towards 0, so that it never exceeds the true nearest depth.
    const float nearest = clipped ? 0.0f : static_cast<float>(1 / inverse_depth) * (1 - 0x1p-20f);
    u0 -= kBoxSlackPixels, v0 -= kBoxSlackPixels, u1 += kBoxSlackPixels, v1 += kBoxSlackPixels;
    if (!(u1 >= 0 && v1 >= 0 && u0 <= width_ && v0 <= height_)) return;  // also drops NaN
    const auto clamp = [](double x, int size) { return static_cast<float>(std::clamp(x, -1.0, size + 1.0)); };
    boxes_.push_back({clamp(u0, width_), clamp(v0, height_), clamp(u1, width_), clamp(v1, height_), nearest, id});
  };

  for (std::size_t t = 0; t < triangles.size(); t += 3) {
    const std::array<std::uint32_t, 3> index{triangles[t], triangles[t + 1], triangles[t + 2]};
    const auto id = static_cast<std::uint32_t>(t / 3);
    int in_front = 0;
    for (const std::uint32_t i : index) in_front += camera_[i].z() >= kNearDepth;
    if (in_front == 3) {
      const std::array<ScreenVertex, 3> corners{screen_[index[0]], screen_[index[1]], screen_[index[2]]};
      rasterise(corners[0], corners[1], corners[2], id);
      keep_box(corners, id, false);
      continue;
    }
    if (in_front == 0) continue;
    // Sutherland-Hodgman against z >= near: walk the edges a -> b, keep a when in front, and add
    // the crossing point when the edge crosses the plane. 1 corner in front gives a triangle, 2 a
    // quadrilateral, drawn as a fan.
    std::array<ScreenVertex, 4> polygon;
    int corners = 0;
    for (int e = 0; e < 3; ++e) {
      const Eigen::Vector3d& a = camera_[index[e]];
      const Eigen::Vector3d& b = camera_[index[(e + 1) % 3]];
      const bool a_in = a.z() >= kNearDepth, b_in = b.z() >= kNearDepth;
      if (a_in) polygon[corners++] = screen_[index[e]];
      if (a_in != b_in) {
        Eigen::Vector3d crossing = a + (kNearDepth - a.z()) / (b.z() - a.z()) * (b - a);
        crossing.z() = kNearDepth;  // exactly on the plane, whatever the rounding of the line above
        polygon[corners++] = project(crossing);
      }
    }
    for (int c = 2; c < corners; ++c) rasterise(polygon[0], polygon[c - 1], polygon[c], id);
    keep_box(std::span(polygon).first(corners), id, true);
  }
  bin_boxes();
}

std::size_t DepthBuffer::TileGrid::cell(double u, double v) const {
  const int column = std::clamp(static_cast<int>(u / size), 0, columns - 1);
  const int row = std::clamp(static_cast<int>(v / size), 0, rows - 1);
  return static_cast<std::size_t>(row) * columns + column;
}

void DepthBuffer::BoxColumns::resize(std::size_t count) {
  // Padding: boxes that hold no point (u0 > u1).
  for (auto* column : {&u0, &v0}) column->assign(count + kScanBlock, 1.0f);
  for (auto* column : {&u1, &v1}) column->assign(count + kScanBlock, 0.0f);
  nearest.assign(count + kScanBlock, std::numeric_limits<float>::infinity());
  triangle.assign(count + kScanBlock, kNoTriangle);
}

void DepthBuffer::BoxColumns::set(std::size_t i, const BoxedTriangle& box) {
  u0[i] = box.u0, v0[i] = box.v0, u1[i] = box.u1, v1[i] = box.v1, nearest[i] = box.nearest;
  triangle[i] = box.triangle;
}

void DepthBuffer::bin_boxes() {
  // Each box goes to the first grid where it spans at most kMaxTilesPerBox tiles, else to the large
  // list: at most kMaxTilesPerBox entries a triangle, whatever its size.
  constexpr std::array<int, 2> kTileSizes{kFineTilePixels, kCoarseTilePixels};
  for (std::size_t g = 0; g < grids_.size(); ++g) {
    TileGrid& grid = grids_[g];
    grid.size = kTileSizes[g];
    grid.columns = (width_ + grid.size - 1) / grid.size;
    grid.rows = (height_ + grid.size - 1) / grid.size;
    grid.first.assign(static_cast<std::size_t>(grid.columns) * grid.rows + 1, 0);
  }
  box_grid_.resize(boxes_.size());
  box_tiles_.resize(boxes_.size());
  // The tile span of a box in a grid, clamped to it.
  auto span_of = [](const TileGrid& grid, const BoxedTriangle& box) {
    const auto index = [&](float x, int count) { return std::clamp(static_cast<int>(std::floor(x / grid.size)), 0, count - 1); };
    return std::array<int, 4>{index(box.u0, grid.columns), index(box.v0, grid.rows), index(box.u1, grid.columns),
                              index(box.v1, grid.rows)};
  };
  // Counting sort: count per tile, turn counts into starts, then place.
  for (std::size_t b = 0; b < boxes_.size(); ++b) {
    box_grid_[b] = static_cast<std::uint8_t>(grids_.size());
    for (std::size_t g = 0; g < grids_.size(); ++g) {
      const auto [c0, r0, c1, r1] = span_of(grids_[g], boxes_[b]);
      if (static_cast<long long>(c1 - c0 + 1) * (r1 - r0 + 1) > kMaxTilesPerBox) continue;
      box_grid_[b] = static_cast<std::uint8_t>(g);
      box_tiles_[b] = {c0, r0, c1, r1};
      for (int r = r0; r <= r1; ++r)
        for (int c = c0; c <= c1; ++c) ++grids_[g].first[static_cast<std::size_t>(r) * grids_[g].columns + c + 1];
      break;
    }
  }
  for (TileGrid& grid : grids_) {
    for (std::size_t cell = 1; cell < grid.first.size(); ++cell) grid.first[cell] += grid.first[cell - 1];
    grid.boxes.resize(grid.first.back());
    grid.next.assign(grid.first.begin(), grid.first.end() - 1);
  }
  large_count_ = static_cast<std::size_t>(std::ranges::count(box_grid_, static_cast<std::uint8_t>(grids_.size())));
  large_.resize(large_count_);
  std::size_t large = 0;
  for (std::size_t b = 0; b < boxes_.size(); ++b) {
    if (box_grid_[b] == grids_.size()) {
      large_.set(large++, boxes_[b]);
      continue;
    }
    TileGrid& grid = grids_[box_grid_[b]];
    const auto [c0, r0, c1, r1] = box_tiles_[b];
    for (int r = r0; r <= r1; ++r)
      for (int c = c0; c <= c1; ++c) grid.boxes.set(grid.next[static_cast<std::size_t>(r) * grid.columns + c]++, boxes_[b]);
  }
}

void DepthBuffer::rasterise(const ScreenVertex& p0, const ScreenVertex& p1, const ScreenVertex& p2,
                            std::uint32_t triangle) {
  const std::array<const ScreenVertex*, 3> p{&p0, &p1, &p2};
  const double area = (p1.u - p0.u) * (p2.v - p0.v) - (p2.u - p0.u) * (p1.v - p0.v);
  if (area == 0 || !std::isfinite(area)) return;
  const double sign = area > 0 ? 1 : -1;

  // Pixels whose centre i + 0.5 lies within the slack of the bounding box, clamped to the image in
  // double before converting (projected corners near the near plane may lie far outside it).
  auto range = [&](double low, double high, int size, int& first, int& last) {
    first = static_cast<int>(std::clamp(std::ceil(low - 0.5 - kEdgeSlackPixels), 0.0, double(size)));
    last = static_cast<int>(std::clamp(std::floor(high - 0.5 + kEdgeSlackPixels), -1.0, double(size - 1)));
    return first <= last;
  };
  int x0, x1, y0, y1;
  if (!range(std::min({p0.u, p1.u, p2.u}), std::max({p0.u, p1.u, p2.u}), width_, x0, x1) ||
      !range(std::min({p0.v, p1.v, p2.v}), std::max({p0.v, p1.v, p2.v}), height_, y0, y1))
    return;

  // Edge i (opposite corner i) from a = p[i+1] to b = p[i+2], oriented so that the inside is
  // positive: E_i(u, v) = sign ((b - a) x ((u, v) - a)) = du_i (u - a.u) + dv_i (v - a.v) with
  // du_i = -sign (b.v - a.v), dv_i = sign (b.u - a.u); covered when E_i >= -slack |b - a|.
  // 1/z(u, v) = sum_i E_i(u, v) / (|area| z_i) is affine too, with gradient
  // sum_i (du_i, dv_i) / (|area| z_i). Both are set up in double at the first centre of the box,
  // (u0, v0) = (x0 + 0.5, y0 + 0.5).
  const double inverse_area = 1 / std::abs(area);
  const double u0 = x0 + 0.5, v0 = y0 + 0.5;
  std::array<double, 3> e0, du, dv, inverse_du, limit;
  double iz0 = 0, iz_du = 0, iz_dv = 0;
  for (int i = 0; i < 3; ++i) {
    const ScreenVertex& a = *p[(i + 1) % 3];
    const ScreenVertex& b = *p[(i + 2) % 3];
    const double edge_u = b.u - a.u, edge_v = b.v - a.v;
    const double weight = p[i]->inverse_depth * inverse_area;
    e0[i] = sign * (edge_u * (v0 - a.v) - edge_v * (u0 - a.u));
    du[i] = -sign * edge_v;
    dv[i] = sign * edge_u;
    inverse_du[i] = 1 / du[i];  // +-infinity for a horizontal edge, which is not used below
    limit[i] = -kEdgeSlackPixels * std::sqrt(edge_u * edge_u + edge_v * edge_v);
    iz0 += e0[i] * weight;
    iz_du += du[i] * weight;
    iz_dv += dv[i] * weight;
  }
  const float iz_low = static_cast<float>(std::min({p0.inverse_depth, p1.inverse_depth, p2.inverse_depth}));
  const float iz_high = static_cast<float>(std::max({p0.inverse_depth, p1.inverse_depth, p2.inverse_depth}));
  const float iz_step = static_cast<float>(iz_du);
  const double last_column = x1 - x0;

  for (int r = 0; r <= y1 - y0; ++r) {
    // The covered run of this row, from the edge functions in double: along the row,
    // E_i(u0 + n, v) = e_i + n du_i >= limit_i holds for n >= (limit_i - e_i) / du_i when du_i > 0,
    // for n <= (limit_i - e_i) / du_i when du_i < 0, and for all n or none when du_i = 0. The
    // bounds are clamped to the box before becoming integers (they may be huge).
    double low = 0, high = last_column;
    for (int i = 0; i < 3; ++i) {
      const double e = e0[i] + r * dv[i];
      if (du[i] > 0)
        low = std::max(low, (limit[i] - e) * inverse_du[i]);
      else if (du[i] < 0)
        high = std::min(high, (limit[i] - e) * inverse_du[i]);
      else if (e < limit[i])
        high = -1;
    }
    if (!(low <= high)) continue;
    const int first = static_cast<int>(std::ceil(low)), last = static_cast<int>(std::floor(high));
    // Only the depth test is left for the inner loop: float, branch-free (both stores are
    // unconditional selects), vectorised. Strictly nearer wins: at equal depth the first drawn stays.
    const float iz_start = static_cast<float>(iz0 + r * iz_dv);
    const std::size_t row_start = static_cast<std::size_t>(y0 + r) * width_ + x0;
    float* row = inverse_depth_.data() + row_start;
    std::uint32_t* ids = triangle_.data() + row_start;
    for (int n = first; n <= last; ++n) {
      const float depth = std::clamp(iz_start + static_cast<float>(n) * iz_step, iz_low, iz_high);
      const bool nearer = depth > row[n];
      row[n] = nearer ? depth : row[n];
      ids[n] = nearer ? triangle : ids[n];
    }
  }
}

}  // namespace odyssey::scene
