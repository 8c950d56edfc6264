// A vertex-animated mesh: the positions of every vertex of one mesh, frame after frame, at a fixed
// frame rate (DeformingThings4D's .anime files are such; mocap_io/anime_file.h reads them). No
// skeleton deforms it; time is resampled by moving each vertex linearly between the two
// neighbouring frames, as Clip::sampled_at does with translations.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

namespace odyssey {

struct MeshAnimation {
  double fps = 30;
  std::size_t vertex_count = 0;
  std::vector<float> positions;  // frame x vertex_count x 3: (x, y, z) of vertex v of frame f at 3 (f V + v)

  int frame_count() const { return vertex_count == 0 ? 0 : static_cast<int>(positions.size() / (3 * vertex_count)); }
  double duration() const { return frame_count() > 0 ? (frame_count() - 1) / fps : 0.0; }
  std::span<const float> frame(int f) const { return std::span(positions).subspan(std::size_t(f) * vertex_count * 3, vertex_count * 3); }

  // The animation at any times (seconds from its first frame, clamped to [0, duration()]): frame k
  // of the result, at `target_fps`, is the positions at times[k], each vertex interpolated linearly
  // between the neighbouring frames. Throws std::invalid_argument for no frames, a non-finite time
  // or a non-positive rate.
  MeshAnimation sampled_at(std::span<const double> times, double target_fps) const;
  // One time of the same into `out` (vertex_count x 3 floats). Allocates nothing.
  void sample(double time, std::span<float> out) const;
};

}  // namespace odyssey
