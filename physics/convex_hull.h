// Convex hulls of point sets and the mass properties of the solids they bound.
//
// The hull itself comes from Bullet (btConvexHullComputer, exact integer arithmetic), so this
// module never writes its own hull algorithm. Mass properties of a closed, outward-oriented
// triangulated surface follow from the divergence theorem: with o any reference point, each
// triangle (a, b, c) spans a tetrahedron (o, a, b, c) of signed volume V_t = det[a-o, b-o, c-o]/6,
// whose second moment about o is C_t = V_t/20 (sum_i p_i p_i^T + (sum_i p_i)(sum_i p_i)^T) with
// p = (o, a, b, c) - o. Summing over triangles gives the volume V, the centroid c = sum V_t m_t
// (m_t the tetrahedron's mean vertex) / V, and the covariance C; the inertia tensor of unit
// density about c is I = trace(C') Id - C', with C' = C - V (c - o)(c - o)^T.
#pragma once

#include <Eigen/Core>
#include <array>
#include <span>
#include <vector>

namespace odyssey::physics {

// The thinnest a point set may be to bound a solid: its extent along its principal axis of least
// variance. Flatter sets (a plane of points, a line) have no volume to give a mass or an inertia.
inline constexpr double kMinimumHullThickness = 1e-3;

struct ConvexHull {
  std::vector<Eigen::Vector3d> vertices;      // the hull's corners: input points, bit for bit
  std::vector<std::array<int, 3>> triangles;  // faces fanned into triangles, counter-clockwise seen from outside
  double volume = 0;                          // m^3
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  Eigen::Matrix3d unit_inertia = Eigen::Matrix3d::Zero();  // about the centroid, density 1 (kg m^2 per kg/m^3)
  double thickness = 0;  // extent along the principal axis of least variance, m
};

// The hull of `points`. Throws std::invalid_argument when there are fewer than 4 points, a
// coordinate is not finite, or the set is thinner than kMinimumHullThickness (saying how thin).
ConvexHull convex_hull(std::span<const Eigen::Vector3d> points);

}  // namespace odyssey::physics
