#include "scene_layouts/visibility.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
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

  // Candidates, in the order tested: the distinct nearest triangles at the 3x3 centres around
  // (u, v) (the pixel holding it and its neighbours inside the image, skipping empty ones, whose
  // triangle entry is stale), then, breadth first, the triangles across their edges whose
  // projection meets the box B = [u - 1, u + 1] x [v - 1, v + 1], up to kMaxCandidates in all.
  const int x = static_cast<int>(u), y = static_cast<int>(v);
  std::array<std::uint32_t, kMaxCandidates> candidates;
  int count = 0;
  // Candidates seen so far, as a set: open addressing in twice as many slots as candidates, so a
  // lookup is a probe or two (a linear search made the flood quadratic in the candidates).
  constexpr std::uint32_t kSlots = 2 * kMaxCandidates;
  static_assert((kSlots & (kSlots - 1)) == 0, "the slot count is a power of two");
  std::array<std::uint32_t, kSlots> seen;
  seen.fill(kNoTriangle);
  // The slot holding `id`, or the empty slot where it would go.
  auto slot_of = [&](std::uint32_t id) {
    std::uint32_t slot = (id * 2654435761u) & (kSlots - 1);
    while (seen[slot] != kNoTriangle && seen[slot] != id) slot = (slot + 1) & (kSlots - 1);
    return slot;
  };
  auto add = [&](std::uint32_t id) {
    if (count >= kMaxCandidates) return;
    const std::uint32_t slot = slot_of(id);
    if (seen[slot] == id) return;
    seen[slot] = id;
    candidates[count++] = id;
  };
  for (int j = std::max(y - 1, 0); j <= std::min(y + 1, height_ - 1); ++j) {
    for (int i = std::max(x - 1, 0); i <= std::min(x + 1, width_ - 1); ++i) {
      const std::size_t pixel = static_cast<std::size_t>(j) * width_ + i;
      if (inverse_depth_[pixel] != 0) add(triangle_[pixel]);
    }
  }
  // Whether triangle t's projection meets B (separating axes: B's two and the triangle's three
  // edge normals); true when a corner lies before the near plane (its projection is not kept),
  // which only lets more triangles in.
  auto meets_box = [&](std::uint32_t t) {
    std::array<const ScreenVertex*, 3> p;
    for (int c = 0; c < 3; ++c) {
      const std::uint32_t i = triangles_[3 * std::size_t{t} + c];
      if (camera_[i].z() < kNearDepth) return true;
      p[c] = &screen_[i];
    }
    if (std::max({p[0]->u, p[1]->u, p[2]->u}) < u - 1 || std::min({p[0]->u, p[1]->u, p[2]->u}) > u + 1 ||
        std::max({p[0]->v, p[1]->v, p[2]->v}) < v - 1 || std::min({p[0]->v, p[1]->v, p[2]->v}) > v + 1)
      return false;
    // Edge a -> b with the third corner c on its positive side (sign of the area): B lies outside
    // when the edge function (b - a) x (q - a), times the sign, is negative at all four corners q of
    // B, that is at the corner maximising it: |du| + |dv| above its value at the centre (u, v).
    const double area = (p[1]->u - p[0]->u) * (p[2]->v - p[0]->v) - (p[2]->u - p[0]->u) * (p[1]->v - p[0]->v);
    const double sign = area < 0 ? -1 : 1;
    for (int e = 0; e < 3; ++e) {
      const ScreenVertex& a = *p[e];
      const ScreenVertex& b = *p[(e + 1) % 3];
      const double du = b.u - a.u, dv = b.v - a.v;
      if (sign * (du * (v - a.v) - dv * (u - a.u)) + std::abs(du) + std::abs(dv) < 0) return false;
    }
    return true;
  };

  // Hidden when the segment from the camera (the origin) to the point crosses a candidate more than
  // `reach` before the point: at s P with 0 < s and (1 - s) |P| > reach.
  const double distance = point.norm();
  const double reach = std::max(kRelativeDepthTolerance * distance, kAbsoluteDepthTolerance);
  for (int c = 0; c < count; ++c) {
    const std::size_t t = 3 * std::size_t{candidates[c]};
    const double s =
        ray_parameter(camera_[triangles_[t]], camera_[triangles_[t + 1]], camera_[triangles_[t + 2]], point);
    if (s > 0 && (1 - s) * distance > reach) {
      // Named by the nearest surface: the one drawn at the point's own pixel when it lies in front
      // of the point (nearly always the ray's first hit), else the candidate just found.
      const std::size_t pixel = static_cast<std::size_t>(y) * width_ + x;
      const bool drawn_in_front = inverse_depth_[pixel] * point.z() > 1 + kRelativeDepthTolerance;
      return {Reason::occluded, drawn_in_front ? triangle_[pixel] : candidates[c]};
    }
    for (int e = 0; e < 3; ++e) {
      const std::uint32_t other = neighbours_[t + e];
      // Known triangles are not tested against the box again (each edge is seen from both sides).
      if (other != kNoTriangle && count < kMaxCandidates && seen[slot_of(other)] != other && meets_box(other)) add(other);
    }
  }
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
  if (!std::ranges::equal(triangles, triangles_)) {
    triangles_.assign(triangles.begin(), triangles.end());
    find_neighbours(positions);
  }

  for (std::size_t t = 0; t < triangles.size(); t += 3) {
    const std::array<std::uint32_t, 3> index{triangles[t], triangles[t + 1], triangles[t + 2]};
    const auto id = static_cast<std::uint32_t>(t / 3);
    int in_front = 0;
    for (const std::uint32_t i : index) in_front += camera_[i].z() >= kNearDepth;
    if (in_front == 3) {
      rasterise(screen_[index[0]], screen_[index[1]], screen_[index[2]], id);
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
  }
}

