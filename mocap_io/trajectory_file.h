// The trajectory annotation file: an .npz with the dataset's keys (PointOdyssey style), so
// existing loaders work, plus this toolkit's own point description. T frames, N points:
//
//   trajs_3d           float32 [T, N, 3]  world positions (Z up, metres)
//   trajs_2d           float32 [T, N, 2]  pixel coordinates (u, v) in the frame's camera (0 where
//                                         the point is behind the camera)
//   visibs             bool    [T, N]     valid and not occluded by any mesh rendered into the frame's
//                                         depth buffer (scene_layouts/visibility.h), so visibs
//                                         implies valids
//   valids             bool    [T, N]     in front of the camera and inside the image
//   intrinsics         float32 [T, 3, 3]  K in pixels
//   extrinsics         float32 [T, 4, 4]  world -> camera, OpenCV axes (x right, y down, z forward)
//   point_vertex_ids   int32   [N, 3]     the corners of each point's triangle, as indices into
//                                         the character's vertices numbered across its meshes in
//                                         order (the vertex order of the point cache's rest OBJ);
//                                         a vertex sample names its vertex three times
//   point_barycentric  float32 [N, 3]     weights of those corners; (1, 0, 0) for a vertex sample
//   point_actor_ids    int32   [N]        which actor of the scene a point is on: 0, 1, ... in the
//                                         scene's order; props are -1 - k for prop k (the first
//                                         prop -1)
//   visibility_codes   uint8   [T, N]     why a point is or is not visible (files of scenes, and of
//                                         odyssey trajectories): 0 visible, 1 occluded by an actor
//                                         (its own body included), 2 occluded by a prop, 3 outside
//                                         the image, 4 behind the camera
//   visibilities       uint8   [T, N]     PointOdyssey's three states, when the header asks for them
//                                         (sequences): 1 visible, 2 behind the camera, 0 otherwise
//                                         (occluded or outside the image); the toolkit has no far limit
//   fps                float64 []         frames per second
//
// float32 throughout, never float16 (half floats resolve only half a pixel past 512 px).
//
// Streaming: frames arrive in chunks of any size (append_frames) and go to disk at once, so
// memory does not grow with T. trajs_3d streams straight into the archive; the other per-frame
// arrays are spooled to temporary files beside the output and copied into the archive, in
// bounded blocks, by close(). Members are stored, not deflated, by default (as numpy.savez
// does): trajectories barely compress and deflate would dominate the export time.
// Nothing appears at `path` until close() succeeds: the archive and the spools live under
// temporary names beside it and are removed when the writer is destroyed without close().
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace odyssey::io {

struct TrajectoryFileHeader {
  std::size_t frames = 0;  // T, at least 1
  std::size_t points = 0;  // N, at least 1
  double fps = 30;
  std::vector<std::int32_t> point_vertex_ids;  // N x 3
  std::vector<float> point_barycentric;        // N x 3
  std::vector<std::int32_t> point_actor_ids;   // N
  bool visibility_codes = false;               // write visibility_codes [T, N]
  bool visibilities = false;                   // and visibilities [T, N] from them (needs the codes)
};

// The values of visibility_codes.
inline constexpr std::uint8_t kVisible = 0, kOccludedByActor = 1, kOccludedByProp = 2, kOutsideImage = 3,
                              kBehindCamera = 4;

class TrajectoryFileWriter {
 public:
  // Throws std::invalid_argument when frames or points is 0, fps is not positive and finite, or
  // the point arrays are not N x 3, N x 3 and N long; InputError naming `path` when the temporary
  // files cannot be created.
  TrajectoryFileWriter(std::string path, TrajectoryFileHeader header, bool compress = false);
  ~TrajectoryFileWriter();
  TrajectoryFileWriter(const TrajectoryFileWriter&) = delete;
  TrajectoryFileWriter& operator=(const TrajectoryFileWriter&) = delete;

  // `count` frames, each array frame after frame: trajs_3d count*N*3, trajs_2d count*N*2, valids
  // and visibs count*N (1 or 0 each), intrinsics count*9 and extrinsics count*16, matrices
  // row-major; visibility_codes count*N when the header asks for them, else empty. Throws
  // std::invalid_argument naming both sizes when a span is the wrong size or the frames would
  // pass T, when a value is not finite or a bool not 0 or 1, when a point is visible but not
  // valid, and when a code disagrees with the flags; InputError when a write fails.
  void append_frames(std::size_t count, std::span<const float> trajs_3d, std::span<const float> trajs_2d,
                     std::span<const std::uint8_t> valids, std::span<const std::uint8_t> visibs,
                     std::span<const float> intrinsics, std::span<const float> extrinsics,
                     std::span<const std::uint8_t> visibility_codes = {});

  std::size_t frames_written() const;

  // Completes the archive and renames it onto `path`. Throws std::invalid_argument when fewer
  // than T frames arrived.
  void close();

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace odyssey::io
