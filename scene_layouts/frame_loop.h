// The frame loop every output of a shot goes through, a chunk of frames at a time so memory does
// not grow with the clip, as three stages a caller may run in a loop of its own:
//
//   FrameLoop loop(actors, props, cameras, options);
//   for (int first = 0; first < loop.frame_count(); first += loop.chunk_frames()) {
//     loop.pose(first, count);           // forward kinematics, culling boxes, vertex-animated meshes
//     loop.skin();                       // tracked points, and each mesh where some camera may see it
//     for (c ...) loop.classify(c, on_frame);  // rasterise c's occluders, project and classify points
//     ... loop.chunk() ...               // what the sinks (sinks.h) are given
//   }
//
// pose: Clip::world_pose of every actor for frames [first, first + count); an actor's culling box is
// the box of its joints (a vertex-animated actor's: of its vertices, placed by W(joint 0)) grown
// by 0.25 of its rest height on every side (hands, feet and head reach beyond their joints by
// less).
// Props that move (StreamProps::motion) are carried rigidly frame by frame in pose: their
// vertices (occluders, culling and inside boxes) and, in skin, their tracked points.
// skin: every tracked point skinned once (SurfacePointSkinner over the points' corner vertices;
// a prop's point is its triangle's corners interpolated as placed, then moved with the prop; a vertex-animated actor's points interpolate their corners with
// their barycentric weights, so they follow the deforming triangles); each actor's whole mesh
// skinned once a frame where some tracking camera may see it or mesh_every_frame asks for it. A
// camera may see an actor unless all eight corners of its box lie behind it, or all project to
// one side of the image: no triangle of the actor can then cover a pixel, so no point in the
// image changes. The frames skipped are counted per actor and camera.
// classify: per frame, the occluders the camera may see (every prop, the actors in view) drawn
// into the camera's depth buffer (visibility.h), and every point projected (skeleton/camera.h)
// and classified: visible, occluded by an actor or by a prop (the owner of the triangle that
// hides it), outside the image, behind the camera. `on_frame` then sees the frame's depth buffer
// and classification (a contact sheet draws from it).
//
// An ego camera rides inside its own actor's head: the triangles of that actor whose corners are
// weighted mostly to the head joint or below it (face, eyes, jaw) are not occluders for it, or the
// face in front of the eyes would hide everything; the rest of its body still occludes.
//
// Cameras inside geometry: a camera whose centre lies inside the box of an actor's tracked points
// (its joints when it has none) or inside a prop's box (a ground plane has no inside) is an error
// naming the camera, the actor or prop and the frame (reject_camera_inside). An ego camera sits
// in its own actor's head by design and is tested against the others only.
//
// Memory: per chunk, the actors' joint transforms, the points (C x N x 3 floats, and per camera
// C x N x 2 floats and 3 bytes), the skinned meshes (C x V x 3 floats), C chosen for about 16 MiB;
// one depth buffer per camera. Results do not depend on the thread count.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "mocap_io/trajectory_file.h"
#include "scene_layouts/timed_clip.h"
#include "scene_layouts/visibility.h"
#include "skeleton/camera.h"
#include "skeleton/character.h"
#include "skinning/lbs.h"
#include "skinning/sampling.h"
#include "skinning/worker_pool.h"

