#include "scene_layouts/streams.h"

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "scene_layouts/visibility.h"
#include "skinning/lbs.h"

namespace odyssey::scene {
namespace {

using Clock = std::chrono::steady_clock;

void require_clip_on(const Character& character, const Clip& clip) {
  const Skeleton& ours = character.skeleton;
  if (clip.joint_count() != ours.joint_count()) {
    throw std::invalid_argument("the clip has " + std::to_string(clip.joint_count()) + " joints, the character " +
                                std::to_string(ours.joint_count()));
  }
  for (int j = 0; j < ours.joint_count(); ++j) {
    if (clip.skeleton.name(j) != ours.name(j) || clip.skeleton.parent(j) != ours.parent(j)) {
      throw std::invalid_argument("the clip's joint " + std::to_string(j) + " (" + clip.skeleton.name(j) +
                                  ") is not the character's (" + ours.name(j) + ")");
    }
  }
  if (clip.frame_count() < 1) throw std::invalid_argument("the clip has no frames");
}

// Frames per chunk: the option, or as many frames of `bytes_per_frame` output as fit in 16 MiB.
int chunk_frames(const StreamOptions& options, std::size_t bytes_per_frame) {
  if (options.chunk_frames < 0) throw std::invalid_argument("chunk_frames must not be negative");
  if (options.threads < 1) throw std::invalid_argument("threads must be at least 1");
  if (options.chunk_frames > 0) return options.chunk_frames;
  constexpr std::size_t kChunkBytes = std::size_t(16) << 20;
  return static_cast<int>(std::clamp<std::size_t>(kChunkBytes / std::max<std::size_t>(bytes_per_frame, 1), 1, 256));
}

// World transforms of frames [first, first + count), frame after frame.
void world_poses(const Clip& clip, int first, int count, std::vector<RigidTransform<double>>& world) {
  const std::size_t joints = clip.joint_count();
  world.resize(count * joints);
  for (int f = 0; f < count; ++f) {
    clip.world_pose(first + f, std::span(world).subspan(f * joints, joints));
  }
}

// Every triangle of every mesh, its corners numbered across the meshes in order (as
// all_vertices() lists them).
std::vector<std::uint32_t> all_triangles(const Character& character) {
  std::vector<std::uint32_t> triangles;
  std::uint32_t offset = 0;
  for (const CharacterMesh& mesh : character.meshes) {
    for (const std::uint32_t corner : mesh.triangles) triangles.push_back(offset + corner);
    offset += static_cast<std::uint32_t>(mesh.positions.size());
  }
  return triangles;
}

}  // namespace

io::TrajectoryFileHeader trajectory_file_header(const Character& character, std::span<const skinning::SurfacePoint> points,
                                                std::size_t frames, double fps, int actor) {
  // Vertex v of mesh m is number offset[m] + v across the meshes, the rest OBJ's order.
  std::vector<std::int64_t> offset(character.meshes.size() + 1, 0);
  for (std::size_t m = 0; m < character.meshes.size(); ++m) {
    offset[m + 1] = offset[m] + static_cast<std::int64_t>(character.meshes[m].positions.size());
  }
  if (offset.back() > INT32_MAX) throw std::invalid_argument("the character has more vertices than int32 numbers");
  io::TrajectoryFileHeader header;
  header.frames = frames;
  header.points = points.size();
  header.fps = fps;
  header.point_vertex_ids.reserve(points.size() * 3);
  header.point_barycentric.reserve(points.size() * 3);
  header.point_actor_ids.assign(points.size(), actor);
  for (const skinning::SurfacePoint& point : points) {
    if (point.mesh >= character.meshes.size()) throw std::invalid_argument("a sampled point names a mesh the character lacks");
    for (int c = 0; c < 3; ++c) {
      header.point_vertex_ids.push_back(static_cast<std::int32_t>(offset[point.mesh] + point.vertices[c]));
      header.point_barycentric.push_back(point.barycentric[c]);
    }
  }
  return header;
}

TrajectoryExportSummary export_trajectories(const Character& character, const Clip& clip,
                                            std::span<const skinning::SurfacePoint> points, const CameraPath& camera,
                                            io::TrajectoryFileWriter& writer, const StreamOptions& options) {
  const auto start = Clock::now();
  require_clip_on(character, clip);
  camera.validate();
  const int frames = clip.frame_count();
  if (camera.frame_count() != frames) {
    throw std::invalid_argument("the camera path has " + std::to_string(camera.frame_count()) + " frames, the clip " +
                                std::to_string(frames));
  }
  skinning::SurfacePointSkinner skinner(character, points, options.threads);
  const std::size_t n = skinner.point_count();
  // Occluders: every mesh of the character, skinned whole each frame and drawn into a depth buffer.
  const std::vector<skinning::MeshVertex> mesh_vertices = skinning::all_vertices(character);
  skinning::LinearBlendSkinner mesh_skinner(character, mesh_vertices, skinning::SkinningOptions{options.threads, false});
  const std::vector<std::uint32_t> triangles = all_triangles(character);
  const std::size_t v = mesh_vertices.size();
  const int chunk_size = chunk_frames(options, n * (5 * sizeof(float) + 2) + v * 3 * sizeof(float));
  const std::size_t chunk = static_cast<std::size_t>(chunk_size);
  std::optional<DepthBuffer> depth;
  std::vector<float> mesh(chunk * v * 3);

  std::vector<RigidTransform<double>> world;
  std::vector<float> trajs_3d(chunk * n * 3), trajs_2d(chunk * n * 2), intrinsics(chunk * 9), extrinsics(chunk * 16);
  std::vector<std::uint8_t> valids(chunk * n), visibs(chunk * n);
  std::size_t valid_count = 0, visible_count = 0;
  for (int first = 0; first < frames; first += chunk_size) {
    const int count = std::min(chunk_size, frames - first);
    world_poses(clip, first, count, world);
    skinner.skin_frames(count, world, std::span(trajs_3d).first(count * n * 3));
    mesh_skinner.skin_frames(count, world, std::span(mesh).first(count * v * 3));
    for (int f = 0; f < count; ++f) {
      const CameraPose& pose = camera.poses[first + f];
      const PinholeIntrinsics& k = camera.intrinsics[first + f];
      if (!depth || depth->width() != k.width || depth->height() != k.height) depth.emplace(k.width, k.height);
      depth->render(pose, k, std::span(mesh).subspan(f * v * 3, v * 3), triangles);
      const float* p = trajs_3d.data() + f * n * 3;
      float* uv = trajs_2d.data() + f * n * 2;
      std::uint8_t* valid = valids.data() + f * n;
      std::uint8_t* visible = visibs.data() + f * n;
      Eigen::Vector3d low = Eigen::Vector3d::Constant(INFINITY), high = Eigen::Vector3d::Constant(-INFINITY);
      for (std::size_t i = 0; i < n; ++i) {
        const Eigen::Vector3d point(p[3 * i], p[3 * i + 1], p[3 * i + 2]);
        const PixelProjection pixel = project(pose, k, point);
        uv[2 * i] = static_cast<float>(pixel.u);
        uv[2 * i + 1] = static_cast<float>(pixel.v);
        valid[i] = pixel.valid;
        visible[i] = pixel.valid && depth->visible(pose.to_camera(point));
        valid_count += valid[i];
        visible_count += visible[i];
        low = low.cwiseMin(point);
        high = high.cwiseMax(point);
      }
      if (options.reject_camera_inside) {
        const Eigen::Vector3d centre = pose.centre();
        if ((centre.array() > low.array()).all() && (centre.array() < high.array()).all()) {
          throw std::invalid_argument("the " + camera.kind + " camera is inside the character at frame " +
                                      std::to_string(first + f) + ": its centre lies within the box of the tracked points");
        }
      }
      const Eigen::Matrix3d kk = k.matrix();
      const Eigen::Matrix4d e = pose.extrinsics();
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) intrinsics[f * 9 + r * 3 + c] = static_cast<float>(kk(r, c));
      }
      for (int r = 0; r < 4; ++r) {
        for (int c = 0; c < 4; ++c) extrinsics[f * 16 + r * 4 + c] = static_cast<float>(e(r, c));
      }
    }
    writer.append_frames(count, std::span(trajs_3d).first(count * n * 3), std::span(trajs_2d).first(count * n * 2),
                         std::span(valids).first(count * n), std::span(visibs).first(count * n),
                         std::span(intrinsics).first(count * 9), std::span(extrinsics).first(count * 16));
  }
  TrajectoryExportSummary summary;
  summary.frames = frames;
  summary.points = n;
  summary.skinned_vertices = skinner.skinned_vertex_count();
  summary.valid_fraction = static_cast<double>(valid_count) / (static_cast<double>(frames) * n);
  summary.visible_fraction = static_cast<double>(visible_count) / (static_cast<double>(frames) * n);
  summary.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return summary;
}

PointCacheSummary export_point_cache(const Character& character, const Clip& clip, io::Pc2Writer& writer,
                                     const StreamOptions& options) {
  const auto start = Clock::now();
  require_clip_on(character, clip);
  const std::vector<skinning::MeshVertex> vertices = skinning::all_vertices(character);
  if (vertices.empty()) throw std::invalid_argument("the character has no mesh vertices");
  skinning::LinearBlendSkinner skinner(character, vertices, skinning::SkinningOptions{options.threads, false});
  const std::size_t v = skinner.vertex_count();
  const int frames = clip.frame_count();
  const int chunk_size = chunk_frames(options, v * 3 * sizeof(float));
  std::vector<RigidTransform<double>> world;
  std::vector<float> positions(static_cast<std::size_t>(chunk_size) * v * 3);
  for (int first = 0; first < frames; first += chunk_size) {
    const int count = std::min(chunk_size, frames - first);
    world_poses(clip, first, count, world);
    const std::span<float> chunk = std::span(positions).first(count * v * 3);
    skinner.skin_frames(count, world, chunk);
    writer.append_frames(count, chunk);
  }
  PointCacheSummary summary;
  summary.frames = frames;
  summary.vertices = v;
  summary.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return summary;
}

}  // namespace odyssey::scene
