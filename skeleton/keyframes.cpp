#include "skeleton/keyframes.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace odyssey {
namespace {

Eigen::Quaterniond quaternion_at(const double* xyzw) { return Eigen::Quaterniond(xyzw[3], xyzw[0], xyzw[1], xyzw[2]); }

void store(const Eigen::Quaterniond& q, std::span<double> out) {
  out[0] = q.x();
  out[1] = q.y();
  out[2] = q.z();
  out[3] = q.w();
}

}  // namespace

void KeyframeTrack::validate(const std::string& what) const {
  if (components < 1 || (rotation && components != 4)) {
    throw std::invalid_argument(what + ": " + std::to_string(components) + " components a key" +
                                (rotation ? " (a rotation has 4)" : ""));
  }
  if (times.empty()) throw std::invalid_argument(what + ": no keys");
  const std::size_t per_key = std::size_t(components) * (interpolation == Interpolation::cubic_spline ? 3 : 1);
  if (values.size() != times.size() * per_key) {
    throw std::invalid_argument(what + ": " + std::to_string(values.size()) + " numbers for " + std::to_string(times.size()) +
                                " keys of " + std::to_string(per_key));
  }
  for (std::size_t k = 0; k < times.size(); ++k) {
    if (!std::isfinite(times[k])) throw std::invalid_argument(what + ": key " + std::to_string(k) + " has a non-finite time");
    if (k > 0 && times[k] < times[k - 1]) {
      throw std::invalid_argument(what + ": key " + std::to_string(k) + " at " + std::to_string(times[k]) +
                                  " s comes before key " + std::to_string(k - 1) + " at " + std::to_string(times[k - 1]) + " s");
    }
  }
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (!std::isfinite(values[i])) {
      throw std::invalid_argument(what + ": key " + std::to_string(i / per_key) + " holds a non-finite value");
    }
  }
  if (rotation) {
    // The value of key k starts at k per_key, after the in-tangent for cubic splines.
    const std::size_t offset = interpolation == Interpolation::cubic_spline ? 4 : 0;
    for (std::size_t k = 0; k < times.size(); ++k) {
      if (quaternion_at(&values[k * per_key + offset]).norm() < 1e-6) {
        throw std::invalid_argument(what + ": key " + std::to_string(k) + " is a rotation quaternion of (near) zero length");
      }
    }
  }
}

void KeyframeTrack::sample(double t, std::span<double> out) const {
  const std::size_t n = std::size_t(components);
  const bool cubic = interpolation == Interpolation::cubic_spline;
  const std::size_t per_key = cubic ? 3 * n : n;
  const std::size_t offset = cubic ? n : 0;  // the value within a key's numbers
  const auto value = [&](std::size_t k) { return &values[k * per_key + offset]; };
  const auto copy_key = [&](std::size_t k) {
    if (rotation) {
      store(quaternion_at(value(k)).normalized(), out);
    } else {
      std::copy(value(k), value(k) + n, out.begin());
    }
  };
  // k: the last key at or before t; t_{k+1} > t then, so d > 0.
  const auto after = std::upper_bound(times.begin(), times.end(), t);
  if (after == times.begin()) return copy_key(0);
  if (after == times.end()) return copy_key(times.size() - 1);
  const std::size_t k = static_cast<std::size_t>(after - times.begin()) - 1;
  if (interpolation == Interpolation::step) return copy_key(k);
  const double d = times[k + 1] - times[k];
  const double s = (t - times[k]) / d;
  if (interpolation == Interpolation::linear) {
    if (rotation) {
      // Eigen's slerp takes the shorter arc (it flips the sign of the second when their dot is negative).
      store(quaternion_at(value(k)).normalized().slerp(s, quaternion_at(value(k + 1)).normalized()), out);
    } else {
      for (std::size_t c = 0; c < n; ++c) out[c] = (1 - s) * value(k)[c] + s * value(k + 1)[c];
    }
    return;
  }
  const double s2 = s * s, s3 = s2 * s;
  const double h_value0 = 2 * s3 - 3 * s2 + 1, h_out0 = d * (s3 - 2 * s2 + s);
  const double h_value1 = -2 * s3 + 3 * s2, h_in1 = d * (s3 - s2);
  const double* out_tangent = &values[k * per_key + 2 * n];
  const double* in_tangent = &values[(k + 1) * per_key];
  for (std::size_t c = 0; c < n; ++c) {
    out[c] = h_value0 * value(k)[c] + h_out0 * out_tangent[c] + h_value1 * value(k + 1)[c] + h_in1 * in_tangent[c];
  }
  if (rotation) {
    Eigen::Quaterniond q = quaternion_at(out.data());
    // Tangents that cancel the values are the file's mistake; keep the nearer key rather than divide by zero.
    if (q.norm() < 1e-12) q = quaternion_at(value(s < 0.5 ? k : k + 1));
    store(q.normalized(), out);
  }
}

}  // namespace odyssey