namespace odyssey::scene {

// An actor as the loop sees it: a character, the clip that drives it over the shot (one frame per
// output frame, on the character's skeleton) and the points tracked on it. A vertex-animated clip
// (actor_source.h, anime) gives its one mesh's vertices in joint 0's frame; they replace skinning
// (world vertex = W(joint 0) local vertex).
struct StreamActor {
  std::string name;
  const Character* character = nullptr;
  const TimedClip* clip = nullptr;
  std::span<const skinning::SurfacePoint> points;
  bool mesh_every_frame = false;  // a sink needs its whole mesh each frame (a point cache)
  int head_joint = -1;            // an ego camera on this actor does not see its own head's subtree
};

// Every prop as one static character: joint 0 at the identity, mesh k is prop k, already in world
// coordinates as placed at frame 0.
struct StreamProps {
  std::vector<std::string> names;
  Character character;
  std::vector<skinning::SurfacePoint> points;
  // Props that move (prop_physics.h): at [f * names.size() + k] the rigid motion M carrying prop
  // k's mesh as placed to where it is in frame f (x_f = M x_0; the identity for a static prop).
  // Empty: every prop stays where it was placed.
  std::vector<RigidTransform<double>> motion;
};

struct StreamCamera {
  std::string name;
  const CameraPath* path = nullptr;
  int own_actor = -1;  // ego: the actor it rides on
  bool tracks = true;  // project and classify the points
};

struct StreamOptions {
  int chunk_frames = 0;  // frames per chunk; 0: as many as fit in about 16 MiB of output (1 to 256)
  int threads = 1;       // skinning and visibility threads, the caller included
  bool reject_camera_inside = true;
  bool prop_vertices = false;  // every prop vertex every frame in the chunk (a props point cache)
};

// One camera's share of a chunk, frame after frame.
struct CameraChunk {
  std::span<const float> trajs_2d;                     // C x N x 2
  std::span<const std::uint8_t> valids, visibs;        // C x N
  std::span<const std::uint8_t> visibility_codes;      // C x N (io::kVisible ...)
  std::span<const float> intrinsics, extrinsics;       // C x 9, C x 16, row-major
};

// What the sinks see of a chunk. Points are numbered actor after actor in the shot's order, then
// the props' points.
struct FrameChunk {
  int first = 0, count = 0;
  std::span<const float> trajs_3d;                         // C x N x 3
  std::span<const std::span<const float>> actor_vertices;  // per actor: C x V x 3 (mesh_every_frame), else empty
  std::span<const float> prop_vertices;  // C x Vp x 3, every prop's vertices in order (StreamOptions::prop_vertices), else empty
  std::span<const CameraChunk> cameras;                    // per camera (empty where it does not track)
};

// One camera's frame as classify() left it: the depth buffer's last render and the points.
struct CameraFrame {
  int camera = 0, frame = 0;
  const CameraPose* pose = nullptr;
  const DepthBuffer* depth = nullptr;
  // The render's triangles in ranges [previous end, end) -> owner (an actor's index a >= 0, or
  // -1 - k for prop k), ends increasing.
  std::span<const std::pair<std::uint32_t, int>> owner_ranges;
  std::span<const float> uv;                   // N x 2
  std::span<const std::uint8_t> valid, codes;  // N

  static constexpr int kNoOwner = INT32_MIN;
  // The owner of triangle t of the render: an actor's index, -1 - k for prop k, or kNoOwner for
  // an index past the render's triangles (triangle_at's empty pixel).
  int owner(std::uint32_t triangle) const;
};
using CameraFrameCallback = std::function<void(const CameraFrame&)>;

struct CameraStreamSummary {
  std::string name;
  double valid_fraction = 0, visible_fraction = 0;       // of point-frames
  double occluded_by_actor_fraction = 0, occluded_by_prop_fraction = 0;
  std::vector<double> actor_visible_fraction;            // per actor: of its point-frames, those visible
  std::vector<long> actor_frames_culled;                 // per actor: frames whose mesh it skipped
};

struct StreamSummary {
  std::size_t frames = 0, points = 0;
  std::vector<long> actor_mesh_frames;  // per actor: frames whose whole mesh was skinned
  std::vector<CameraStreamSummary> cameras;
  double seconds = 0;                   // wall clock of the loop (skinning, projection, sinks)
};

// The point description of a trajectory file for these actors and props: corners numbered across
// each owner's meshes in order, point_actor_ids the actor's index, -1 - k for prop k.
io::TrajectoryFileHeader trajectory_file_header(std::span<const StreamActor> actors, const StreamProps* props,
                                                std::size_t frames, double fps);

// The loop's model (actors, props, cameras: read, not owned; they must outlive it) and its data
// (skinners, chunk buffers, depth buffers). One per thread.
class FrameLoop {
 public:
  // Validates and builds the skinners. Throws std::invalid_argument naming the actor, camera or
  // frame for mismatched clips or paths, or an invalid path.
  FrameLoop(std::span<const StreamActor> actors, const StreamProps* props, std::span<const StreamCamera> cameras,
            const StreamOptions& options = {});
  ~FrameLoop();
  FrameLoop(const FrameLoop&) = delete;
  FrameLoop& operator=(const FrameLoop&) = delete;

