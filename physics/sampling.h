// Seeded draws for physics scenes: random kicks and non-overlapping placements on the ground.
//
// Portability: std::mt19937_64 is bit-exact by the standard, but the standard distributions are
// not (each library maps engine output its own way). So draws here map the engine's 64-bit output
// to [0, 1) by hand, u = (x >> 11) 2^-53, and use only +, *, / and sqrt on it (exactly rounded by
// IEEE 754): the same seed gives the same numbers with every compiler and library. Each prop draws
// from its own engine seeded by (seed, prop), so adding a prop never moves another prop's draws.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <random>
#include <span>
#include <vector>

#include "physics/rigid_scene.h"

namespace odyssey::physics {

class PortableUniform {
 public:
  PortableUniform(std::uint64_t seed, std::uint64_t stream);
  double next() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }  // [0, 1)
  double between(double low, double high) { return low + (high - low) * next(); }

 private:
  std::mt19937_64 engine_;
};

// Kicks as a process per prop over [0, duration): the count is floor(rate duration + u) (its mean
// is rate duration), the times uniform and sorted. Each kick changes the prop's velocity by
// |dv| in [min_speed_change, max_speed_change] (impulse = mass dv), in a direction whose horizontal
// heading is uniform and whose upward component (of the unit direction) is uniform in
// [0, max_upward]. It acts at a point uniform in the ball of radius lever_arm about the prop's
// origin, so a non-zero lever arm also spins the prop.
struct ImpulseSampling {
  std::uint64_t seed = 0;
  double rate = 0.1;              // kicks per prop per second, >= 0
  double min_speed_change = 0.5;  // m/s
  double max_speed_change = 2.0;  // m/s
  double max_upward = 0.5;        // [0, 1]; 0: horizontal kicks only
  double lever_arm = 0;           // m
};

// Sorted by time, then prop. Throws std::invalid_argument naming a bad parameter or mass.
std::vector<Impulse> sample_impulses(const ImpulseSampling& sampling, std::span<const double> prop_masses, double duration);

// Placing props on the ground (z = 0 plane, positions in x y). Each prop is a disc of its footprint
// radius; discs must not overlap (plus `gap`). The first `on_paths` props go on the polylines in
// `paths` (prop i on path i mod paths.size(), uniformly by arc length; they may lie outside the
// region), so walking actors meet them; the rest go inside the region with their whole disc. No
// disc may overlap a keep-out disc (where an actor stands at the first frame, a table's legs).
struct KeepOut {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double radius = 0;  // m, >= 0
};

struct ScatterRequest {
  std::uint64_t seed = 0;
  std::vector<double> footprint_radii;  // m, > 0
  Eigen::Vector2d region_min = Eigen::Vector2d::Zero();
  Eigen::Vector2d region_max = Eigen::Vector2d::Zero();
  std::vector<std::vector<Eigen::Vector2d>> paths;  // each at least 2 points
  int on_paths = 0;
  std::vector<KeepOut> keep_out;
  double gap = 0;          // m, extra clearance between discs
  int max_attempts = 1000;  // draws per prop before giving up
};

struct ScatterPlacement {
  Eigen::Vector2d position = Eigen::Vector2d::Zero();
  double yaw = 0;  // radians in [0, 2 pi), about z
  int path = -1;   // the path it was put on, or -1
};

// Throws std::invalid_argument when the request is malformed, when the discs' total area exceeds
// what the densest packing (pi / sqrt(12) of the region) could hold, or when a prop finds no free
// spot after max_attempts draws (naming the prop, its radius and how many were placed).
std::vector<ScatterPlacement> scatter_props(const ScatterRequest& request);

}  // namespace odyssey::physics
