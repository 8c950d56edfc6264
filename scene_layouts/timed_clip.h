// An actor's clip on the shot's timeline and floor, evaluated frame by frame and never stored
// whole: an actor costs its source's frames (a motion's, one loop of an animation, an anime
// file's), not the shot's, however long the shot.
//
// Shot frame k, at scene time s = k / fps, plays the source at
//   c(s) = clamp(trim_start + speed (s - start), trim_start, trim_end)     (scene.h's time map)
//   u    = c, or loop_time(c, P, fps) for a source looping with period P   (node_animation.h),
// the pose at u interpolated between the source's neighbouring frames (Clip::local_pose_at), or,
// for a character's own animation, its keys evaluated at u (NodeAnimationPlayer: exact at any
// time), then carried by the placement (R, d): every world transform T becomes (R, d) T, since the
// roots hang from it (KinematicData::base). A vertex-animated source (anime) gives its vertices at
// u likewise, in joint 0's frame.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <span>

#include "skeleton/clip.h"
#include "skeleton/fk.h"
#include "skeleton/mesh_animation.h"
#include "skeleton/node_animation.h"

namespace odyssey::scene {

struct ClipTiming {
  double fps = 30;  // the shot's
  int frames = 0;   // the shot's
  double start = 0, speed = 1;
  double trim_start = 0, trim_end = 0;  // played time, within [0, the source's played length]
  bool loops = false;                   // the source wraps with period source.duration()
};

class TimedClip {
 public:
  TimedClip() = default;
  // The clip as it is: shot frame k is clip frame k (no timing, no placement).
  explicit TimedClip(Clip clip);
  // `source` timed; `vertices`, when given, at the source's times; `keys`, when given, evaluated
  // in place of the source's frames (source time u is the animation's time start + u). Throws
  // std::invalid_argument for a source that fails Clip::validate or has no frames, vertices that
  // do not last as long, or a timing that is not finite.
  TimedClip(std::shared_ptr<const Clip> source, std::shared_ptr<const MeshAnimation> vertices,
            std::shared_ptr<const NodeAnimationPlayer> keys, const ClipTiming& timing);

  // Sets the placement: the source's world transforms T become (rotation, shift) T.
  void place(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& shift);

  int frame_count() const { return timing_.frames; }
  int joint_count() const { return source_ ? source_->joint_count() : 0; }
  double fps() const { return timing_.fps; }
  const Skeleton& skeleton() const { return source_->skeleton; }
  const Clip& source() const { return *source_; }

  // The source time frame k shows.
  double source_time(int frame) const;
  // World transforms of frame k (data.base is set to the placement; data sized for the skeleton).
  void world_pose(int frame, KinematicData<double>& data) const;
  void world_pose(int frame, std::span<RigidTransform<double>> world) const;

  bool vertex_animated() const { return vertices_ != nullptr; }
  std::size_t vertex_count() const { return vertices_ ? vertices_->vertex_count : 0; }
  // A vertex-animated source's vertices at frame k, in joint 0's frame (vertex_count x 3 floats).
  void local_vertices(int frame, std::span<float> out) const;

  // Every frame stored (the source's translated joints, and its roots), for writers that hold the
  // whole shot anyway (the scene GLB).
  Clip stored_clip() const;
  MeshAnimation stored_vertices() const;

 private:
  void local_pose(int frame, std::span<RigidTransform<double>> local) const;

  std::shared_ptr<const Clip> source_;
  std::shared_ptr<const MeshAnimation> vertices_;
  std::shared_ptr<const NodeAnimationPlayer> keys_;
  ClipTiming timing_;
  RigidTransform<double> placement_;
};

}  // namespace odyssey::scene
