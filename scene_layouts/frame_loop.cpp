#include "scene_layouts/frame_loop.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>

namespace odyssey::scene {
namespace {

using Clock = std::chrono::steady_clock;

// Points classified per task of the worker pool: about a millisecond of work.
constexpr std::size_t kPointBlock = 2048;

void require_clip_on(const StreamActor& actor) {
  const Skeleton& ours = actor.character->skeleton;
  const std::string who = "actor '" + actor.name + "': ";
  if (actor.clip == nullptr || actor.clip->joint_count() == 0) throw std::invalid_argument(who + "no clip");
  const Skeleton& theirs = actor.clip->skeleton();
  const TimedClip& clip = *actor.clip;
  if (clip.joint_count() != ours.joint_count()) {
    throw std::invalid_argument(who + "the clip has " + std::to_string(clip.joint_count()) + " joints, the character " +
                                std::to_string(ours.joint_count()));
  }
  for (int j = 0; j < ours.joint_count(); ++j) {
    if (theirs.name(j) != ours.name(j) || theirs.parent(j) != ours.parent(j)) {
      throw std::invalid_argument(who + "the clip's joint " + std::to_string(j) + " (" + theirs.name(j) +
                                  ") is not the character's (" + ours.name(j) + ")");
    }
  }
  if (clip.frame_count() < 1) throw std::invalid_argument(who + "the clip has no frames");
}

void require_vertex_animation(const StreamActor& actor) {
  const std::string who = "actor '" + actor.name + "': ";
  if (actor.character->meshes.size() != 1 || actor.clip->vertex_count() != actor.character->meshes[0].positions.size()) {
    throw std::invalid_argument(who + "a vertex animation needs one mesh of as many vertices as it animates");
  }
}

// Frames per chunk: the option, or as many frames of `bytes_per_frame` output as fit in 16 MiB.
int frames_per_chunk(const StreamOptions& options, std::size_t bytes_per_frame) {
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

// Per actor, what the loop holds across chunks.
struct FrameLoop::ActorState {
  std::unique_ptr<skinning::SurfacePointSkinner> points;
  std::unique_ptr<skinning::LinearBlendSkinner> mesh;
  bool animated = false;  // a vertex-animated actor: no skinners
  bool has_mesh = false;  // mesh_positions are filled (skinned or animated)
  std::vector<std::uint32_t> triangles;  // numbered within the actor's vertices
  std::vector<std::uint32_t> triangles_without_head;  // for an ego camera riding on it
  std::size_t vertices = 0;
  std::size_t first_point = 0;
  double margin = 0;                     // culling box growth, 0.25 rest height
  KinematicData<double> pose;                  // one frame's
  std::vector<float> local_vertices;           // a vertex-animated actor's, one frame's, V x 3
  std::vector<RigidTransform<double>> world;   // C x J
  std::vector<float> point_positions;          // C x n x 3
  std::vector<float> mesh_positions;           // C x V x 3 (frames not needed are left stale)
  std::vector<Eigen::AlignedBox3d> boxes;      // per frame of the chunk: culling box
  std::vector<Eigen::AlignedBox3d> point_boxes;  // per frame: the inside test's box
};

// Per camera, its buffers for a whole chunk and what it drew last.
struct FrameLoop::CameraState {
  std::vector<float> trajs_2d;
  std::vector<std::uint8_t> valids, visibs, visibility_codes;
  std::vector<float> intrinsics, extrinsics;
  std::optional<DepthBuffer> depth;
  // The occluders drawn last frame (which actors), to rebuild the triangle list only when that set
  // changes (the buffer rejoins edges whenever its triangles change).
  std::vector<char> drawn;
  bool built = false;
  std::vector<std::uint32_t> triangles;
  // Triangle ranges of the list, [end, owner): owner >= 0 an actor, -1 the props.
  std::vector<std::pair<std::uint32_t, int>> owner_ranges;
  std::array<std::size_t, 5> code_counts{};
  std::vector<std::size_t> actor_visible;  // per actor: its visible point-frames
  std::vector<long> actor_frames_culled;
};

int CameraFrame::owner(std::uint32_t triangle) const {
  const auto range = std::upper_bound(owner_ranges.begin(), owner_ranges.end(), triangle,
                                      [](std::uint32_t t, const auto& r) { return t < r.first; });
  return range != owner_ranges.end() ? range->second : kNoOwner;
}

FrameLoop::FrameLoop(std::span<const StreamActor> actors, const StreamProps* props, std::span<const StreamCamera> cameras,
                     const StreamOptions& options)
    : actors_(actors), props_(props), cameras_(cameras), options_(options), pool_(std::max(options.threads, 1)) {
  if (actors.empty()) throw std::invalid_argument("a shot needs at least one actor");
  for (const StreamActor& actor : actors) require_clip_on(actor);
  frames_ = actors[0].clip->frame_count();
  for (const StreamActor& actor : actors) {
    if (actor.clip->frame_count() != frames_) {
      throw std::invalid_argument("actor '" + actor.name + "' has " + std::to_string(actor.clip->frame_count()) +
                                  " frames, actor '" + actors[0].name + "' " + std::to_string(frames_));
    }
  }
  for (const StreamCamera& camera : cameras) {
    camera.path->validate();
    if (camera.path->frame_count() != frames_) {
      throw std::invalid_argument("camera '" + camera.name + "' has " + std::to_string(camera.path->frame_count()) +
                                  " frames, the shot " + std::to_string(frames_));
    }
    if (camera.own_actor >= static_cast<int>(actors.size())) {
      throw std::invalid_argument("camera '" + camera.name + "' rides on actor " + std::to_string(camera.own_actor) +
                                  ", the shot has " + std::to_string(actors.size()));
    }
  }
  tracking_ = std::any_of(cameras.begin(), cameras.end(), [](const StreamCamera& c) { return c.tracks; });

  // Actors' skinners; the numbering of points (actor after actor, then the props').
  actors_state_.resize(actors.size());
  std::size_t mesh_floats_per_frame = 0;
  for (std::size_t a = 0; a < actors.size(); ++a) {
    const StreamActor& actor = actors[a];
    ActorState& s = actors_state_[a];
    s.first_point = n_;
    s.vertices = vertex_count(*actor.character);
    s.pose = KinematicData<double>(actor.clip->skeleton().kinematics());
    if (actor.clip->vertex_animated()) {
      require_vertex_animation(actor);
      s.animated = true;
      if (tracking_) n_ += actor.points.size();
    } else if (tracking_ && !actor.points.empty()) {
      s.points = std::make_unique<skinning::SurfacePointSkinner>(*actor.character, actor.points, options.threads);
      n_ += actor.points.size();
    }
    if ((tracking_ || actor.mesh_every_frame) && s.vertices > 0) {
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
  // Props: their vertices and points as placed, once; moving props are carried from there.
  if (props) {
    const std::size_t prop_count = props->character.meshes.size();
    if (!props->motion.empty() && props->motion.size() != static_cast<std::size_t>(frames_) * prop_count) {
      throw std::invalid_argument("the props' motion has " + std::to_string(props->motion.size()) + " transforms, " +
                                  std::to_string(frames_) + " frames of " + std::to_string(prop_count) + " props need " +
                                  std::to_string(static_cast<std::size_t>(frames_) * prop_count));
    }
    prop_moves_.assign(prop_count, 0);
    for (std::size_t i = 0; i < props->motion.size(); ++i) {
      const RigidTransform<double>& m = props->motion[i];
      if (!m.rotation.allFinite() || !m.translation.allFinite()) {
        throw std::invalid_argument("prop '" + props->names.at(i % prop_count) + "': its motion is not finite at frame " +
                                    std::to_string(i / prop_count));
      }
      if (!m.rotation.isIdentity(0) || !m.translation.isZero(0)) prop_moves_[i % prop_count] = 1;
    }
    props_move_ = std::any_of(prop_moves_.begin(), prop_moves_.end(), [](char m) { return m != 0; });
    std::size_t first_vertex = 0;
    for (std::size_t m = 0; m < prop_count; ++m) {
      const CharacterMesh& mesh = props->character.meshes[m];
      prop_first_vertex_.push_back(first_vertex);
      first_vertex += mesh.positions.size();
      Eigen::AlignedBox3d box;
      for (const Eigen::Vector3f& p : mesh.positions) box.extend(p.cast<double>());
      prop_boxes_.push_back(box);
      for (const Eigen::Vector3f& p : mesh.positions) prop_vertices_.insert(prop_vertices_.end(), {p.x(), p.y(), p.z()});
    }
    prop_triangles_ = all_triangles(props->character);
    std::uint32_t end = 0;
    for (const CharacterMesh& mesh : props->character.meshes) {
      end += static_cast<std::uint32_t>(mesh.triangles.size() / 3);
      prop_triangle_ends_.push_back(end);
    }
    if (tracking_) {
      for (const skinning::SurfacePoint& point : props->points) {
        const CharacterMesh& mesh = props->character.meshes.at(point.mesh);
        Eigen::Vector3f p = Eigen::Vector3f::Zero();
        for (int c = 0; c < 3; ++c) p += point.barycentric[c] * mesh.positions.at(point.vertices[c]);
        prop_points_.insert(prop_points_.end(), {p.x(), p.y(), p.z()});
        prop_point_owner_.push_back(point.mesh);
      }
    }
  }
  prop_first_point_ = n_;
  n_ += prop_points_.size() / 3;
  const std::size_t tracking_cameras =
      static_cast<std::size_t>(std::count_if(cameras.begin(), cameras.end(), [](const StreamCamera& c) { return c.tracks; }));
  chunk_frames_ = frames_per_chunk(options, n_ * 3 * sizeof(float) + tracking_cameras * n_ * (2 * sizeof(float) + 3) +
                                            mesh_floats_per_frame * 4);
  const std::size_t chunk = static_cast<std::size_t>(chunk_frames_);

  trajs_3d_.resize(tracking_ ? chunk * n_ * 3 : 0);
  cameras_state_.resize(cameras.size());
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    CameraState& out = cameras_state_[c];
    out.actor_frames_culled.assign(actors.size(), 0);
    out.actor_visible.assign(actors.size(), 0);
    if (!cameras[c].tracks) continue;
    out.trajs_2d.resize(chunk * n_ * 2);
    out.valids.resize(chunk * n_);
    out.visibs.resize(chunk * n_);
    out.visibility_codes.resize(chunk * n_);
    out.intrinsics.resize(chunk * 9);
    out.extrinsics.resize(chunk * 16);
  }
  actor_mesh_frames_.assign(actors.size(), 0);
}

FrameLoop::~FrameLoop() = default;

void FrameLoop::pose(int first, int count) {
  if (first < 0 || count < 1 || count > chunk_frames_ || first + count > frames_) {
    throw std::invalid_argument("frames " + std::to_string(first) + " to " + std::to_string(first + count - 1) +
                                " are not a chunk of the shot's " + std::to_string(frames_) + " (at most " +
                                std::to_string(chunk_frames_) + " a chunk)");
  }
  first_ = first;
  count_ = count;
  for (std::size_t a = 0; a < actors_.size(); ++a) {
    ActorState& s = actors_state_[a];
    const std::size_t joints = actors_[a].clip->joint_count();
    s.world.resize(count * joints);
    s.boxes.assign(count, Eigen::AlignedBox3d());
    s.point_boxes.assign(count, Eigen::AlignedBox3d());
    if (s.animated && s.has_mesh) s.mesh_positions.resize(count * s.vertices * 3);
    for (int f = 0; f < count; ++f) {
      const std::span<RigidTransform<double>> world = std::span(s.world).subspan(f * joints, joints);
      actors_[a].clip->world_pose(first + f, s.pose);
      std::copy(s.pose.world.begin(), s.pose.world.end(), world.begin());
      for (const RigidTransform<double>& joint : world) s.boxes[f].extend(joint.translation);
      if (s.animated && s.has_mesh) {
        // World vertex = W(joint 0) local vertex; the box is the vertices'.
        const Eigen::Matrix3f rotation = world[0].rotation.cast<float>();
        const Eigen::Vector3f translation = world[0].translation.cast<float>();
        s.local_vertices.resize(s.vertices * 3);
        actors_[a].clip->local_vertices(first + f, s.local_vertices);
        const std::span<const float> local = s.local_vertices;
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
  }
  if (moving_props() || (options_.prop_vertices && props_)) {
    // Every prop vertex of every frame of the chunk: a moving prop's carried, x_f = M x_0 in
    // double, then stored as float32 like the rest.
    const std::size_t prop_count = prop_boxes_.size(), floats = prop_vertices_.size();
    prop_frame_vertices_.resize(count * floats);
    prop_frame_boxes_.assign(count * prop_count, Eigen::AlignedBox3d());
    for (int f = 0; f < count; ++f) {
      float* out = prop_frame_vertices_.data() + f * floats;
      std::copy(prop_vertices_.begin(), prop_vertices_.end(), out);
      for (std::size_t k = 0; k < prop_count; ++k) {
        Eigen::AlignedBox3d& box = prop_frame_boxes_[f * prop_count + k];
        if (!prop_moves_[k]) {
          box = prop_boxes_[k];
          continue;
        }
        const RigidTransform<double>& m = props_->motion[(first + f) * prop_count + k];
        const std::size_t end = k + 1 < prop_count ? prop_first_vertex_[k + 1] : floats / 3;
        for (std::size_t v = prop_first_vertex_[k]; v < end; ++v) {
          const Eigen::Vector3d p = m * Eigen::Vector3d(out[3 * v], out[3 * v + 1], out[3 * v + 2]);
          out[3 * v] = static_cast<float>(p.x());
          out[3 * v + 1] = static_cast<float>(p.y());
          out[3 * v + 2] = static_cast<float>(p.z());
          box.extend(p);
        }
      }
    }
  }
}

bool FrameLoop::moving_props() const { return props_move_; }

void FrameLoop::skin() {
  const int count = count_;
  const std::size_t n = n_;
  for (std::size_t a = 0; a < actors_.size(); ++a) {
    ActorState& s = actors_state_[a];
    if (s.animated && tracking_ && !actors_[a].points.empty()) {
      // Points interpolate their triangle's corners, as SurfacePointSkinner does, in float32.
      const std::span<const skinning::SurfacePoint> points = actors_[a].points;
      for (int f = 0; f < count; ++f) {
        const float* vertices = s.mesh_positions.data() + f * s.vertices * 3;
        float* to = trajs_3d_.data() + (f * n + s.first_point) * 3;
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
        std::copy(p, p + np * 3, trajs_3d_.begin() + (f * n + s.first_point) * 3);
      }
    }
  }
  for (int f = 0; f < count && !prop_points_.empty(); ++f) {
    float* to = trajs_3d_.data() + (f * n + prop_first_point_) * 3;
    std::copy(prop_points_.begin(), prop_points_.end(), to);
    if (!moving_props()) continue;
    const std::size_t prop_count = prop_boxes_.size();
    for (std::size_t i = 0; i < prop_point_owner_.size(); ++i) {
      const std::uint32_t k = prop_point_owner_[i];
      if (!prop_moves_[k]) continue;
      const Eigen::Vector3d p = props_->motion[(first_ + f) * prop_count + k] * Eigen::Vector3d(to[3 * i], to[3 * i + 1], to[3 * i + 2]);
      to[3 * i] = static_cast<float>(p.x());
      to[3 * i + 1] = static_cast<float>(p.y());
      to[3 * i + 2] = static_cast<float>(p.z());
    }
  }

  // Which camera may see which actor, frame by frame; each actor's mesh is skinned once a frame
  // if some camera may, or every frame for a point cache.
  const std::size_t cameras = cameras_.size(), actors = actors_.size();
  sees_.assign(std::size_t(count) * cameras * actors, 0);
  for (std::size_t a = 0; a < actors; ++a) {
    ActorState& s = actors_state_[a];
    if (!s.has_mesh) continue;
    const std::size_t v3 = s.vertices * 3;
    s.mesh_positions.resize(count * v3);
    const std::size_t joints = actors_[a].clip->joint_count();
    for (int f = 0; f < count; ++f) {
      bool needed = actors_[a].mesh_every_frame;
      for (std::size_t c = 0; c < cameras; ++c) {
        if (!cameras_[c].tracks) continue;
        const std::size_t frame = first_ + f;
        const bool in_view = !box_out_of_view(s.boxes[f], cameras_[c].path->poses[frame], cameras_[c].path->intrinsics[frame]);
        sees_[(f * cameras + c) * actors + a] = in_view;
        if (!in_view) ++cameras_state_[c].actor_frames_culled[a];
        needed |= in_view;
      }
      if (!needed) continue;
      if (s.mesh) s.mesh->skin_frames(1, std::span(s.world).subspan(f * joints, joints), std::span(s.mesh_positions).subspan(f * v3, v3));
      ++actor_mesh_frames_[a];
    }
  }
}

void FrameLoop::classify(std::size_t c, const CameraFrameCallback& on_frame) {
  if (c >= cameras_.size()) throw std::invalid_argument("no camera " + std::to_string(c));
  const StreamCamera& camera = cameras_[c];
  if (!camera.tracks) return;
  CameraState& out = cameras_state_[c];
  const std::size_t n = n_, actors = actors_.size(), cameras = cameras_.size();
  for (int f = 0; f < count_; ++f) {
    const std::size_t frame = first_ + f;
    const CameraPose& pose = camera.path->poses[frame];
    const PinholeIntrinsics& k = camera.path->intrinsics[frame];
    if (options_.reject_camera_inside) {
      const Eigen::Vector3d centre = pose.centre();
      for (std::size_t a = 0; a < actors; ++a) {
        const ActorState& s = actors_state_[a];
        if (static_cast<int>(a) != camera.own_actor && strictly_inside(s.point_boxes[f], centre)) {
          throw std::invalid_argument("camera '" + camera.name + "' is inside actor '" + actors_[a].name + "' at frame " +
                                      std::to_string(frame) + ": its centre lies within the box of the actor's " +
                                      (s.points || (s.animated && !actors_[a].points.empty()) ? "tracked points" : "joints"));
        }
      }
      for (std::size_t p = 0; p < prop_boxes_.size(); ++p) {
        if (strictly_inside(moving_props() ? prop_frame_boxes_[f * prop_boxes_.size() + p] : prop_boxes_[p], centre)) {
          throw std::invalid_argument("camera '" + camera.name + "' is inside prop '" + props_->names[p] + "' at frame " +
                                      std::to_string(frame));
        }
      }
    }
    // The occluders this camera may see this frame: the props, then the actors in view.
    std::vector<char> now(actors);
    for (std::size_t a = 0; a < actors; ++a) now[a] = actors_state_[a].has_mesh && sees_[(f * cameras + c) * actors + a];
    if (moving_props()) {
      const auto frame_vertices = prop_frame_vertices_.begin() + f * prop_vertices_.size();
      occluder_positions_.assign(frame_vertices, frame_vertices + prop_vertices_.size());
    } else {
      occluder_positions_.assign(prop_vertices_.begin(), prop_vertices_.end());
    }
    for (std::size_t a = 0; a < actors; ++a) {
      if (!now[a]) continue;
      const std::size_t v3 = actors_state_[a].vertices * 3;
      const float* p = actors_state_[a].mesh_positions.data() + f * v3;
      occluder_positions_.insert(occluder_positions_.end(), p, p + v3);
    }
    if (!out.built || now != out.drawn) {
      out.built = true;
      out.drawn = now;
      out.triangles = prop_triangles_;
      out.owner_ranges.clear();
      for (std::size_t p = 0; p < prop_triangle_ends_.size(); ++p) {
        out.owner_ranges.push_back({prop_triangle_ends_[p], -1 - static_cast<int>(p)});
      }
      std::uint32_t offset = static_cast<std::uint32_t>(prop_vertices_.size() / 3);
      for (std::size_t a = 0; a < actors; ++a) {
        if (!now[a]) continue;
        const bool own = static_cast<int>(a) == camera.own_actor && actors_[a].head_joint >= 0;
        for (const std::uint32_t corner : own ? actors_state_[a].triangles_without_head : actors_state_[a].triangles) {
          out.triangles.push_back(offset + corner);
        }
        offset += static_cast<std::uint32_t>(actors_state_[a].vertices);
        out.owner_ranges.push_back({static_cast<std::uint32_t>(out.triangles.size() / 3), static_cast<int>(a)});
      }
    }
    if (!out.depth || out.depth->width() != k.width || out.depth->height() != k.height) out.depth.emplace(k.width, k.height);
    out.depth->render(pose, k, occluder_positions_, out.triangles);

    const float* p = trajs_3d_.data() + f * n * 3;
    float* uv = out.trajs_2d.data() + f * n * 2;
    std::uint8_t* valid = out.valids.data() + f * n;
    std::uint8_t* visible = out.visibs.data() + f * n;
    std::uint8_t* code = out.visibility_codes.data() + f * n;
    // Points in blocks over the pool's threads; each block writes only its own range and counts
    // its codes apart, so the result does not depend on the thread count.
    const DepthBuffer& buffer = *out.depth;
    const auto& ranges = out.owner_ranges;
    const std::size_t blocks = (n + kPointBlock - 1) / kPointBlock;
    block_counts_.assign(blocks, std::array<std::size_t, 5>{});
    pool_.run(blocks, [&](std::size_t b) {
      std::array<std::size_t, 5>& counts = block_counts_[b];
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
    for (const auto& counts : block_counts_) {
      for (int k5 = 0; k5 < 5; ++k5) out.code_counts[k5] += counts[k5];
    }
    // Points are numbered actor after actor.
    for (std::size_t a = 0, first = 0; a < actors; first += actors_[a].points.size(), ++a) {
      out.actor_visible[a] += static_cast<std::size_t>(
          std::count(code + first, code + first + actors_[a].points.size(), static_cast<std::uint8_t>(io::kVisible)));
    }
    const Eigen::Matrix3d kk = k.matrix();
    const Eigen::Matrix4d e = pose.extrinsics();
    for (int r = 0; r < 3; ++r) {
      for (int col = 0; col < 3; ++col) out.intrinsics[f * 9 + r * 3 + col] = static_cast<float>(kk(r, col));
    }
    for (int r = 0; r < 4; ++r) {
      for (int col = 0; col < 4; ++col) out.extrinsics[f * 16 + r * 4 + col] = static_cast<float>(e(r, col));
    }
    if (on_frame) {
      on_frame(CameraFrame{static_cast<int>(c), static_cast<int>(frame), &pose, &buffer, ranges, std::span<const float>(uv, n * 2),
                           std::span<const std::uint8_t>(valid, n), std::span<const std::uint8_t>(code, n)});
    }
  }
}

FrameChunk FrameLoop::chunk() {
  const std::size_t count = static_cast<std::size_t>(count_), n = n_;
  camera_chunks_.assign(cameras_.size(), CameraChunk{});
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    if (!cameras_[c].tracks) continue;
    const CameraState& full = cameras_state_[c];
    camera_chunks_[c] = CameraChunk{std::span(full.trajs_2d).first(count * n * 2), std::span(full.valids).first(count * n),
                                    std::span(full.visibs).first(count * n), std::span(full.visibility_codes).first(count * n),
                                    std::span(full.intrinsics).first(count * 9), std::span(full.extrinsics).first(count * 16)};
  }
  actor_vertices_.assign(actors_.size(), {});
  for (std::size_t a = 0; a < actors_.size(); ++a) {
    if (actors_[a].mesh_every_frame) {
      actor_vertices_[a] = std::span(actors_state_[a].mesh_positions).first(count * actors_state_[a].vertices * 3);
    }
  }
  FrameChunk view;
  view.first = first_;
  view.count = count_;
  view.trajs_3d = std::span(trajs_3d_).first(tracking_ ? count * n * 3 : 0);
  view.actor_vertices = actor_vertices_;
  if (options_.prop_vertices && props_) view.prop_vertices = std::span(prop_frame_vertices_).first(count * prop_vertices_.size());
  view.cameras = camera_chunks_;
  return view;
}

StreamSummary FrameLoop::summary() const {
  StreamSummary summary;
  summary.frames = frames_;
  summary.points = n_;
  summary.actor_mesh_frames = actor_mesh_frames_;
  summary.cameras.resize(cameras_.size());
  const double point_frames = static_cast<double>(frames_) * static_cast<double>(n_);
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    CameraStreamSummary& s = summary.cameras[c];
    s.name = cameras_[c].name;
    s.actor_frames_culled = cameras_state_[c].actor_frames_culled;
    if (!cameras_[c].tracks || point_frames == 0) continue;
    const auto& counts = cameras_state_[c].code_counts;
    s.visible_fraction = counts[io::kVisible] / point_frames;
    s.occluded_by_actor_fraction = counts[io::kOccludedByActor] / point_frames;
    s.occluded_by_prop_fraction = counts[io::kOccludedByProp] / point_frames;
    s.valid_fraction = s.visible_fraction + s.occluded_by_actor_fraction + s.occluded_by_prop_fraction;
    s.actor_visible_fraction.assign(actors_.size(), 0.0);
    for (std::size_t a = 0; a < actors_.size(); ++a) {
      const double actor_point_frames = static_cast<double>(frames_) * static_cast<double>(actors_[a].points.size());
      if (actor_point_frames > 0) s.actor_visible_fraction[a] = static_cast<double>(cameras_state_[c].actor_visible[a]) / actor_point_frames;
    }
  }
  return summary;
}

StreamSummary run_frame_loop(std::span<const StreamActor> actors, const StreamProps* props,
                             std::span<const StreamCamera> cameras, std::span<StreamSink* const> sinks,
                             const StreamOptions& options, const std::function<void(int done, int total)>& on_chunk) {
  const auto start = Clock::now();
  FrameLoop loop(actors, props, cameras, options);
  for (StreamSink* sink : sinks) sink->begin();
  const CameraFrameCallback to_sinks = [&](const CameraFrame& frame) {
    for (StreamSink* sink : sinks) sink->camera_frame(frame);
  };
  const int frames = loop.frame_count();
  for (int first = 0; first < frames; first += loop.chunk_frames()) {
    const int count = std::min(loop.chunk_frames(), frames - first);
    loop.pose(first, count);
    loop.skin();
    for (std::size_t c = 0; c < cameras.size(); ++c) loop.classify(c, to_sinks);
    const FrameChunk chunk = loop.chunk();
    for (StreamSink* sink : sinks) sink->write(chunk);
    if (on_chunk) on_chunk(first + count, frames);
  }
  StreamSummary summary = loop.summary();
  summary.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return summary;
}

}  // namespace odyssey::scene
