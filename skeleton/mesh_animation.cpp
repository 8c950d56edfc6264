#include "skeleton/mesh_animation.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace odyssey {

MeshAnimation MeshAnimation::sampled_at(std::span<const double> times, double target_fps) const {
  if (!(target_fps > 0) || !std::isfinite(target_fps)) throw std::invalid_argument("mesh animation: the rate must be positive");
  if (!(fps > 0) || !std::isfinite(fps)) throw std::invalid_argument("mesh animation: its own rate is not positive");
  const int frames = frame_count();
  if (frames < 1) throw std::invalid_argument("mesh animation: no frames");
  MeshAnimation out;
  out.fps = target_fps;
  out.vertex_count = vertex_count;
  out.positions.resize(times.size() * vertex_count * 3);
  const std::size_t floats = vertex_count * 3;
  for (std::size_t k = 0; k < times.size(); ++k) {
    if (!std::isfinite(times[k])) throw std::invalid_argument("mesh animation: time " + std::to_string(k) + " is not finite");
    // Source frame position u = t fps, between frames i and i + 1 with weight w on i + 1.
    const double u = std::clamp(times[k], 0.0, duration()) * fps;
    const int i = std::min(static_cast<int>(std::floor(u)), frames - 1);
    const double w = i + 1 < frames ? u - i : 0.0;
    const float* a = positions.data() + std::size_t(i) * floats;
    const float* b = positions.data() + std::size_t(std::min(i + 1, frames - 1)) * floats;
    float* to = out.positions.data() + k * floats;
    if (w == 0) {
      std::copy(a, a + floats, to);
    } else {
      for (std::size_t c = 0; c < floats; ++c) to[c] = static_cast<float>((1 - w) * a[c] + w * b[c]);
    }
  }
  return out;
}

}  // namespace odyssey
