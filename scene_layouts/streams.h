// The frame loop every output of a shot goes through, a chunk of frames at a time so memory does
// not grow with the clip, and the sinks it feeds.
//
// Per chunk of C frames: forward kinematics of every actor (Clip::world_pose); every tracked point
// skinned once (SurfacePointSkinner over the points' corner vertices; props' points are static; a
// vertex-animated actor's vertices are placed by its joint every frame, and its points interpolate
// their corners with their barycentric weights, so they follow the deforming triangles);
// each actor's whole mesh skinned once a frame where some camera may see it or a sink asks for its
// mesh; then per camera and frame: the occluders it may see (every prop, the actors whose
// conservative box meets its view) drawn into that camera's depth buffer (visibility.h), and every
// point projected (skeleton/camera.h) and classified: visible, occluded by an actor or by a prop
// (by the owner of the triangle that hides it), outside the image, behind the camera. Sinks get
// each chunk in order (write) between begin() and finish().
//
// Culling: an actor's box for a frame is the box of its joints (a vertex-animated actor's: of its
// vertices) grown by 0.25 of its rest height
// on every side (hands, feet and head reach beyond their joints by less). A camera skips the
// actor's mesh when all eight corners lie behind it, or all project to one side of the image; no
// triangle of the actor can then cover a pixel, so no point in the image changes. The frames
// skipped are counted per actor and camera.
//
// An ego camera rides inside its own actor's head: the triangles of that actor whose corners are
// weighted mostly to the head joint or below it (face, eyes, jaw) are not occluders for it, or the
// face in front of the eyes would hide everything; the rest of its body still occludes.
//
// Cameras inside geometry: a static, orbiting or imported camera whose centre lies inside the box
// of an actor's tracked points (its joints when it has none) or inside a prop's box (a ground
// plane has no inside) is an error naming the camera, the actor or prop and the frame. An ego
// camera sits in its own actor's head by design and is tested against the others only.
//
// Memory: per chunk, the actors' joint transforms, the points (C x N x 3 floats, and per camera
// C x N x 2 floats and 3 bytes), the skinned meshes (C x V x 3 floats), C chosen for about 16 MiB;
// one depth buffer per camera; the sinks stream to disk.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "mocap_io/point_cache.h"
#include "mocap_io/trajectory_file.h"
#include "skeleton/camera.h"
#include "skeleton/character.h"
#include "skeleton/clip.h"
#include "skeleton/mesh_animation.h"
#include "skinning/sampling.h"

namespace odyssey::scene {

// An actor as the loop sees it: a character, the clip that drives it over the shot (one frame per
// output frame, on the character's skeleton) and the points tracked on it.
struct StreamActor {
  std::string name;
  const Character* character = nullptr;
  const Clip* clip = nullptr;
  // A vertex-animated actor (actor_source.h, anime): its one mesh's vertices every frame, in clip
  // joint 0's frame; they replace skinning (world vertex = W(joint 0) local vertex).
  const MeshAnimation* vertex_animation = nullptr;
  std::vector<skinning::SurfacePoint> points;
  bool mesh_every_frame = false;  // a sink needs its whole mesh each frame (a point cache)
  int head_joint = -1;            // an ego camera on this actor does not see its own head's subtree
};

// Every prop as one static character: joint 0 at the identity, mesh k is prop k, already in world
// coordinates.
struct StreamProps {
  std::vector<std::string> names;
  Character character;
  std::vector<skinning::SurfacePoint> points;
};

struct StreamCamera {
  std::string name;
  const CameraPath* path = nullptr;
  int own_actor = -1;  // ego: the actor it rides on
  bool tracks = true;  // project and classify the points (a trajectory sink listens)
  bool preview = false;  // draw contact-sheet tiles (preview.h); needs tracks
};

struct StreamOptions {
  int chunk_frames = 0;  // frames per chunk; 0: as many as fit in about 16 MiB of output (1 to 256)
  int threads = 1;       // skinning and visibility threads, the caller included
  bool reject_camera_inside = true;
  std::function<void(int done, int total)> on_chunk;  // after each chunk reached the sinks: frames done of total
};

// A contact-sheet tile (preview.h): one frame as the camera's depth buffer saw it, RGB.
struct PreviewFrame {
  int frame = 0;
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;  // width x height x 3, rows from the top
};

// One camera's share of a chunk, frame after frame.
struct CameraChunk {
  std::span<const float> trajs_2d;                     // C x N x 2
  std::span<const std::uint8_t> valids, visibs;        // C x N
  std::span<const std::uint8_t> visibility_codes;      // C x N (io::kVisible ...)
  std::span<const float> intrinsics, extrinsics;       // C x 9, C x 16, row-major
  std::span<const PreviewFrame> previews;              // the chunk's contact-sheet tiles (preview camera)
};

// What the sinks see of a chunk. Points are numbered actor after actor in the scene's order, then
// the props' points.
struct FrameChunk {
  int first = 0, count = 0;
  std::span<const float> trajs_3d;                     // C x N x 3
  std::span<const std::span<const float>> actor_vertices;  // per actor: C x V x 3 (mesh_every_frame), else empty
  std::span<const CameraChunk> cameras;                // per camera (empty where it does not track)
};

// begin() before the first chunk, write() once per chunk in frame order, finish() after the last:
// a sink completes its file under the name it was given (a staged temporary of StagedOutputs).
class StreamSink {
 public:
  virtual ~StreamSink() = default;
  virtual void begin() {}
  virtual void write(const FrameChunk& chunk) = 0;
  virtual void finish() {}
};

// Trajectories of every point in camera `camera`, into a writer the caller made (and closes).
class TrajectorySink : public StreamSink {
 public:
  TrajectorySink(int camera, io::TrajectoryFileWriter& writer) : camera_(camera), writer_(writer) {}
  void write(const FrameChunk& chunk) override;

 private:
  int camera_;
  io::TrajectoryFileWriter& writer_;
};

// The whole mesh of actor `actor` every frame, into a PC2 writer the caller made (and closes).
class PointCacheSink : public StreamSink {
 public:
  PointCacheSink(int actor, io::Pc2Writer& writer) : actor_(actor), writer_(writer) {}
  void write(const FrameChunk& chunk) override;

 private:
  int actor_;
  io::Pc2Writer& writer_;
};

struct CameraStreamSummary {
  std::string name;
  double valid_fraction = 0, visible_fraction = 0;       // of point-frames
  double occluded_by_actor_fraction = 0, occluded_by_prop_fraction = 0;
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

// Runs the loop over every frame of the actors' clips (all the same length and rate; each on its
// character's skeleton) and every camera (paths of the same length). Throws std::invalid_argument
// naming the actor, camera or frame for mismatched clips or paths, an invalid path, or a camera
// inside geometry (reject_camera_inside); sinks' own errors propagate.
StreamSummary run_streams(std::span<const StreamActor> actors, const StreamProps* props,
                          std::span<const StreamCamera> cameras, std::span<StreamSink* const> sinks,
                          const StreamOptions& options = {});

}  // namespace odyssey::scene