void DepthBuffer::find_neighbours(std::span<const float> positions) {
  // Corners are joined by position, not index: meshes split vertices along UV and normal seams.
  // same[v] is the first vertex (in xyz order) at v's exact float position.
  const std::size_t vertices = positions.size() / 3;
  std::vector<std::uint32_t> order(vertices), same(vertices);
  for (std::size_t v = 0; v < vertices; ++v) order[v] = static_cast<std::uint32_t>(v);
  auto xyz = [&](std::uint32_t v) { return std::span(positions).subspan(3 * std::size_t{v}, 3); };
  std::ranges::sort(order, [&](std::uint32_t a, std::uint32_t b) {
    return std::ranges::lexicographical_compare(xyz(a), xyz(b));
  });
  for (std::size_t i = 0; i < vertices; ++i)
    same[order[i]] = i > 0 && std::ranges::equal(xyz(order[i]), xyz(order[i - 1])) ? same[order[i - 1]] : order[i];
  std::vector<std::uint32_t> corner(triangles_.size());
  for (std::size_t i = 0; i < triangles_.size(); ++i) corner[i] = same[triangles_[i]];

  // The triangles around each (joined) vertex, as one array sliced by vertex (counting sort):
  // triangle t is listed under each of its corners, between first[v] and first[v + 1].
  const std::size_t count = corner.size() / 3;
  std::vector<std::size_t> first(vertices + 1, 0);
  for (const std::uint32_t v : corner) ++first[v + 1];
  for (std::size_t v = 0; v < vertices; ++v) first[v + 1] += first[v];
  std::vector<std::uint32_t> around(corner.size());
  std::vector<std::size_t> next(first.begin(), first.end() - 1);
  for (std::size_t i = 0; i < corner.size(); ++i) around[next[corner[i]]++] = static_cast<std::uint32_t>(i / 3);
  // Across edge e of t (corners e, e + 1): a triangle other than t around corner e holding corner e + 1.
  neighbours_.assign(corner.size(), kNoTriangle);
  for (std::size_t t = 0; t < count; ++t) {
    for (int e = 0; e < 3; ++e) {
      const std::uint32_t a = corner[3 * t + e], b = corner[3 * t + (e + 1) % 3];
      for (std::size_t i = first[a]; i < first[a + 1]; ++i) {
        const std::uint32_t other = around[i];
        const auto corners = std::span(corner).subspan(3 * std::size_t{other}, 3);
        if (other != t && std::ranges::find(corners, b) != corners.end()) {
          neighbours_[3 * t + e] = other;
          break;
        }
      }
    }
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
