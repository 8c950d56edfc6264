// A rigged character: a skeleton and the meshes it deforms, in the toolkit's world (Z up,
// metres), independent of the file it came from. Skinning follows glTF's definition, kept per
// mesh so that several skins over one skeleton (and rigid meshes on bones) need no special case:
//
//   v_world = sum_k w_k  W(joints[k]) * inverse_bind[k] * v_mesh
//
// where W(j) is joint j's rigid world transform from forward kinematics (a 4x4 with unit scale:
// any node scale is folded into offsets and into inverse_bind) and v_mesh a vertex as stored.
// A mesh attached rigidly to a bone is a skin of one joint with weight 1.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "skeleton/skeleton.h"

namespace odyssey {

struct CharacterMesh {
  std::string name;
  std::vector<Eigen::Vector3f> positions;  // mesh space, as stored (see inverse_bind)
  std::vector<std::uint32_t> triangles;    // 3 vertex indices a triangle
  // The mesh's skin: skeleton joint of each skin slot and its inverse bind matrix.
  std::vector<int> skin_joints;
  std::vector<Eigen::Matrix4d> inverse_bind;
  // Up to 4 influences a vertex: slots into skin_joints, weights summing to 1 (unused: weight 0).
  std::vector<std::array<std::uint16_t, 4>> influence_slots;
  std::vector<std::array<float, 4>> influence_weights;
};

struct Character {
  std::string name;
  Skeleton skeleton;  // rest pose = the file's node transforms
  std::vector<CharacterMesh> meshes;
  // For writers that animate the original file: the file's node index of each joint.
  std::vector<int> source_node_of_joint;
  // Uniform scale accumulated on each joint in the file (glTF node scales, armature scale), which
  // the rigid skeleton has folded away; writers restore it for translation channels.
  std::vector<double> source_scale_of_joint;
  // Where the rest pose comes from, in words: "node transforms (...)", or "inverse bind matrices
  // (...)" when a skin's inverse bind matrices put its joints elsewhere than the nodes do (the
  // file's nodes hold another pose than the one the mesh was bound in; mocap_io/gltf_character.h).
  std::string rest_pose_origin;
  // In the second case, each joint's local matrix at rest in the file's own frame (its node's
  // transform as it would read at bind), for writers that pose the original file; else empty.
  std::vector<Eigen::Matrix4d> source_rest_local_of_joint;
  // The humanoid bone list the file declares, in the file's own vocabulary (VRM's "hips",
  // "leftUpperLeg", ...): which joint plays each bone; empty when the file declares none.
  struct DeclaredBone {
    std::string bone;
    int joint;
  };
  std::vector<DeclaredBone> declared_humanoid;
  std::string declared_humanoid_convention;  // "VRM 0.x" or "VRM 1.0"; empty when none
  // What the loader skipped, approximated or cannot animate (unsupported primitives, influences
  // beyond four, morph targets, the file parser's own remarks), one line each.
  std::vector<std::string> warnings;

  // Axis-aligned bounds of the skinned meshes at the rest pose (z is height), for scale and
  // floor placement; when there is no mesh, of the joints.
  Eigen::AlignedBox3d rest_bounds() const;
};

// Skins one mesh at the given world joint transforms (one per skeleton joint). The plain
// reference implementation: clear, double precision, no tricks; the fast engine is in skinning/.
// Throws std::invalid_argument when the mesh's arrays disagree in length, or a skin joint or an
// influence slot points outside joint_world or skin_joints.
std::vector<Eigen::Vector3d> skin_mesh_reference(const CharacterMesh& mesh,
                                                 const std::vector<RigidTransform<double>>& joint_world);

}  // namespace odyssey
