// Keyframe tracks as glTF animation samplers define them, sampled at any time. A track holds key
// times t_0 <= t_1 <= ... and per key a value of `components` numbers (3 for a translation or a
// scale, 4 for a rotation quaternion stored x, y, z, w). Between keys t_k <= t < t_{k+1}, with
// d = t_{k+1} - t_k and s = (t - t_k) / d:
//
//   step          v_k (held until the next key)
//   linear        (1 - s) v_k + s v_{k+1}; rotations slerp the shorter way from v_k to v_{k+1}
//   cubic_spline  (2s^3 - 3s^2 + 1) v_k + d (s^3 - 2s^2 + s) b_k + (-2s^3 + 3s^2) v_{k+1} + d (s^3 - s^2) a_{k+1}
//                 (Hermite, glTF's CUBICSPLINE: a_k and b_k are key k's in- and out-tangents, in
//                 units per second, hence the factor d); rotations are normalised afterwards
//
// Before the first key a track holds its first value, after the last its last. Keys with equal
// times are allowed (glTF asks for strictly increasing ones): the later key wins from that time on,
// so a track can jump. Values of a cubic_spline track are stored per key as (in-tangent, value,
// out-tangent), as glTF stores them.
#pragma once

#include <span>
#include <string>
#include <vector>

namespace odyssey {

enum class Interpolation { step, linear, cubic_spline };

struct KeyframeTrack {
  Interpolation interpolation = Interpolation::linear;
  int components = 3;
  bool rotation = false;  // the values are quaternions x, y, z, w: slerped, normalised
  std::vector<double> times;
  // step, linear: times.size() x components; cubic_spline: times.size() x 3 x components.
  std::vector<double> values;

  // Throws std::invalid_argument (naming `what` and the key) on no keys, a value count that does
  // not match, a time that is not finite or decreases, a value that is not finite, or a rotation
  // key of (near) zero length.
  void validate(const std::string& what) const;

  // The value at time t into out (components numbers). The track must be valid.
  void sample(double t, std::span<double> out) const;
};

}  // namespace odyssey