  int frame_count() const { return frames_; }
  int chunk_frames() const { return chunk_frames_; }
  std::size_t point_count() const { return n_; }

  // The stages, in this order per chunk; count <= chunk_frames().
  void pose(int first, int count);
  void skin();
  // Throws std::invalid_argument for a camera inside geometry (reject_camera_inside).
  void classify(std::size_t camera, const CameraFrameCallback& on_frame = {});

  // The chunk as the stages left it: spans into the loop's buffers, valid until the next pose().
  FrameChunk chunk();
  // The counts so far (classify's codes, skinned and culled frames); `seconds` is left 0.
  StreamSummary summary() const;

 private:
  struct ActorState;
  struct CameraState;
  bool moving_props() const;
  std::span<const StreamActor> actors_;
  const StreamProps* props_;
  std::span<const StreamCamera> cameras_;
  StreamOptions options_;
  int frames_ = 0, chunk_frames_ = 1;
  int first_ = 0, count_ = 0;
  bool tracking_ = false;
  std::size_t n_ = 0, prop_first_point_ = 0;
  std::vector<ActorState> actors_state_;
  std::vector<CameraState> cameras_state_;
  std::vector<float> prop_vertices_, prop_points_;
  std::vector<std::uint32_t> prop_triangles_;
  std::vector<std::uint32_t> prop_triangle_ends_;  // per prop: the end of its triangles in prop_triangles_
  std::vector<Eigen::AlignedBox3d> prop_boxes_;
  // Moving props: which props move, each prop's first vertex, each point's prop, and per frame of
  // the chunk every prop vertex (C x Vp x 3) and box (C x P).
  std::vector<char> prop_moves_;
  bool props_move_ = false;  // some prop moves
  std::vector<std::size_t> prop_first_vertex_;
  std::vector<std::uint32_t> prop_point_owner_;
  std::vector<float> prop_frame_vertices_;
  std::vector<Eigen::AlignedBox3d> prop_frame_boxes_;
  std::vector<float> trajs_3d_;
  std::vector<char> sees_;  // sees_[(f C + c) A + a]: camera c may see actor a in frame f of the chunk
  std::vector<float> occluder_positions_;
  std::vector<std::array<std::size_t, 5>> block_counts_;
  std::vector<CameraChunk> camera_chunks_;
  std::vector<std::span<const float>> actor_vertices_;
  std::vector<long> actor_mesh_frames_;
  skinning::WorkerPool pool_;
};

// A sink: the one interface every output of a shot is written through (sinks.h). begin() before
// the first chunk, write() once per chunk in frame order (camera_frame() for each camera-frame of
// the chunk before it), finish() after the last, with the shot's result; a sink writes its files
// under the names it was given (staged temporaries of io::StagedOutputs) and lists them in files().
struct SceneResult;
class StreamSink {
 public:
  virtual ~StreamSink() = default;
  virtual void begin() {}
  virtual void camera_frame(const CameraFrame&) {}
  virtual void write(const FrameChunk&) {}
  virtual void finish(const SceneResult&) {}
  // A report lists every output and the run's total time: it finishes after the others.
  virtual bool is_report() const { return false; }
  // What the sink writes, by its final names, in the order a report lists them.
  virtual std::vector<std::string> files() const = 0;
};

// Runs the loop over every frame of the actors' clips (all the same length and rate; each on its
// character's skeleton) and every camera (paths of the same length), into the sinks (begin, then
// camera_frame and write per chunk; not finish). `on_chunk` is told the frames done after each
// chunk reached the sinks. Throws what FrameLoop throws; sinks' own errors propagate.
StreamSummary run_frame_loop(std::span<const StreamActor> actors, const StreamProps* props,
                             std::span<const StreamCamera> cameras, std::span<StreamSink* const> sinks,
                             const StreamOptions& options = {},
                             const std::function<void(int done, int total)>& on_chunk = {});

}  // namespace odyssey::scene
