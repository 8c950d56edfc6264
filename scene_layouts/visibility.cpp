#include "scene_layouts/visibility.h"

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
}

float DepthBuffer::depth(int x, int y) const {
  if (x < 0 || x >= width_ || y < 0 || y >= height_)
    throw std::out_of_range("depth buffer: pixel (" + std::to_string(x) + ", " + std::to_string(y) + ") is outside the " +
                            std::to_string(width_) + "x" + std::to_string(height_) + " image");
  // 1/0 = +infinity in IEEE arithmetic: an empty pixel reads as infinitely far.
  return 1.0f / inverse_depth_[static_cast<std::size_t>(y) * width_ + x];
}

bool DepthBuffer::visible(double u, double v, double depth) const {
  // Written so that NaN fails every test.
  if (!(depth > 0 && depth < std::numeric_limits<double>::infinity())) return false;
  if (!(u >= 0 && u < width_ && v >= 0 && v < height_)) return false;
  const int i0 = static_cast<int>(std::floor(u - 0.5)), j0 = static_cast<int>(std::floor(v - 0.5));
  // The largest depth over the 2x2 centres is the smallest stored 1/z (0 where nothing was drawn).
  float smallest = std::numeric_limits<float>::infinity();
  for (const int j : {j0, j0 + 1}) {
    const std::size_t row = static_cast<std::size_t>(std::clamp(j, 0, height_ - 1)) * width_;
    for (const int i : {i0, i0 + 1}) smallest = std::min(smallest, inverse_depth_[row + std::clamp(i, 0, width_ - 1)]);
  }
  // z <= (1 + tol) / (1/D), multiplied out so that an empty centre (1/D = 0) makes it visible.
  return depth * smallest <= 1 + kRelativeDepthTolerance;
}

void DepthBuffer::render(const CameraPose& pose, const PinholeIntrinsics& k, std::span<const float> positions,
                         std::span<const std::uint32_t> triangles) {
  std::fill(inverse_depth_.begin(), inverse_depth_.end(), 0.0f);
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

  for (std::size_t t = 0; t < triangles.size(); t += 3) {
    const std::array<std::uint32_t, 3> index{triangles[t], triangles[t + 1], triangles[t + 2]};
    int in_front = 0;
    for (const std::uint32_t i : index) in_front += camera_[i].z() >= kNearDepth;
    if (in_front == 3) {
      rasterise(screen_[index[0]], screen_[index[1]], screen_[index[2]]);
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
    for (int c = 2; c < corners; ++c) rasterise(polygon[0], polygon[c - 1], polygon[c]);
  }
}

void DepthBuffer::rasterise(const ScreenVertex& p0, const ScreenVertex& p1, const ScreenVertex& p2) {
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
    // Only the depth is left for the inner loop: float, branch-free, vectorised.
    const float iz_start = static_cast<float>(iz0 + r * iz_dv);
    float* row = inverse_depth_.data() + static_cast<std::size_t>(y0 + r) * width_ + x0;
    for (int n = first; n <= last; ++n) {
      const float depth = std::clamp(iz_start + static_cast<float>(n) * iz_step, iz_low, iz_high);
      row[n] = std::max(row[n], depth);
    }
  }
}

}  // namespace odyssey::scene
