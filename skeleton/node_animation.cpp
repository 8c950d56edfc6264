#include "skeleton/node_animation.h"

#include <Eigen/SVD>
#include <cmath>
#include <set>
#include <stdexcept>
#include <utility>

#include "skeleton/rotation.h"

namespace odyssey {
namespace {

const char* property_name(NodeProperty property) {
  switch (property) {
    case NodeProperty::translation:
      return "translation";
    case NodeProperty::rotation:
      return "rotation";
    case NodeProperty::scale:
      return "scale";
  }
  return "?";
}

// The rotation closest to A (the polar factor U V^T of A = U Sigma V^T, with U's last column
// flipped when A mirrors), as the glTF loader decomposes world matrices.
Eigen::Matrix3d closest_rotation(const Eigen::Matrix3d& a) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(a, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d u = svd.matrixU();
  const Eigen::Matrix3d v = svd.matrixV();
  if ((u * v.transpose()).determinant() < 0) u.col(2) = -u.col(2);
  return u * v.transpose();
}

}  // namespace

void NodeAnimation::validate() const {
  const std::size_t nodes = parents.size();
  const std::string who = "animation '" + name + "': ";
  if (rest.size() != nodes || order.size() != nodes) {
    throw std::invalid_argument(who + std::to_string(nodes) + " parents, " + std::to_string(rest.size()) + " rest poses and " +
                                std::to_string(order.size()) + " nodes in order");
  }
  std::vector<bool> placed(nodes, false);
  for (const int node : order) {
    if (node < 0 || std::size_t(node) >= nodes || placed[node]) throw std::invalid_argument(who + "the node order is not a permutation");
    if (parents[node] >= 0 && (std::size_t(parents[node]) >= nodes || !placed[parents[node]])) {
      throw std::invalid_argument(who + "node " + std::to_string(node) + " comes before its parent");
    }
    placed[node] = true;
  }
  std::set<std::pair<int, NodeProperty>> animated;
  for (std::size_t c = 0; c < channels.size(); ++c) {
    const NodeChannel& channel = channels[c];
    const std::string what = who + "channel " + std::to_string(c);
    if (channel.node < 0 || std::size_t(channel.node) >= nodes) {
      throw std::invalid_argument(what + " targets node " + std::to_string(channel.node) + " of " + std::to_string(nodes));
    }
    if (rest[channel.node].matrix) {
      throw std::invalid_argument(what + " animates node " + std::to_string(channel.node) +
                                  ", which is given as a matrix (glTF animates only nodes given by translation, rotation and scale)");
    }
    if (!animated.insert({channel.node, channel.property}).second) {
      throw std::invalid_argument(what + " animates the " + property_name(channel.property) + " of node " +
                                  std::to_string(channel.node) + ", which another channel already animates");
    }
    const bool rotation = channel.property == NodeProperty::rotation;
    if (channel.track.rotation != rotation || channel.track.components != (rotation ? 4 : 3)) {
      throw std::invalid_argument(what + ": a " + property_name(channel.property) + " track needs " + (rotation ? "4" : "3") +
                                  " components");
    }
    channel.track.validate(what + " (" + property_name(channel.property) + " of node " + std::to_string(channel.node) + ")");
  }
}

void NodeAnimation::world_matrices(double t, std::vector<Eigen::Matrix4d>& world) const {
  std::vector<NodeTransform> pose = rest;
  double value[4];
  for (const NodeChannel& channel : channels) {
    channel.track.sample(t, std::span(value, channel.track.components));
    NodeTransform& node = pose[channel.node];
    if (channel.property == NodeProperty::translation) node.translation = Eigen::Vector3d(value[0], value[1], value[2]);
    if (channel.property == NodeProperty::scale) node.scale = Eigen::Vector3d(value[0], value[1], value[2]);
    if (channel.property == NodeProperty::rotation) node.rotation = Eigen::Quaterniond(value[3], value[0], value[1], value[2]);
  }
  std::vector<Eigen::Matrix4d> local(pose.size());
  for (std::size_t n = 0; n < pose.size(); ++n) local[n] = local_matrix(pose[n]);
  odyssey::world_matrices(parents, order, local, world);
}

NodeAnimationPlayer::NodeAnimationPlayer(const Character& character, NodeAnimation animation, double scale)
    : animation_(std::move(animation)), skeleton_(character.skeleton), node_of_joint_(character.source_node_of_joint), scale_(scale) {
  const int joints = skeleton_.joint_count();
  const std::string who = "animation '" + animation_.name + "': ";
  if (static_cast<int>(node_of_joint_.size()) != joints) {
    throw std::invalid_argument(who + "the character does not say which node each joint stands for");
  }
  for (const int node : node_of_joint_) {
    if (node < 0 || std::size_t(node) >= animation_.parents.size()) {
      throw std::invalid_argument(who + "a joint of the character stands for node " + std::to_string(node) +
                                  ", which the animation's hierarchy does not have");
    }
  }
  if (!(scale > 0) || !std::isfinite(scale)) throw std::invalid_argument(who + "the scale must be positive");
  // Joints that bind vertices, and their rest R^T A.
  binds_.assign(joints, false);
  for (const CharacterMesh& mesh : character.meshes) {
    for (const int joint : mesh.skin_joints) {
      if (joint >= 0 && joint < joints) binds_[joint] = true;
    }
  }
  // The rest pose is the file's node transforms, not the animation's first keys.
  std::vector<Eigen::Matrix4d> rest_world;
  {
    NodeAnimation still = animation_;
    still.channels.clear();
    still.world_matrices(0, rest_world);
  }
  rest_binding_.resize(joints);
  for (int j = 0; j < joints; ++j) {
    const Eigen::Matrix3d a = rest_world[node_of_joint_[j]].topLeftCorner<3, 3>();
    rest_binding_[j] = closest_rotation(a).transpose() * a;
  }
}

void NodeAnimationPlayer::local_pose(double t, std::span<RigidTransform<double>> local) const {
  const int joints = skeleton_.joint_count();
  const std::string who = "animation '" + animation_.name + "': ";
  std::vector<Eigen::Matrix4d> world;
  animation_.world_matrices(t, world);
  std::vector<Eigen::Matrix3d> rotation(joints);
  std::vector<Eigen::Vector3d> position(joints);
  const Eigen::Matrix3d& c = animation_.to_world;
  for (int j = 0; j < joints; ++j) {
    const Eigen::Matrix4d& g = world[node_of_joint_[j]];
    if (!g.allFinite()) throw std::invalid_argument(who + "joint '" + skeleton_.name(j) + "' overflows at " + std::to_string(t) + " s");
    const Eigen::Matrix3d a = g.topLeftCorner<3, 3>();
    rotation[j] = closest_rotation(a);
    position[j] = g.topRightCorner<3, 1>();
    if (binds_[j]) {
      const double change = (rotation[j].transpose() * a - rest_binding_[j]).norm() / std::max(rest_binding_[j].norm(), 1e-300);
      if (change > kMaxSkinScaleChange) {
        throw std::invalid_argument(who + "at " + std::to_string(t) + " s the animated scale changes joint '" + skeleton_.name(j) +
                                    "', which carries mesh vertices, by " + std::to_string(change) +
                                    " of its rest size or shape; a rigid skeleton cannot play that (only scale that "
                                    "moves joints, not scale of geometry, is played)");
      }
    }
    const int parent = skeleton_.parent(j);
    if (parent < 0) {
      local[j] = {c * rotation[j], scale_ * (c * position[j])};
    } else {
      local[j] = {rotation[parent].transpose() * rotation[j], scale_ * (rotation[parent].transpose() * (position[j] - position[parent]))};
    }
  }
}

Clip play_node_animation(const Character& character, const NodeAnimation& animation, std::span<const double> times,
                         double fps) {
  const NodeAnimationPlayer player(character, animation);
  const Skeleton& skeleton = character.skeleton;
  const int joints = skeleton.joint_count();
  const std::string who = "animation '" + animation.name + "': ";
  if (times.empty()) throw std::invalid_argument(who + "no times to sample");
  if (!(fps > 0) || !std::isfinite(fps)) throw std::invalid_argument(who + "the frame rate must be positive");
  const double size = std::max(character.rest_bounds().sizes().norm(), 1e-12);

  Clip clip;
  clip.skeleton = skeleton;
  clip.fps = fps;
  const std::size_t frames = times.size();
  clip.rotations.resize(frames * joints);
  std::vector<Eigen::Vector3d> offsets(frames * joints);
  std::vector<RigidTransform<double>> local(joints);
  for (std::size_t f = 0; f < frames; ++f) {
    player.local_pose(times[f], local);
    for (int j = 0; j < joints; ++j) {
      offsets[f * joints + j] = local[j].translation;
      Eigen::Quaterniond q = quaternion_from_matrix(local[j].rotation);
      if (f > 0) q = sign_aligned(q, clip.rotations[(f - 1) * joints + j]);
      clip.rotations[f * joints + j] = q;
    }
  }
  // Joints whose offset from their parent moves get translation channels.
  for (int j = 0; j < joints; ++j) {
    for (std::size_t f = 0; f < frames; ++f) {
      if ((offsets[f * joints + j] - skeleton.rest_offsets()[j]).norm() > 1e-9 * size) {
        clip.translated_joints.push_back(j);
        break;
      }
    }
  }
  const std::size_t k = clip.translated_joints.size();
  clip.translations.resize(frames * k);
  for (std::size_t f = 0; f < frames; ++f) {
    for (std::size_t t = 0; t < k; ++t) clip.translations[f * k + t] = offsets[f * joints + clip.translated_joints[t]];
  }
  clip.validate();
  return clip;
}

double played_seconds(const std::string& who, double duration, double fps, std::optional<int> loops,
                      std::optional<double> seconds, double max_frames) {
  if (!(fps > 0) || !std::isfinite(fps)) throw std::invalid_argument(who + "the frame rate must be positive");
  if (loops && seconds) throw std::invalid_argument(who + "give loops or seconds, not both");
  if (loops && *loops < 1) throw std::invalid_argument(who + "loops must be 1 or more");
  if (seconds && !(*seconds >= 0 && std::isfinite(*seconds))) throw std::invalid_argument(who + "seconds must be 0 or more");
  const double total = seconds ? *seconds : duration * loops.value_or(1);
  if (total * fps >= max_frames) {
    throw std::invalid_argument(who + std::to_string(total) + " s at " + std::to_string(fps) + " fps is more than " +
                                std::to_string(static_cast<long long>(max_frames)) + " frames");
  }
  return total;
}

namespace {
constexpr double kLoopSlack = 1e-4;  // of a frame period
}  // namespace

double loop_time(double t, double duration, double fps) {
  if (!(duration > 0) || !(t > 0)) return 0;
  const double wrapped = std::fmod(t, duration);
  if (wrapped < kLoopSlack / fps || duration - wrapped < kLoopSlack / fps) return duration;
  return wrapped;
}

}  // namespace odyssey
