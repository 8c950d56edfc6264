#include "skeleton/mesh_animation.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace odyssey {

namespace {

void require_sampleable(const MeshAnimation& animation) {
  if (!(animation.fps > 0) || !std::isfinite(animation.fps)) throw std::invalid_argument("mesh animation: its own rate is not positive");
  if (animation.frame_count() < 1) throw std::invalid_argument("mesh animation: no frames");
}

// Source frame position u = t fps, between frames i and i + 1 with weight w on i + 1.
void sample_unchecked(const MeshAnimation& animation, double time, float* to) {
  const int frames = animation.frame_count();
  const std::size_t floats = animation.vertex_count * 3;
  const double u = std::clamp(time, 0.0, animation.duration()) * animation.fps;
  const int i = std::min(static_cast<int>(std::floor(u)), frames - 1);
  const double w = i + 1 < frames ? u - i : 0.0;
  const float* a = animation.positions.data() + std::size_t(i) * floats;
  const float* b = animation.positions.data() + std::size_t(std::min(i + 1, frames - 1)) * floats;
  if (w == 0) {
    std::copy(a, a + floats, to);
  } else {
    for (std::size_t c = 0; c < floats; ++c) to[c] = static_cast<float>((1 - w) * a[c] + w * b[c]);
  }
}

}  // namespace

MeshAnimation MeshAnimation::sampled_at(std::span<const double> times, double target_fps) const {
  if (!(target_fps > 0) || !std::isfinite(target_fps)) throw std::invalid_argument("mesh animation: the rate must be positive");
  require_sampleable(*this);
  MeshAnimation out;
  out.fps = target_fps;
  out.vertex_count = vertex_count;
  out.positions.resize(times.size() * vertex_count * 3);
  for (std::size_t k = 0; k < times.size(); ++k) {
    if (!std::isfinite(times[k])) throw std::invalid_argument("mesh animation: time " + std::to_string(k) + " is not finite");
    sample_unchecked(*this, times[k], out.positions.data() + k * vertex_count * 3);
  }
  return out;
}

void MeshAnimation::sample(double time, std::span<float> out) const {
  require_sampleable(*this);
  if (!std::isfinite(time)) throw std::invalid_argument("mesh animation: a time is not finite");
  if (out.size() != vertex_count * 3) throw std::invalid_argument("mesh animation: the output holds " + std::to_string(out.size()) + " floats, not " + std::to_string(vertex_count * 3));
  sample_unchecked(*this, time, out.data());
}

}  // namespace odyssey
