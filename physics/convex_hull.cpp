#include "physics/convex_hull.h"

#include <Eigen/Eigenvalues>
#include <LinearMath/btConvexHullComputer.h>
#include <cmath>
#include <stdexcept>
#include <string>

namespace odyssey::physics {
namespace {

double principal_thickness(std::span<const Eigen::Vector3d> points) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : points) mean += p;
  mean /= static_cast<double>(points.size());
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (const auto& p : points) covariance += (p - mean) * (p - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance);
  const Eigen::Vector3d axis = solver.eigenvectors().col(0);  // eigenvalues ascend: least variance first
  double low = INFINITY, high = -INFINITY;
  for (const auto& p : points) {
    const double t = axis.dot(p - mean);
    low = std::min(low, t);
    high = std::max(high, t);
  }
  return high - low;
}

void check_points(std::span<const Eigen::Vector3d> points) {
  if (points.size() < 4) throw std::invalid_argument("a convex hull needs at least 4 points, got " + std::to_string(points.size()));
  for (std::size_t i = 0; i < points.size(); ++i)
    if (!points[i].allFinite()) throw std::invalid_argument("hull point " + std::to_string(i) + " is not finite");
}

}  // namespace

ConvexHull convex_hull(std::span<const Eigen::Vector3d> points) {
  check_points(points);
  ConvexHull hull;
  hull.thickness = principal_thickness(points);
  if (!(hull.thickness >= kMinimumHullThickness))
    throw std::invalid_argument("hull has no volume: its " + std::to_string(points.size()) + " points span " +
                                std::to_string(hull.thickness) + " m along their thinnest axis (need at least " +
                                std::to_string(kMinimumHullThickness) + " m; flat or collinear points)");
  btConvexHullComputer computer;
  computer.compute(points.data()->data(), sizeof(Eigen::Vector3d), static_cast<int>(points.size()), 0, 0);
  hull.vertices.reserve(computer.vertices.size());
  // Bullet computes on coordinates quantised to integers; its corners are the input points rounded
  // to about 1e-5 of the extent, so take the input points they came from instead.
  for (int i = 0; i < computer.vertices.size(); ++i) hull.vertices.push_back(points[computer.original_vertex_index[i]]);
  for (int f = 0; f < computer.faces.size(); ++f) {
    const btConvexHullComputer::Edge* first = &computer.edges[computer.faces[f]];
    const int a = first->getSourceVertex();
    const btConvexHullComputer::Edge* edge = first->getNextEdgeOfFace();
    while (edge->getTargetVertex() != a) {
      hull.triangles.push_back({a, edge->getSourceVertex(), edge->getTargetVertex()});
      edge = edge->getNextEdgeOfFace();
    }
  }
  // Mass properties about a reference point inside the hull keep the sums well conditioned.
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  for (const auto& v : hull.vertices) origin += v;
  origin /= static_cast<double>(hull.vertices.size());
  double volume = 0;
  Eigen::Vector3d first_moment = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second_moment = Eigen::Matrix3d::Zero();
  for (const auto& t : hull.triangles) {
    const Eigen::Vector3d a = hull.vertices[t[0]] - origin, b = hull.vertices[t[1]] - origin, c = hull.vertices[t[2]] - origin;
    const double v = a.dot(b.cross(c)) / 6.0;
    const Eigen::Vector3d sum = a + b + c;
    volume += v;
    first_moment += v * sum / 4.0;
    second_moment += v / 20.0 * (a * a.transpose() + b * b.transpose() + c * c.transpose() + sum * sum.transpose());
  }
  // Bullet's face order is not promised outward; a consistently inward hull has negative volume and
  // every moment flips sign with it.
  if (volume < 0) {
    volume = -volume;
    first_moment = -first_moment;
    second_moment = -second_moment;
    for (auto& t : hull.triangles) std::swap(t[1], t[2]);
  }
  if (!(volume > 0)) throw std::invalid_argument("hull has no volume");
  const Eigen::Vector3d offset = first_moment / volume;
  hull.volume = volume;
  hull.centroid = origin + offset;
  const Eigen::Matrix3d central = second_moment - volume * offset * offset.transpose();
  hull.unit_inertia = central.trace() * Eigen::Matrix3d::Identity() - central;
  return hull;
}

}  // namespace odyssey::physics
