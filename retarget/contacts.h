// Feet, the floor, and when a foot is planted.
//
// A foot is the joints it can touch the floor with: the ankle (canonical left_ankle) and the
// ball of the foot (left_foot) where the rig has them. Joints sit above the sole, so each carries
// a ground height, its height above the floor when the foot is planted, and a foot's clearance
// in a frame is the height of its lowest point above where it would be planted:
//
//   clearance(t) = min_k ( z_k(t) - ground_height_k ),   k over the foot's joints,
//
// 0 for a foot flat on the floor, negative when it sinks in. Taking the lowest of ankle and ball
// keeps a heel strike and a toe-off (either end down) at clearance ~0. The floor is z = 0.
//
// A target foot's joints need not reach the front of its sole: RobotExpressive's foot is one joint
// at the heel of a rigid block (4.5 cm above its sole, its toe 0.84 m ahead), and RiggedFigure's
// ball joint sits 3.5 cm ahead of its ankle on a 27 cm sole. Such a foot has nothing to stand on
// at toe-off, and nothing that says where its sole lies. So every target foot that carries a mesh
// takes a toe from it: of the rest vertices the foot carries (whose strongest influence is its
// first joint or a joint below it), those within a tenth of the carried height of the lowest, the
// one farthest ahead (ahead: from the joint toward the carried vertices' centroid, horizontally)
// gives the toe's height and reach, and the toe is that far straight ahead of the joint. It is a
// point rigid with the first joint (Foot::toe, in its frame), counted among the foot's points
// with its own ground height: clearance(t) is then the lowest of heel, ball and toe, and a foot
// that rolls over its toe at toe-off stays at clearance ~0. The transfer pitches the foot by it
// (transfer.h). A source's foot, or a foot that carries no mesh, has none.
//
// The floor. A target character stands on z = 0 with its soles on the floor at rest: each foot
// joint's ground height is its rest height above the lowest point of the rest mesh
// (Character::rest_bounds). A recorded clip says neither where the floor is nor where the soles
// are, and its floor need not be level: the CMU walk's stance heights rise about 4.5 cm over its
// 3.3 m (the fit finds its floor tilted by 0.9 degrees), and its first frame is a T-pose reference
// standing lower than any step. So the source's floor is fitted as a plane through the foot joints' stance
// samples (a joint moving slower than `max_speed` horizontally, within `max_height` of the plane):
//
//   z_k(t) = h_k + b x_k(t) + c y_k(t)      least squares over the stance samples, one height
//                                           h_k per foot joint, one slope (b, c) for the floor,
//
// starting from the joints' 10th-percentile heights with no slope and reselecting the samples
// five times. A slope the samples cannot see (the feet never leave a line, a clip standing still)
// is held near zero by a ridge term worth samples spread 0.1 m along each axis. The fitted floor
// is then levelled: the source world is turned by the shortest rotation taking the plane's normal
// (-b, -c, 1)/|.| to +z (Feet::levelling), every use of the source (contacts, transfer, metrics)
// sees the levelled source, and each joint's ground height is the 10th percentile of its levelled
// stance heights (the flat-foot height rather than the mean, which heel-off and toe-off raise).
// A clip with fewer than 10 stance samples for a joint (it never touches the floor) falls back to
// the joint's lowest levelled height over the clip.
//
// Contacts are detected on the levelled source at its recorded size (a human performer, before
// scaling): a foot is planted in frame t when its clearance is under `max_height` and the lowest
// of its joints moves horizontally slower than `max_speed` between t and t+1 (the last frame uses
// the step from the frame before). The defaults, 5 cm and 0.5 m/s, are the metrics' contact
// height and skate speed (metrics.h).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "retarget/bone_map.h"
#include "skeleton/character.h"
#include "skeleton/clip.h"

namespace odyssey::retarget {

struct Foot {
  std::vector<int> joints;             // rig joints: the ankle, then the ball of the foot, if mapped
  std::vector<double> ground_heights;  // height of each above the floor with the foot planted, m
  // Target feet with a mesh (above): the front of the sole, in joints[0]'s frame (its world
  // rotation's), and its height above the floor with the foot planted flat.
  bool has_toe = false;
  Eigen::Vector3d toe = Eigen::Vector3d::Zero();
  double toe_ground_height = 0;

  // The foot's contact points: its joints, then the toe if it has one.
  int point_count() const { return static_cast<int>(joints.size()) + (has_toe ? 1 : 0); }
  double point_ground_height(int k) const { return k < static_cast<int>(joints.size()) ? ground_heights[k] : toe_ground_height; }
  // World position of point k from the joints' world positions and joints[0]'s world rotation.
  Eigen::Vector3d point(int k, std::span<const Eigen::Vector3d> joint_positions, const Eigen::Matrix3d& first_rotation) const {
    return k < static_cast<int>(joints.size()) ? joint_positions[joints[k]]
                                               : Eigen::Vector3d(joint_positions[joints[0]] + first_rotation * toe);
  }
};

struct Feet {
  std::array<Foot, 2> sides;  // [0] the left foot, [1] the right foot
  // World -> levelled world, where the floor is horizontal (identity for a target character).
  Eigen::Quaterniond levelling = Eigen::Quaterniond::Identity();

  const Foot& operator[](int side) const { return sides[side]; }
};

struct ContactOptions {
  double max_height = 0.05;  // m
  double max_speed = 0.5;    // m/s, horizontal
};

struct FootContacts {
  std::array<std::vector<std::uint8_t>, 2> planted;  // [foot][frame], 1 when planted

  int frame_count() const { return static_cast<int>(planted[0].size()); }
  int planted_count() const;
};

// clearance(t) above for one foot, from the levelled world positions of the rig's joints (the
// foot's joints only: its toe needs a rotation).
double foot_clearance(const Foot& foot, std::span<const Eigen::Vector3d> joint_positions);
// Index into foot.joints of the joint that is lowest relative to its ground height.
int lowest_foot_joint(const Foot& foot, std::span<const Eigen::Vector3d> joint_positions);
// The same over every point of the foot, its toe included (`first_rotation`: joints[0]'s world
// rotation); the index is a point's (Foot::point).
double foot_clearance(const Foot& foot, std::span<const Eigen::Vector3d> joint_positions, const Eigen::Matrix3d& first_rotation);
int lowest_foot_point(const Foot& foot, std::span<const Eigen::Vector3d> joint_positions, const Eigen::Matrix3d& first_rotation);

// The fitted floor and ground heights (see above). Throws std::invalid_argument when the map has
// neither ankle nor ball of the foot for a side, or the clip has no frames.
Feet source_feet(const Clip& source, const BoneMap& map, const ContactOptions& options = {});
// Ground heights from the character's rest pose, and each foot's toe (see above). Throws std::invalid_argument when
// the map has neither ankle nor ball of the foot for a side.
Feet target_feet(const Character& target, const BoneMap& map);

FootContacts detect_contacts(const Clip& source, const Feet& feet, const ContactOptions& options = {});

}  // namespace odyssey::retarget
