#include "scene_layouts/streams.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "scene_layouts/preview.h"
#include "scene_layouts/visibility.h"
#include "skinning/lbs.h"
#include "skinning/worker_pool.h"

namespace odyssey::scene {
namespace {

using Clock = std::chrono::steady_clock;

// Points classified per task of the worker pool: about a millisecond of work.
constexpr std::size_t kPointBlock = 2048;

void require_clip_on(const StreamActor& actor) {
  const Skeleton& ours = actor.character->skeleton;
  const Clip& clip = *actor.clip;
  const std::string who = "actor '" + actor.name + "': ";
  if (clip.joint_count() != ours.joint_count()) {
    throw std::invalid_argument(who + "the clip has " + std::to_string(clip.joint_count()) + " joints, the character " +
                                std::to_string(ours.joint_count()));
  }
  for (int j = 0; j < ours.joint_count(); ++j) {
    if (clip.skeleton.name(j) != ours.name(j) || clip.skeleton.parent(j) != ours.parent(j)) {
      throw std::invalid_argument(who + "the clip's joint " + std::to_string(j) + " (" + clip.skeleton.name(j) +
                                  ") is not the character's (" + ours.name(j) + ")");
    }
  }
  if (clip.frame_count() < 1) throw std::invalid_argument(who + "the clip has no frames");
}

void require_vertex_animation(const StreamActor& actor) {
  const std::string who = "actor '" + actor.name + "': ";
  const MeshAnimation& animation = *actor.vertex_animation;
  if (actor.character->meshes.size() != 1 || animation.vertex_count != actor.character->meshes[0].positions.size()) {
    throw std::invalid_argument(who + "a vertex animation needs one mesh of as many vertices as it animates");
  }
  if (animation.frame_count() != actor.clip->frame_count()) {
    throw std::invalid_argument(who + "the vertex animation has " + std::to_string(animation.frame_count()) +
                                " frames, the clip " + std::to_string(actor.clip->frame_count()));
  }
}

// Frames per chunk: the option, or as many frames of `bytes_per_frame` output as fit in 16 MiB.
int chunk_frames(const StreamOptions& options, std::size_t bytes_per_frame) {
  if (options.chunk_frames < 0) throw std::invalid_argument("chunk_frames must not be negative");
  if (options.threads < 1) throw std::invalid_argument("threads must be at least 1");
  if (options.chunk_frames > 0) return options.chunk_frames;
  constexpr std::size_t kChunkBytes = std::size_t(16) << 20;
  return static_cast<int>(std::clamp<std::size_t>(kChunkBytes / std::max<std::size_t>(bytes_per_frame, 1), 1, 256));
}

std::size_t vertex_count(const Character& character) {
  std::size_t count = 0;
  for (const CharacterMesh& mesh : character.meshes) count += mesh.positions.size();
  return count;
}

// Every triangle of every mesh, corners numbered across the meshes in order (as all_vertices()
// lists them), plus `offset`.
std::vector<std::uint32_t> all_triangles(const Character& character, std::uint32_t offset = 0) {
  std::vector<std::uint32_t> triangles;
  for (const CharacterMesh& mesh : character.meshes) {
    for (const std::uint32_t corner : mesh.triangles) triangles.push_back(offset + corner);
    offset += static_cast<std::uint32_t>(mesh.positions.size());
  }
  return triangles;
}

// Whether no part of the box can be seen: all corners behind the camera, or all projecting to one
// side of the image.
bool box_out_of_view(const Eigen::AlignedBox3d& box, const CameraPose& pose, const PinholeIntrinsics& k) {
  bool all_behind = true, all_left = true, all_right = true, all_above = true, all_below = true;
  for (int c = 0; c < 8; ++c) {
    const Eigen::Vector3d p = pose.to_camera(box.corner(static_cast<Eigen::AlignedBox3d::CornerType>(c)));
    if (p.z() > 0) {
      all_behind = false;
      const double u = k.fx * p.x() / p.z() + k.cx, v = k.fy * p.y() / p.z() + k.cy;
      all_left &= u < 0;
      all_right &= u >= k.width;
      all_above &= v < 0;
      all_below &= v >= k.height;
    } else {
      // A corner behind the camera can project anywhere: only "all behind" may still cull.
      all_left = all_right = all_above = all_below = false;
    }
  }
  return all_behind || all_left || all_right || all_above || all_below;
}

bool strictly_inside(const Eigen::AlignedBox3d& box, const Eigen::Vector3d& point) {
  return (point.array() > box.min().array()).all() && (point.array() < box.max().array()).all();
}

// Per actor, what the loop holds across chunks.
struct ActorState {
  std::unique_ptr<skinning::SurfacePointSkinner> points;
  std::unique_ptr<skinning::LinearBlendSkinner> mesh;
  const MeshAnimation* animated = nullptr;  // a vertex-animated actor: no skinners
  bool has_mesh = false;                    // mesh_positions are filled (skinned or animated)
  std::vector<std::uint32_t> triangles;  // numbered within the actor's vertices
  std::vector<std::uint32_t> triangles_without_head;  // for an ego camera riding on it
  std::size_t vertices = 0;
  std::size_t first_point = 0;
  double margin = 0;                     // culling box growth, 0.25 rest height
  std::vector<RigidTransform<double>> world;   // C x J
  std::vector<float> point_positions;          // C x n x 3
  std::vector<float> mesh_positions;           // C x V x 3 (frames not needed are left stale)
  std::vector<Eigen::AlignedBox3d> boxes;      // per frame of the chunk: culling box
  std::vector<Eigen::AlignedBox3d> point_boxes;  // per frame: the inside test's box
};

}  // namespace

io::TrajectoryFileHeader trajectory_file_header(std::span<const StreamActor> actors, const StreamProps* props,
                                                std::size_t frames, double fps) {
  io::TrajectoryFileHeader header;
  header.frames = frames;
  header.fps = fps;
  header.visibility_codes = true;
  const auto add = [&](const Character& character, std::span<const skinning::SurfacePoint> points, int id) {
    // Vertex v of mesh m is number offset[m] + v across the meshes, the rest OBJ's order.
    std::vector<std::int64_t> offset(character.meshes.size() + 1, 0);
    for (std::size_t m = 0; m < character.meshes.size(); ++m) {
      offset[m + 1] = offset[m] + static_cast<std::int64_t>(character.meshes[m].positions.size());
    }
    if (offset.back() > INT32_MAX) throw std::invalid_argument("a character has more vertices than int32 numbers");
    for (const skinning::SurfacePoint& point : points) {
      if (point.mesh >= character.meshes.size()) throw std::invalid_argument("a sampled point names a mesh that is not there");
      const int owner = id >= 0 ? id : -1 - static_cast<int>(point.mesh);
      for (int c = 0; c < 3; ++c) {
        header.point_vertex_ids.push_back(static_cast<std::int32_t>(offset[point.mesh] + point.vertices[c]));
        header.point_barycentric.push_back(point.barycentric[c]);
      }
      header.point_actor_ids.push_back(owner);
    }
  };
  for (std::size_t a = 0; a < actors.size(); ++a) add(*actors[a].character, actors[a].points, static_cast<int>(a));
  if (props) add(props->character, props->points, -1);
  header.points = header.point_actor_ids.size();
  return header;
}

void TrajectorySink::write(const FrameChunk& chunk) {
  const CameraChunk& c = chunk.cameras[camera_];
  writer_.append_frames(chunk.count, chunk.trajs_3d, c.trajs_2d, c.valids, c.visibs, c.intrinsics, c.extrinsics,
                        c.visibility_codes);
}

void PointCacheSink::write(const FrameChunk& chunk) { writer_.append_frames(chunk.count, chunk.actor_vertices[actor_]); }

StreamSummary run_streams(std::span<const StreamActor> actors, const StreamProps* props,
                          std::span<const StreamCamera> cameras, std::span<StreamSink* const> sinks,
                          const StreamOptions& options) {
  const auto start = Clock::now();
  if (actors.empty()) throw std::invalid_argument("a shot needs at least one actor");
  for (const StreamActor& actor : actors) require_clip_on(actor);
  const int frames = actors[0].clip->frame_count();
  for (const StreamActor& actor : actors) {
    if (actor.clip->frame_count() != frames) {
      throw std::invalid_argument("actor '" + actor.name + "' has " + std::to_string(actor.clip->frame_count()) +
                                  " frames, actor '" + actors[0].name + "' " + std::to_string(frames));
    }
  }
  for (const StreamCamera& camera : cameras) {
    camera.path->validate();
    if (camera.path->frame_count() != frames) {
      throw std::invalid_argument("camera '" + camera.name + "' has " + std::to_string(camera.path->frame_count()) +
                                  " frames, the shot " + std::to_string(frames));
    }
    if (camera.own_actor >= static_cast<int>(actors.size())) {
      throw std::invalid_argument("camera '" + camera.name + "' rides on actor " + std::to_string(camera.own_actor) +
                                  ", the shot has " + std::to_string(actors.size()));
    }
  }
  const bool tracking = std::any_of(cameras.begin(), cameras.end(), [](const StreamCamera& c) { return c.tracks; });

  // Actors' skinners; the numbering of points (actor after actor, then the props').
  std::vector<ActorState> state(actors.size());
  std::size_t n = 0;
  std::size_t mesh_floats_per_frame = 0;
  for (std::size_t a = 0; a < actors.size(); ++a) {
    const StreamActor& actor = actors[a];
    ActorState& s = state[a];
    s.first_point = n;
    s.vertices = vertex_count(*actor.character);
    if (actor.vertex_animation) {
      require_vertex_animation(actor);
      s.animated = actor.vertex_animation;
      if (tracking) n += actor.points.size();
    } else if (tracking && !actor.points.empty()) {
      s.points = std::make_unique<skinning::SurfacePointSkinner>(*actor.character, actor.points, options.threads);
      n += actor.points.size();
    }
    if ((tracking || actor.mesh_every_frame) && s.vertices > 0) {
      if (!s.animated) {
        const std::vector<skinning::MeshVertex> vertices = skinning::all_vertices(*actor.character);
        s.mesh = std::make_unique<skinning::LinearBlendSkinner>(*actor.character, vertices,
                                                                skinning::SkinningOptions{options.threads, false});
      }
      s.has_mesh = true;
      s.triangles = all_triangles(*actor.character);
      mesh_floats_per_frame += s.vertices * 3;
      if (actor.head_joint >= 0) {
        const std::array<int, 1> head{actor.head_joint};
        const skinning::JointSet skull = skinning::JointSet::subtrees(actor.character->skeleton, head);
        std::vector<char> in_head;
        for (const CharacterMesh& mesh : actor.character->meshes) {
          for (std::size_t v = 0; v < mesh.positions.size(); ++v) in_head.push_back(skull.contains(skinning::dominant_joint(mesh, v)));
        }
        for (std::size_t t = 0; t < s.triangles.size(); t += 3) {
          if (in_head[s.triangles[t]] || in_head[s.triangles[t + 1]] || in_head[s.triangles[t + 2]]) continue;
          s.triangles_without_head.insert(s.triangles_without_head.end(), s.triangles.begin() + t, s.triangles.begin() + t + 3);
        }
      }
    }
    s.margin = 0.25 * actor.character->rest_bounds().sizes().z();
  }
  // Props: static, so their vertices and points are placed once.
  std::vector<float> prop_vertices;
  std::vector<std::uint32_t> prop_triangles;
  std::vector<std::uint32_t> prop_of_triangle;  // mesh (prop) index per prop triangle
  std::vector<float> prop_points;
  std::vector<Eigen::AlignedBox3d> prop_boxes;  // per prop; empty for a flat one
  if (props) {
    for (std::size_t m = 0; m < props->character.meshes.size(); ++m) {
      const CharacterMesh& mesh = props->character.meshes[m];
      Eigen::AlignedBox3d box;
      for (const Eigen::Vector3f& p : mesh.positions) box.extend(p.cast<double>());
      prop_boxes.push_back(box);
      for (std::size_t t = 0; t < mesh.triangles.size() / 3; ++t) prop_of_triangle.push_back(static_cast<std::uint32_t>(m));
      for (const Eigen::Vector3f& p : mesh.positions) prop_vertices.insert(prop_vertices.end(), {p.x(), p.y(), p.z()});
    }
    prop_triangles = all_triangles(props->character);
    if (tracking) {
      for (const skinning::SurfacePoint& point : props->points) {
        const CharacterMesh& mesh = props->character.meshes.at(point.mesh);
        Eigen::Vector3f p = Eigen::Vector3f::Zero();
        for (int c = 0; c < 3; ++c) p += point.barycentric[c] * mesh.positions.at(point.vertices[c]);
        prop_points.insert(prop_points.end(), {p.x(), p.y(), p.z()});
      }
    }
  }
  const std::size_t prop_first_point = n;
  n += prop_points.size() / 3;
  const std::size_t tracking_cameras =
      static_cast<std::size_t>(std::count_if(cameras.begin(), cameras.end(), [](const StreamCamera& c) { return c.tracks; }));
  const int chunk_size =
      chunk_frames(options, n * 3 * sizeof(float) + tracking_cameras * n * (2 * sizeof(float) + 3) + mesh_floats_per_frame * 4);
  const std::size_t chunk = static_cast<std::size_t>(chunk_size);

  std::vector<float> trajs_3d(tracking ? chunk * n * 3 : 0);
  // One camera's buffers for a whole chunk.
  struct CameraFrames {
    std::vector<float> trajs_2d;
    std::vector<std::uint8_t> valids, visibs, visibility_codes;
    std::vector<float> intrinsics, extrinsics;
    std::vector<PreviewFrame> previews;
    // Trails for the contact sheet: the uv of every kTrailStride-th point over the last
    // kTrailFrames frames, a ring; NaN where the point was not valid.
    std::vector<std::vector<float>> trail;
    std::size_t trail_next = 0;
    std::vector<int> preview_frames;
  };
  constexpr std::size_t kTrailFrames = 15, kTrailStride = 8;
  std::vector<CameraFrames> camera_frames(cameras.size());
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    if (!cameras[c].tracks) continue;
    CameraFrames& out = camera_frames[c];
    out.trajs_2d.resize(chunk * n * 2);
    out.valids.resize(chunk * n);
    out.visibs.resize(chunk * n);
    out.visibility_codes.resize(chunk * n);
    out.intrinsics.resize(chunk * 9);
    out.extrinsics.resize(chunk * 16);
    if (cameras[c].preview) {
      out.preview_frames = preview_frames(frames);
      out.trail.assign(kTrailFrames, std::vector<float>(2 * ((n + kTrailStride - 1) / kTrailStride), NAN));
    }
  }
  std::vector<std::optional<DepthBuffer>> depth(cameras.size());
  // Per camera: the occluders drawn last frame (which actors), to rebuild the triangle list only
  // when that set changes (the buffer rejoins edges whenever its triangles change).
  std::vector<std::vector<char>> drawn(cameras.size());
  std::vector<char> built(cameras.size(), 0);
  std::vector<std::vector<std::uint32_t>> camera_triangles(cameras.size());
  // Per camera: triangle ranges of the list, [end, owner): owner >= 0 an actor, -1 the props.
  std::vector<std::vector<std::pair<std::uint32_t, int>>> owner_ranges(cameras.size());
  std::vector<float> occluder_positions;

