// The per-frame streams renderers and annotators consume, produced from a character and the clip
// that drives it, a chunk of frames at a time so memory does not grow with the clip:
//
// - Trajectories: sampled surface points (skinning/sampling.h) moved with the skinned mesh, their
//   projections into a camera path's frames, their visibility, and the cameras, into a
//   TrajectoryFileWriter (mocap_io/trajectory_file.h). Per chunk of C frames: forward kinematics of
//   each frame (Clip::world_pose); SurfacePointSkinner over the points' corner vertices; the whole
//   mesh skinned (LinearBlendSkinner) and drawn into the frame's depth buffer
//   (scene_layouts/visibility.h); then for every point the pinhole projection of skeleton/camera.h
//   (u, v in pixels; valid when in front of the camera and inside the image; u = v = 0 behind it)
//   and the depth test (visible: valid and not hidden by any part of the character).
// - Point cache: every vertex of every mesh, skinned with LinearBlendSkinner, into a Pc2Writer.
//
// Memory: the buffers of one chunk (joint transforms C x J, points C x N x 5 floats plus flags,
// vertices C x V x 3 floats; C chosen for about 16 MiB) and one depth buffer, whatever the clip's
// length; the writers stream to disk.
//
// Cameras inside the character. A static, orbiting or imported camera that sits inside the
// character sees the mesh from inside, which is never what a dataset wants; with
// `reject_camera_inside` the export stops with an error naming the frame when the camera centre
// lies inside the axis-aligned box of the tracked points that frame (a conservative test: the
// box is larger than the body, so a camera between the legs is refused too). An ego-head camera
// sits at the head by design and is not tested (its own head, behind the eyes, is clipped by the
// depth buffer's near plane and hides nothing in front of it).
#pragma once

#include <cstddef>
#include <span>

#include "mocap_io/point_cache.h"
#include "mocap_io/trajectory_file.h"
#include "skeleton/camera.h"
#include "skeleton/character.h"
#include "skeleton/clip.h"
#include "skinning/sampling.h"

namespace odyssey::scene {

struct StreamOptions {
  int chunk_frames = 0;              // frames per chunk; 0: as many as fit in about 16 MiB of output (1 to 256)
  int threads = 1;                   // skinning threads, the caller included
  bool reject_camera_inside = false;
};

struct TrajectoryExportSummary {
  std::size_t frames = 0, points = 0;
  std::size_t skinned_vertices = 0;  // the points' corner vertices, skinned each frame
  double valid_fraction = 0;         // share of (frame, point) pairs that are valid
  double visible_fraction = 0;       // share that are visible
  double seconds = 0;                // wall clock of the export loop (skinning, projection, writing)
};

// The point description a trajectory file stores: corners as vertex indices numbered across the
// character's meshes in order, barycentric weights, actor `actor` for every point. `frames` and
// `fps` complete the header.
io::TrajectoryFileHeader trajectory_file_header(const Character& character, std::span<const skinning::SurfacePoint> points,
                                                std::size_t frames, double fps, int actor = 0);

// Streams every frame of `clip` (a clip on character.skeleton) through `writer`, which must have
// been made with trajectory_file_header(character, points, clip frames, clip fps); does not close
// it. Throws std::invalid_argument when the camera path's frame count differs from the clip's or
// it does not validate, the clip is not on the character's skeleton, or (reject_camera_inside) a
// camera is inside the character, naming the frame.
TrajectoryExportSummary export_trajectories(const Character& character, const Clip& clip,
                                            std::span<const skinning::SurfacePoint> points, const CameraPath& camera,
                                            io::TrajectoryFileWriter& writer, const StreamOptions& options = {});

struct PointCacheSummary {
  std::size_t frames = 0, vertices = 0;
  double seconds = 0;
};

// Streams every frame of `clip` through `writer` (made for the character's total vertex count and
// the clip's frame count); does not close it.
PointCacheSummary export_point_cache(const Character& character, const Clip& clip, io::Pc2Writer& writer,
                                     const StreamOptions& options = {});

}  // namespace odyssey::scene
