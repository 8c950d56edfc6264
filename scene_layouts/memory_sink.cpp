#include "scene_layouts/memory_sink.h"

#include <stdexcept>

namespace odyssey::scene {
namespace {

void check_size(const char* name, std::size_t got, std::size_t expected) {
  if (got != expected) {
    throw std::invalid_argument(std::string("trajectory arrays: ") + name + " has " + std::to_string(got) +
                                " values, expected " + std::to_string(expected));
  }
}

template <class T>
void append(std::vector<T>& to, std::span<const T> from) {
  to.insert(to.end(), from.begin(), from.end());
}

}  // namespace

TrajectoryMemorySink::TrajectoryMemorySink(int camera, const io::TrajectoryFileHeader& header) : camera_(camera) {
  const std::size_t T = header.frames, N = header.points;
  if (T == 0 || N == 0) {
    throw std::invalid_argument("trajectory arrays: need at least one frame and one point, got " + std::to_string(T) +
                                " frames and " + std::to_string(N) + " points");
  }
  check_size("point_vertex_ids", header.point_vertex_ids.size(), 3 * N);
  check_size("point_barycentric", header.point_barycentric.size(), 3 * N);
  check_size("point_actor_ids", header.point_actor_ids.size(), N);
  arrays_.frames = T;
  arrays_.points = N;
  arrays_.fps = header.fps;
  arrays_.point_vertex_ids = header.point_vertex_ids;
  arrays_.point_barycentric = header.point_barycentric;
  arrays_.point_actor_ids = header.point_actor_ids;
  // Reserved whole up front: the arrays end at exactly their file's size, with no regrowth.
  arrays_.trajs_3d.reserve(T * N * 3);
  arrays_.trajs_2d.reserve(T * N * 2);
  arrays_.visibs.reserve(T * N);
  arrays_.valids.reserve(T * N);
  arrays_.visibility_codes.reserve(T * N);
  arrays_.intrinsics.reserve(T * 9);
  arrays_.extrinsics.reserve(T * 16);
}

void TrajectoryMemorySink::write(const FrameChunk& chunk) {
  const std::size_t count = static_cast<std::size_t>(chunk.count), N = arrays_.points;
  if (count > arrays_.frames - written_) {
    throw std::invalid_argument("trajectory arrays: " + std::to_string(count) + " more frames after " +
                                std::to_string(written_) + " would pass the shot's " + std::to_string(arrays_.frames));
  }
  const CameraChunk& c = chunk.cameras[camera_];
  check_size("trajs_3d", chunk.trajs_3d.size(), count * N * 3);
  check_size("trajs_2d", c.trajs_2d.size(), count * N * 2);
  check_size("valids", c.valids.size(), count * N);
  check_size("visibs", c.visibs.size(), count * N);
  check_size("visibility_codes", c.visibility_codes.size(), count * N);
  check_size("intrinsics", c.intrinsics.size(), count * 9);
  check_size("extrinsics", c.extrinsics.size(), count * 16);
  append(arrays_.trajs_3d, chunk.trajs_3d);
  append(arrays_.trajs_2d, c.trajs_2d);
  append(arrays_.valids, c.valids);
  append(arrays_.visibs, c.visibs);
  append(arrays_.visibility_codes, c.visibility_codes);
  append(arrays_.intrinsics, c.intrinsics);
  append(arrays_.extrinsics, c.extrinsics);
  written_ += count;
}

void TrajectoryMemorySink::finish(const SceneResult&) {
  if (written_ != arrays_.frames) {
    throw std::invalid_argument("trajectory arrays: " + std::to_string(written_) + " frames arrived, the shot has " +
                                std::to_string(arrays_.frames));
  }
}

}  // namespace odyssey::scene