  StreamSummary summary;
  summary.frames = frames;
  summary.points = n;
  summary.actor_mesh_frames.assign(actors.size(), 0);
  summary.cameras.resize(cameras.size());
  std::vector<std::array<std::size_t, 5>> code_counts(cameras.size(), std::array<std::size_t, 5>{});
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    summary.cameras[c].name = cameras[c].name;
    summary.cameras[c].actor_frames_culled.assign(actors.size(), 0);
  }

  for (StreamSink* sink : sinks) sink->begin();
  skinning::WorkerPool pool(options.threads);
  std::vector<std::array<std::size_t, 5>> block_counts;
  // sees[(f C + c) A + a]: camera c may see actor a in frame f of the chunk.
  std::vector<char> sees;
  for (int first = 0; first < frames; first += chunk_size) {
    const int count = std::min(chunk_size, frames - first);
    sees.assign(std::size_t(count) * cameras.size() * actors.size(), 0);
    for (std::size_t a = 0; a < actors.size(); ++a) {
      ActorState& s = state[a];
      const std::size_t joints = actors[a].clip->joint_count();
      s.world.resize(count * joints);
      s.boxes.assign(count, Eigen::AlignedBox3d());
      s.point_boxes.assign(count, Eigen::AlignedBox3d());
      if (s.animated && s.has_mesh) s.mesh_positions.resize(count * s.vertices * 3);
      for (int f = 0; f < count; ++f) {
        const std::span<RigidTransform<double>> world = std::span(s.world).subspan(f * joints, joints);
        actors[a].clip->world_pose(first + f, world);
        for (const RigidTransform<double>& joint : world) s.boxes[f].extend(joint.translation);
        if (s.animated && s.has_mesh) {
          // World vertex = W(joint 0) local vertex; the box is the vertices'.
          const Eigen::Matrix3f rotation = world[0].rotation.cast<float>();
          const Eigen::Vector3f translation = world[0].translation.cast<float>();
          const std::span<const float> local = s.animated->frame(first + f);
          float* out = s.mesh_positions.data() + f * s.vertices * 3;
          for (std::size_t v = 0; v < s.vertices; ++v) {
            const Eigen::Vector3f p = rotation * Eigen::Vector3f(local[3 * v], local[3 * v + 1], local[3 * v + 2]) + translation;
            out[3 * v] = p.x();
            out[3 * v + 1] = p.y();
            out[3 * v + 2] = p.z();
            s.boxes[f].extend(p.cast<double>());
          }
        }
        s.point_boxes[f] = s.boxes[f];
        s.boxes[f].min().array() -= s.margin;
        s.boxes[f].max().array() += s.margin;
      }
      if (s.animated && tracking && !actors[a].points.empty()) {
        // Points interpolate their triangle's corners, as SurfacePointSkinner does, in float32.
        const std::vector<skinning::SurfacePoint>& points = actors[a].points;
        for (int f = 0; f < count; ++f) {
          const float* vertices = s.mesh_positions.data() + f * s.vertices * 3;
          float* to = trajs_3d.data() + (f * n + s.first_point) * 3;
          Eigen::AlignedBox3d box;
          for (std::size_t i = 0; i < points.size(); ++i) {
            Eigen::Vector3f p = Eigen::Vector3f::Zero();
            for (int c = 0; c < 3; ++c) p += points[i].barycentric[c] * Eigen::Vector3f::Map(vertices + 3 * points[i].vertices[c]);
            to[3 * i] = p.x();
            to[3 * i + 1] = p.y();
            to[3 * i + 2] = p.z();
            box.extend(p.cast<double>());
          }
          s.point_boxes[f] = box;
        }
      }
      if (s.points) {
        const std::size_t np = s.points->point_count();
        s.point_positions.resize(count * np * 3);
        s.points->skin_frames(count, s.world, s.point_positions);
        for (int f = 0; f < count; ++f) {
          Eigen::AlignedBox3d box;
          const float* p = s.point_positions.data() + f * np * 3;
          for (std::size_t i = 0; i < np; ++i) box.extend(Eigen::Vector3d(p[3 * i], p[3 * i + 1], p[3 * i + 2]));
          s.point_boxes[f] = box;
          std::copy(p, p + np * 3, trajs_3d.begin() + (f * n + s.first_point) * 3);
        }
      }
    }
    for (int f = 0; f < count && !prop_points.empty(); ++f) {
      std::copy(prop_points.begin(), prop_points.end(), trajs_3d.begin() + (f * n + prop_first_point) * 3);
    }

    // Which camera may see which actor, frame by frame; each actor's mesh is skinned once a frame
    // if some camera may, or every frame for a point cache.
    for (std::size_t a = 0; a < actors.size(); ++a) {
      ActorState& s = state[a];
      if (!s.has_mesh) continue;
      const std::size_t v3 = s.vertices * 3;
      s.mesh_positions.resize(count * v3);
      const std::size_t joints = actors[a].clip->joint_count();
      for (int f = 0; f < count; ++f) {
        bool needed = actors[a].mesh_every_frame;
        for (std::size_t c = 0; c < cameras.size(); ++c) {
          if (!cameras[c].tracks) continue;
          const std::size_t frame = first + f;
          const bool in_view =
              !box_out_of_view(s.boxes[f], cameras[c].path->poses[frame], cameras[c].path->intrinsics[frame]);
          sees[(f * cameras.size() + c) * actors.size() + a] = in_view;
          if (!in_view) ++summary.cameras[c].actor_frames_culled[a];
          needed |= in_view;
        }
        if (!needed) continue;
        if (s.mesh) s.mesh->skin_frames(1, std::span(s.world).subspan(f * joints, joints), std::span(s.mesh_positions).subspan(f * v3, v3));
        ++summary.actor_mesh_frames[a];
      }
    }

    for (std::size_t c = 0; c < cameras.size(); ++c) {
      if (!cameras[c].tracks) continue;
      const StreamCamera& camera = cameras[c];
      CameraFrames& out = camera_frames[c];
      for (int f = 0; f < count; ++f) {
        const std::size_t frame = first + f;
        const CameraPose& pose = camera.path->poses[frame];
        const PinholeIntrinsics& k = camera.path->intrinsics[frame];
        if (options.reject_camera_inside) {
          const Eigen::Vector3d centre = pose.centre();
          for (std::size_t a = 0; a < actors.size(); ++a) {
            if (static_cast<int>(a) != camera.own_actor && strictly_inside(state[a].point_boxes[f], centre)) {
              throw std::invalid_argument("camera '" + camera.name + "' is inside actor '" + actors[a].name + "' at frame " +
                                          std::to_string(frame) + ": its centre lies within the box of the actor's " +
                                          (state[a].points || (state[a].animated && !actors[a].points.empty()) ? "tracked points" : "joints"));
            }
          }
          for (std::size_t p = 0; p < prop_boxes.size(); ++p) {
            if (strictly_inside(prop_boxes[p], centre)) {
              throw std::invalid_argument("camera '" + camera.name + "' is inside prop '" + props->names[p] +
                                          "' at frame " + std::to_string(frame));
            }
          }
        }
        // The occluders this camera may see this frame: the props, then the actors in view.
        std::vector<char> now(actors.size());
        for (std::size_t a = 0; a < actors.size(); ++a) {
          now[a] = state[a].has_mesh && sees[(f * cameras.size() + c) * actors.size() + a];
        }
        occluder_positions.assign(prop_vertices.begin(), prop_vertices.end());
        for (std::size_t a = 0; a < actors.size(); ++a) {
          if (!now[a]) continue;
          const std::size_t v3 = state[a].vertices * 3;
          const float* p = state[a].mesh_positions.data() + f * v3;
          occluder_positions.insert(occluder_positions.end(), p, p + v3);
        }
        if (!built[c] || now != drawn[c]) {
          built[c] = 1;
          drawn[c] = now;
          std::vector<std::uint32_t>& triangles = camera_triangles[c];
          triangles = prop_triangles;
          owner_ranges[c].clear();
          owner_ranges[c].push_back({static_cast<std::uint32_t>(triangles.size() / 3), -1});
          std::uint32_t offset = static_cast<std::uint32_t>(prop_vertices.size() / 3);
          for (std::size_t a = 0; a < actors.size(); ++a) {
            if (!now[a]) continue;
            const bool own = static_cast<int>(a) == camera.own_actor && actors[a].head_joint >= 0;
            for (const std::uint32_t corner : own ? state[a].triangles_without_head : state[a].triangles) {
              triangles.push_back(offset + corner);
            }
            offset += static_cast<std::uint32_t>(state[a].vertices);
            owner_ranges[c].push_back({static_cast<std::uint32_t>(triangles.size() / 3), static_cast<int>(a)});
          }
        }
        if (!depth[c] || depth[c]->width() != k.width || depth[c]->height() != k.height) depth[c].emplace(k.width, k.height);
        depth[c]->render(pose, k, occluder_positions, camera_triangles[c]);

        const float* p = trajs_3d.data() + f * n * 3;
        float* uv = out.trajs_2d.data() + f * n * 2;
        std::uint8_t* valid = out.valids.data() + f * n;
        std::uint8_t* visible = out.visibs.data() + f * n;
        std::uint8_t* code = out.visibility_codes.data() + f * n;
        // Points in blocks over the pool's threads; each block writes only its own range and
        // counts its codes apart, so the result does not depend on the thread count.
        const DepthBuffer& buffer = *depth[c];
        const auto& ranges = owner_ranges[c];
        const std::size_t blocks = (n + kPointBlock - 1) / kPointBlock;
        block_counts.assign(blocks, std::array<std::size_t, 5>{});
        pool.run(blocks, [&](std::size_t b) {
          std::array<std::size_t, 5>& counts = block_counts[b];
          for (std::size_t i = b * kPointBlock; i < std::min(n, (b + 1) * kPointBlock); ++i) {
            const Eigen::Vector3d point(p[3 * i], p[3 * i + 1], p[3 * i + 2]);
            const PixelProjection pixel = project(pose, k, point);
            uv[2 * i] = static_cast<float>(pixel.u);
            uv[2 * i + 1] = static_cast<float>(pixel.v);
            valid[i] = pixel.valid;
            if (!pixel.valid) {
              visible[i] = 0;
              code[i] = pixel.depth > 0 ? io::kOutsideImage : io::kBehindCamera;
            } else {
              const PointVisibility seen = buffer.classify(pose.to_camera(point));
              visible[i] = seen.visible();
              if (seen.visible()) {
                code[i] = io::kVisible;
              } else if (seen.reason == PointVisibility::Reason::occluded) {
                const auto owner = std::upper_bound(ranges.begin(), ranges.end(), seen.occluder,
                                                    [](std::uint32_t t, const auto& range) { return t < range.first; });
                code[i] = owner != ranges.end() && owner->second >= 0 ? io::kOccludedByActor : io::kOccludedByProp;
              } else {
                // The projection says valid, the buffer's own test says not: a point on the image's
                // edge up to rounding. Counted as outside, and not valid, so the flags agree.
                valid[i] = 0;
                code[i] = io::kOutsideImage;
              }
            }
            ++counts[code[i]];
          }
        });
        for (const auto& counts : block_counts) {
          for (int k5 = 0; k5 < 5; ++k5) code_counts[c][k5] += counts[k5];
        }
        if (camera.preview) {
          std::vector<float>& trail = out.trail[out.trail_next];
          for (std::size_t i = 0; i < n; i += kTrailStride) {
            trail[2 * (i / kTrailStride)] = valid[i] ? uv[2 * i] : NAN;
            trail[2 * (i / kTrailStride) + 1] = valid[i] ? uv[2 * i + 1] : NAN;
          }
          out.trail_next = (out.trail_next + 1) % kTrailFrames;
          if (std::binary_search(out.preview_frames.begin(), out.preview_frames.end(), static_cast<int>(frame))) {
            PreviewFrame image = draw_preview(
                buffer,
                [&](std::uint32_t t) {
                  const auto owner = std::upper_bound(ranges.begin(), ranges.end(), t,
                                                      [](std::uint32_t id, const auto& range) { return id < range.first; });
                  return owner != ranges.end() ? owner->second : -1;
                },
                static_cast<int>(frame));
            std::vector<std::vector<float>> oldest_first;
            for (std::size_t k2 = 0; k2 < kTrailFrames; ++k2) oldest_first.push_back(out.trail[(out.trail_next + k2) % kTrailFrames]);
            draw_points(image, std::span(uv, n * 2), std::span(code, n), oldest_first);
            out.previews.push_back(std::move(image));
          }
        }
        const Eigen::Matrix3d kk = k.matrix();
        const Eigen::Matrix4d e = pose.extrinsics();
        for (int r = 0; r < 3; ++r) {
          for (int col = 0; col < 3; ++col) out.intrinsics[f * 9 + r * 3 + col] = static_cast<float>(kk(r, col));
        }
        for (int r = 0; r < 4; ++r) {
          for (int col = 0; col < 4; ++col) out.extrinsics[f * 16 + r * 4 + col] = static_cast<float>(e(r, col));
        }
      }
    }

    // The sinks see spans cut to this chunk's frames.
    std::vector<CameraChunk> cut(cameras.size());
    for (std::size_t c = 0; c < cameras.size(); ++c) {
      if (!cameras[c].tracks) continue;
      const CameraFrames& full = camera_frames[c];
      cut[c] = CameraChunk{std::span(full.trajs_2d).first(count * n * 2), std::span(full.valids).first(count * n),
                           std::span(full.visibs).first(count * n), std::span(full.visibility_codes).first(count * n),
                           std::span(full.intrinsics).first(count * 9), std::span(full.extrinsics).first(count * 16),
                           full.previews};
    }
    std::vector<std::span<const float>> actor_vertices(actors.size());
    for (std::size_t a = 0; a < actors.size(); ++a) {
      if (actors[a].mesh_every_frame) actor_vertices[a] = std::span(state[a].mesh_positions).first(count * state[a].vertices * 3);
    }
    FrameChunk view;
    view.first = first;
    view.count = count;
    view.trajs_3d = std::span(trajs_3d).first(tracking ? count * n * 3 : 0);
    view.actor_vertices = actor_vertices;
    view.cameras = cut;
    for (StreamSink* sink : sinks) sink->write(view);
    for (CameraFrames& out : camera_frames) out.previews.clear();
    if (options.on_chunk) options.on_chunk(first + count, frames);
  }
  for (StreamSink* sink : sinks) sink->finish();

  const double point_frames = static_cast<double>(frames) * static_cast<double>(n);
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    if (!cameras[c].tracks || point_frames == 0) continue;
    const auto& counts = code_counts[c];
    CameraStreamSummary& s = summary.cameras[c];
    s.visible_fraction = counts[io::kVisible] / point_frames;
    s.occluded_by_actor_fraction = counts[io::kOccludedByActor] / point_frames;
    s.occluded_by_prop_fraction = counts[io::kOccludedByProp] / point_frames;
    s.valid_fraction = s.visible_fraction + s.occluded_by_actor_fraction + s.occluded_by_prop_fraction;
  }
  summary.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return summary;
}

}  // namespace odyssey::scene
