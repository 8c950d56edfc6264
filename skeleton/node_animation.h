// A character's own animation: a node hierarchy (glTF's) whose nodes' translation, rotation and
// scale are driven by keyframe tracks, played on the Character built from the same hierarchy
// (mocap_io/gltf_character.h) as an ordinary Clip, with no retargeting.
//
// Evaluation at animation time t: each node's local matrix is L = T R S from its rest
// translation, rotation and scale with the animated ones substituted (a node given as a matrix
// keeps it; glTF does not animate those), and its world matrix G(n) = G(parent) L(n)
// (node_transform.h).
//
// Playback on the character. The character's joint j stands for node n = source_node_of_joint[j];
// its rest world transform is W = C [R | t] with [A | t] = G_rest(n), R the rotation closest to A
// and C = to_world (glTF Y up to the toolkit's Z up), and every mesh vertex is bound to
// R^T A at rest (gltf_character.h, "Skinning"). At time t the same decomposition of G_t(n) gives
// the joint's world transform W_t = C [R_t | t_t]; the clip stores local rotations
// R_parent^T R_t (C R_t for a root) and, for joints whose offset from their parent changes,
// local translations R_parent^T (t_t - t_parent) (C t_t for a root). Nodes above the skeleton's
// root that the loader folded away (an armature node, a Z-up fix) are part of G, so their
// animation moves the whole character. Joint positions are therefore exact for any animated
// translation, rotation and scale. Skinned and rigid meshes are exact as long as R_t^T A_t equals
// its rest value for every joint that binds vertices, i.e. while no animated scale changes the
// size or shape of a joint that carries geometry (the rigid skeleton and linear blend skinning
// carry no per-frame scale); a larger change than kMaxSkinScaleChange is an error naming the
// joint and the time. A scale animated on nodes that bind no vertex (it only moves children) is
// played exactly.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "skeleton/character.h"
#include "skeleton/clip.h"
#include "skeleton/keyframes.h"
#include "skeleton/node_transform.h"

namespace odyssey {

// Largest change of R^T A (relative to its rest value's norm) accepted on a joint that binds
// vertices: a vertex at distance r from its joint then moves by at most about 1e-5 r.
inline constexpr double kMaxSkinScaleChange = 1e-5;

enum class NodeProperty { translation, rotation, scale };

struct NodeChannel {
  int node = 0;
  NodeProperty property = NodeProperty::rotation;
  KeyframeTrack track;
};

struct NodeAnimation {
  std::string name;
  std::vector<int> parents;  // per node, -1 for a root
  std::vector<int> order;    // every node, parents before children
  std::vector<NodeTransform> rest;  // the nodes as the file gives them
  std::vector<NodeChannel> channels;
  double start = 0, end = 0;  // the earliest and latest key time of any channel
  Eigen::Matrix3d to_world = Eigen::Matrix3d::Identity();
  // Channels the file has that are not played (morph target weights), one line each.
  std::vector<std::string> warnings;

  double duration() const { return end - start; }

  // Throws std::invalid_argument on sizes that disagree, a channel on a node outside the
  // hierarchy or on a matrix node, two channels on one node's property, or an invalid track.
  void validate() const;

  // G(n) of every node at animation time t (seconds on the file's clock).
  void world_matrices(double t, std::vector<Eigen::Matrix4d>& world) const;
};

// The animation on `character` (built from the same file) at animation times `times`: frame k of
// the clip is the pose at times[k]; the clip's rate is `fps`. Throws std::invalid_argument when the
// character's joints name nodes the animation does not have, or an animated scale changes a
// joint that binds vertices (naming the joint, the time and the change).
Clip play_node_animation(const Character& character, const NodeAnimation& animation, std::span<const double> times,
                         double fps);

// The animation played on the character at any time: the per-frame step of play_node_animation.
// Its lengths are multiplied by `scale` (the character's offsets must be scaled alike). Throws
// std::invalid_argument when the character's joints name nodes the animation does not have.
class NodeAnimationPlayer {
 public:
  NodeAnimationPlayer(const Character& character, NodeAnimation animation, double scale = 1);
  const NodeAnimation& animation() const { return animation_; }
  // Every joint's local transform at animation time t (the file's clock): its local rotation and
  // its offset from its parent (for a root, its world transform), as play_node_animation stores
  // them. Throws std::invalid_argument naming the joint and the time for an overflow or an animated
  // scale on a joint that binds vertices.
  void local_pose(double t, std::span<RigidTransform<double>> local) const;

 private:
  NodeAnimation animation_;
  Skeleton skeleton_;
  std::vector<int> node_of_joint_;
  double scale_ = 1;
  std::vector<bool> binds_;                    // per joint: it binds vertices
  std::vector<Eigen::Matrix3d> rest_binding_;  // per joint: R^T A at rest
};

// The length played: `loops` times `duration`, `seconds` (looping as often as needed), or once
// (neither). Throws std::invalid_argument (`who` begins the message) for both given, loops < 1,
// negative or non-finite seconds, or more than max_frames frames at `fps`.
double played_seconds(const std::string& who, double duration, double fps, std::optional<int> loops,
                      std::optional<double> seconds, double max_frames = 10'000'000);

// Played time t of a looping animation of `duration` s, as a time within one loop: t mod duration,
// except that a time within 1e-4 of a frame period (at `fps`) of a loop's end (t > 0) maps to the
// end itself, since key times are float32 (17 / 24 s is a little short): one loop of 17 key
// intervals at 24 fps is 18 frames, and its last frame shows the last key, not the first.
// A duration of 0 (one instant) maps every time to 0.
double loop_time(double t, double duration, double fps);

}  // namespace odyssey
