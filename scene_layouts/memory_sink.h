// A trajectory file held in memory: the arrays TrajectorySink writes into trajectories_<camera>.npz
// (mocap_io/trajectory_file.h), with the same keys, shapes, types and values, for callers that
// want the numbers without a file (the Python module's in-memory scenes). The sink writes no file.
//
// Memory: every array of the shot at once, T x N x (3 + 2 floats + 3 bytes) plus T x 25 floats,
// so it suits shots that fit in memory; streaming to disk is what TrajectorySink is for.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "mocap_io/trajectory_file.h"
#include "scene_layouts/frame_loop.h"

namespace odyssey::scene {

// The trajectory file's arrays, row-major, with their shapes in the comments (T frames, N points).
struct TrajectoryArrays {
  std::size_t frames = 0, points = 0;
  double fps = 30;
  std::vector<float> trajs_3d;                    // T x N x 3
  std::vector<float> trajs_2d;                    // T x N x 2
  std::vector<std::uint8_t> visibs, valids;       // T x N, 0 or 1
  std::vector<float> intrinsics, extrinsics;      // T x 3 x 3, T x 4 x 4
  std::vector<std::uint8_t> visibility_codes;     // T x N (io::kVisible ...)
  std::vector<std::int32_t> point_vertex_ids;     // N x 3
  std::vector<float> point_barycentric;           // N x 3
  std::vector<std::int32_t> point_actor_ids;      // N
};

// Camera `camera`'s trajectories, as TrajectorySink would write them with `header`.
class TrajectoryMemorySink : public StreamSink {
 public:
  // Throws std::invalid_argument as io::TrajectoryFileWriter does for an empty or inconsistent header.
  TrajectoryMemorySink(int camera, const io::TrajectoryFileHeader& header);
  // Copies the chunk's frames. Throws std::invalid_argument naming both sizes when a span of the
  // chunk is the wrong size or the frames would pass T (the frame loop's values are the ones the
  // file writer checks, so its value checks are not repeated).
  void write(const FrameChunk& chunk) override;
  // Throws std::invalid_argument when fewer than T frames arrived.
  void finish(const SceneResult&) override;
  std::vector<std::string> files() const override { return {}; }

  // The arrays once finished (moved out: the sink is empty afterwards).
  TrajectoryArrays take() { return std::move(arrays_); }

 private:
  int camera_;
  std::size_t written_ = 0;
  TrajectoryArrays arrays_;
};

}  // namespace odyssey::scene
