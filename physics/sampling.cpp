#include "physics/sampling.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>
#include <string>

namespace odyssey::physics {
namespace {

std::string number(double x) {
  char text[32];
  std::snprintf(text, sizeof text, "%.9g", x);
  return text;
}

// A unit vector uniform on the circle, by rejection from the square (no trigonometry).
Eigen::Vector2d unit_heading(PortableUniform& uniform) {
  for (;;) {
    const Eigen::Vector2d v(uniform.between(-1, 1), uniform.between(-1, 1));
    const double r2 = v.squaredNorm();
    if (r2 > 1e-4 && r2 <= 1) return v / std::sqrt(r2);
  }
}

Eigen::Vector3d in_ball(PortableUniform& uniform, double radius) {
  for (;;) {
    const Eigen::Vector3d v(uniform.between(-1, 1), uniform.between(-1, 1), uniform.between(-1, 1));
    if (v.squaredNorm() <= 1) return radius * v;
  }
}

}  // namespace

PortableUniform::PortableUniform(std::uint64_t seed, std::uint64_t stream) {
  // seed_seq's mixing is specified by the standard, so the engine state is portable too.
  std::seed_seq sequence{static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(seed >> 32),
                         static_cast<std::uint32_t>(stream), static_cast<std::uint32_t>(stream >> 32)};
  engine_.seed(sequence);
}

std::vector<Impulse> sample_impulses(const ImpulseSampling& sampling, std::span<const double> prop_masses, double duration) {
  const auto bad = [](const std::string& what) { return std::invalid_argument("impulse sampling: " + what); };
  if (!(std::isfinite(duration) && duration >= 0)) throw bad("duration must be finite and >= 0 s, got " + number(duration));
  if (!(std::isfinite(sampling.rate) && sampling.rate >= 0)) throw bad("rate must be finite and >= 0, got " + number(sampling.rate));
  if (!(sampling.min_speed_change >= 0 && sampling.max_speed_change >= sampling.min_speed_change && std::isfinite(sampling.max_speed_change)))
    throw bad("speed change range [" + number(sampling.min_speed_change) + ", " + number(sampling.max_speed_change) +
              "] m/s must be finite with 0 <= min <= max");
  if (!(sampling.max_upward >= 0 && sampling.max_upward <= 1)) throw bad("max_upward must be in [0, 1], got " + number(sampling.max_upward));
  if (!(std::isfinite(sampling.lever_arm) && sampling.lever_arm >= 0))
    throw bad("lever_arm must be finite and >= 0 m, got " + number(sampling.lever_arm));
  std::vector<Impulse> kicks;
  for (std::size_t prop = 0; prop < prop_masses.size(); ++prop) {
    const double mass = prop_masses[prop];
    if (!(std::isfinite(mass) && mass > 0)) throw bad("prop " + std::to_string(prop) + ": mass must be finite and > 0 kg, got " + number(mass));
    PortableUniform uniform(sampling.seed, prop);
    const auto count = static_cast<long long>(std::floor(sampling.rate * duration + uniform.next()));
    std::vector<double> times;
    for (long long k = 0; k < count; ++k) times.push_back(uniform.between(0, duration));
    std::sort(times.begin(), times.end());
    for (double time : times) {
      Impulse kick;
      kick.time = time;
      kick.prop = static_cast<int>(prop);
      const double speed = uniform.between(sampling.min_speed_change, sampling.max_speed_change);
      const double up = uniform.between(0, sampling.max_upward);
      const Eigen::Vector2d heading = unit_heading(uniform) * std::sqrt(1 - up * up);
      kick.impulse = mass * speed * Eigen::Vector3d(heading.x(), heading.y(), up);
      kick.point = in_ball(uniform, sampling.lever_arm);
      kicks.push_back(kick);
    }
  }
  std::stable_sort(kicks.begin(), kicks.end(), [](const Impulse& a, const Impulse& b) { return a.time < b.time; });
  return kicks;
}

std::vector<ScatterPlacement> scatter_props(const ScatterRequest& request) {
  const auto bad = [](const std::string& what) { return std::invalid_argument("scatter: " + what); };
  const std::size_t count = request.footprint_radii.size();
  if (!request.region_min.allFinite() || !request.region_max.allFinite() || !(request.region_max.array() > request.region_min.array()).all())
    throw bad("region must be finite with max > min in x and y");
  if (!(std::isfinite(request.gap) && request.gap >= 0)) throw bad("gap must be finite and >= 0 m, got " + number(request.gap));
  if (request.max_attempts < 1) throw bad("max_attempts must be >= 1, got " + std::to_string(request.max_attempts));
  if (request.on_paths < 0 || static_cast<std::size_t>(request.on_paths) > count)
    throw bad("on_paths = " + std::to_string(request.on_paths) + " must be in [0, " + std::to_string(count) + "] (the prop count)");
  if (request.on_paths > 0 && request.paths.empty()) throw bad(std::to_string(request.on_paths) + " props should go on paths, but no path is given");
  std::vector<std::vector<double>> arc(request.paths.size());  // cumulative arc length per path
  for (std::size_t p = 0; p < request.paths.size(); ++p) {
    const auto& path = request.paths[p];
    if (path.size() < 2) throw bad("path " + std::to_string(p) + " has " + std::to_string(path.size()) + " points, needs at least 2");
    arc[p].push_back(0);
    for (std::size_t k = 0; k < path.size(); ++k) {
      if (!path[k].allFinite()) throw bad("path " + std::to_string(p) + " point " + std::to_string(k) + " is not finite");
      if (k > 0) arc[p].push_back(arc[p].back() + (path[k] - path[k - 1]).norm());
    }
  }
  for (std::size_t k = 0; k < request.keep_out.size(); ++k)
    if (!request.keep_out[k].centre.allFinite() || !(std::isfinite(request.keep_out[k].radius) && request.keep_out[k].radius >= 0))
      throw bad("keep-out disc " + std::to_string(k) + " must have a finite centre and a finite radius >= 0");
  const Eigen::Vector2d size = request.region_max - request.region_min;
  double footprint_area = 0;
  for (std::size_t i = 0; i < count; ++i) {
    const double r = request.footprint_radii[i];
    if (!(std::isfinite(r) && r > 0)) throw bad("prop " + std::to_string(i) + ": footprint radius must be finite and > 0 m, got " + number(r));
    if (static_cast<int>(i) >= request.on_paths) {
      if (2 * r > size.minCoeff())
        throw bad("prop " + std::to_string(i) + ": footprint radius " + number(r) + " m does not fit in the " + number(size.x()) + " x " +
                  number(size.y()) + " m region");
      const double padded = r + 0.5 * request.gap;
      footprint_area += std::numbers::pi * padded * padded;
    }
  }
  // Hexagonal packing fills pi / sqrt(12) ~ 0.9069 of the plane; no placement does better.
  const double region_area = size.x() * size.y();
  const double densest = std::numbers::pi / std::sqrt(12.0) * region_area;
  if (footprint_area > densest)
    throw bad(std::to_string(count - request.on_paths) + " footprints cover " + number(footprint_area) + " m^2, more than the densest packing fits in the " +
              number(size.x()) + " x " + number(size.y()) + " m region (" + number(densest) + " m^2)");

  std::vector<ScatterPlacement> placed;
  const auto free_at = [&](const Eigen::Vector2d& at, double r) {
    for (const KeepOut& disc : request.keep_out)
      if ((disc.centre - at).norm() < r + disc.radius + request.gap) return false;
    for (std::size_t j = 0; j < placed.size(); ++j)
      if ((placed[j].position - at).norm() < r + request.footprint_radii[j] + request.gap) return false;
    return true;
  };
  for (std::size_t i = 0; i < count; ++i) {
    PortableUniform uniform(request.seed, i);
    const double r = request.footprint_radii[i];
    const bool on_path = static_cast<int>(i) < request.on_paths;
    const int path = on_path ? static_cast<int>(i % request.paths.size()) : -1;
    bool done = false;
    for (int attempt = 0; attempt < request.max_attempts && !done; ++attempt) {
      Eigen::Vector2d at;
      if (on_path) {
        const auto& lengths = arc[path];
        const double s = uniform.between(0, lengths.back());
        const std::size_t k = std::min<std::size_t>(std::upper_bound(lengths.begin(), lengths.end(), s) - lengths.begin(), lengths.size() - 1);
        const double span = lengths[k] - lengths[k - 1];
        const double t = span > 0 ? (s - lengths[k - 1]) / span : 0;
        at = (1 - t) * request.paths[path][k - 1] + t * request.paths[path][k];
      } else {
        at = Eigen::Vector2d(uniform.between(request.region_min.x() + r, request.region_max.x() - r),
                             uniform.between(request.region_min.y() + r, request.region_max.y() - r));
      }
      const double yaw = uniform.between(0, 2 * std::numbers::pi);
      if (free_at(at, r)) {
        placed.push_back({at, yaw, path});
        done = true;
      }
    }
    if (!done)
      throw bad("prop " + std::to_string(i) + " (footprint radius " + number(r) + " m) found no free spot " +
                (on_path ? "on path " + std::to_string(path) : std::string("in the region")) + " after " + std::to_string(request.max_attempts) +
                " attempts; " + std::to_string(placed.size()) + " of " + std::to_string(count) + " props were placed");
  }
  return placed;
}

}  // namespace odyssey::physics
