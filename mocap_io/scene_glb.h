// One GLB of a whole scene: every actor skinned and animated, every prop, every camera, built from
// the toolkit's own data (not by re-writing the characters' source files, as gltf_export.h does),
// so any number of actors, several on the same character, fit in one file.
//
// What the written file holds (one scene, one buffer: the GLB's binary chunk).
// * Per actor a group node named after the actor (identity transform) whose children are the
//   root joints of its skeleton; below them one node per joint, named as the joint, carrying the
//   skeleton's rest transform (rest_offsets, rest_rotations) as translation and rotation.
// * Per actor mesh a root node, named "<actor>/<mesh name>" (or "<actor>/mesh<k>"), holding a mesh
//   of one triangle primitive (POSITION as stored, NORMAL, JOINTS_0, WEIGHTS_0, uint32 indices,
//   the actor's material) and a skin of its own, as the Character keeps skins per mesh: joints are
//   the nodes of CharacterMesh::skin_joints, inverse bind matrices CharacterMesh::inverse_bind,
//   skeleton the actor's group node. glTF skins such a node by G(joint) IBM v, and ignores the
//   node's own transform, so the mesh node is a root with none. Normals are area-weighted vertex
//   normals in mesh space ((0, 1, 0) for a vertex on no triangle). Weights are written as float32,
//   merged where one slot is listed twice, divided by their sum, the largest set to 1 minus the
//   others (the validator wants the stored floats to sum to 1); zero weights get joint slot 0; a
//   vertex with all-zero weights gets weight 1 on its first slot, as the toolkit skins it.
//   Vertex order is the Character's, so a trajectory file's point_vertex_ids (numbered across the
//   character's meshes in order) index the written meshes: the node's extras say which actor and
//   mesh it is and the number of its first vertex ({"odyssey_actor": a, "odyssey_mesh": k,
//   "odyssey_first_vertex": n}). A mesh without triangles is not written (glTF has no empty
//   accessors); the others keep their extras.
// * A vertex-animated actor (SceneGlbActor::vertex_animation; one joint, one mesh: a .anime mesh)
//   is written as above, its joint animated by the clip, and its mesh also carries morph targets:
//   target k is a frame's vertices (in the joint's frame) minus the stored positions, consecutive
//   equal frames (an actor held before its start or after its end) sharing one target, and a
//   "weights" channel on the mesh node puts weight 1 on frame f's target at time f / fps and 0 on
//   the others, LINEAR, so between frames glTF blends two targets (1 - s, s): every vertex moves
//   linearly from frame to frame, as the toolkit resamples. Normals are not morphed (the targets
//   hold no NORMAL: a renderer shades with the first frame's). The weights take frames x targets
//   floats: a shot of 3,000 distinct frames writes 9 million (36 MB) besides the targets.
// * Per prop mesh (props->meshes, world coordinates) a root node named as the mesh ("prop<k>" if
//   unnamed), a static mesh (POSITION, NORMAL, indices) in glTF's world, the props' material, and
//   extras {"odyssey_prop": k, "odyssey_first_vertex": n} (vertices numbered across the props'
//   meshes, as trajectory files number prop points). A prop that moves (`prop_motion`: per frame f
//   and prop k the rigid motion M = [R | t] carrying its mesh as stored to frame f) gets a
//   translation and a rotation channel: its glTF vertices are g = C^-1 x, moved to C^-1 (R x + t)
//   = (C^-1 R C) g + C^-1 t, so the node's rotation is C^-1 R C and its translation C^-1 t (the
//   identity for a prop that never moves, which gets no channel).
// * Per camera a root node and a perspective camera, both named as the camera, extras
//   {"odyssey_camera": c} (and, for an ego camera, "odyssey_rides_on" and "odyssey_hides_subtree_of":
//   SceneGlbCamera).
// * One animation, "scene", LINEAR, with one time accessor (frame f at f / fps seconds, float32):
//   a rotation channel on every joint node, a translation channel on every root joint and every
//   joint of clip.translated_joints, and a translation and a rotation channel on every camera node.
//   Rotation samples are sign-aligned to the previous sample of their channel (the first to the
//   node's rest rotation), so interpolation between frames takes the short way.
// * One flat material per actor (a fixed palette, repeating after eight actors) and one, grey, for
//   the props.
//
// The maths. The toolkit's world is Z up; glTF's is Y up. C = y_up_to_z_up() takes glTF to the
// toolkit, so a toolkit point x goes to glTF as C^-1 x, and a toolkit world frame W = [R | t] to
// C^-1 W. This is done in one place (to_gltf in the .cpp) and applied to what hangs in the world:
// the root joints' transforms, the props' vertices and normals, and the cameras. A non-root joint's
// local transform is the same in both worlds (C^-1 W_parent L = (C^-1 W_parent) L). A clip frame's
// local rotation Q_j replaces the rest rotation (r = Q_j, or C^-1 Q_j for a root), and a translated
// joint's translation o_j its rest offset (u = o_j, or C^-1 o_j for a root), so glTF's joint world is
// G_j = C^-1 W_j and its skinning matrix G_j IBM_j = C^-1 W_j inverse_bind_j: exactly the
// toolkit's (character.h) taken to glTF's world, so the file skins the mesh the toolkit skins.
// Character::source_scale_of_joint plays no part: the skeleton is rigid and in metres, and
// inverse_bind already maps the mesh's own space.
//   Cameras (OpenCV axes, world -> camera R_cv, t; centre c = -R_cv^T t), as in gltf_export.h: a
// glTF camera looks along its local -Z with +Y up, so p_cv = D p_gl with D = diag(1, -1, -1), and
// the node's rotation and translation are  Rg = C^-1 R_cv^T D,  ug = C^-1 c. Its static transform is
// frame 0's. Projection: glTF's perspective camera has a centred principal point and square
// pixels, so it carries  yfov = 2 atan(height / (2 fy))  and  aspectRatio = width / height  of
// frame 0's intrinsics, znear 0.01 m and no zfar (infinite). Core glTF cannot animate a camera's
// projection: a path whose intrinsics change over its frames (a zoom, another image size) is
// written with frame 0's throughout, and its cx, cy and fx are never carried (an off-centre
// principal point or non-square pixels render as the ideal camera); the trajectory and camera path
// files hold the exact intrinsics of every frame.
//
// Errors. std::invalid_argument for inconsistent input: a null character or clip, a clip that is
// not on its character's skeleton (joint count, names, parents) or does not validate, a clip or
// camera path whose frame count differs from the others' or whose fps is not `fps`, a camera path
// that does not validate, a mesh whose arrays disagree, whose skin is empty, lists a joint twice or
// outside the skeleton, or whose triangles or influences point outside it, a non-finite vertex or
// bind matrix, a negative or non-finite weight, fps not positive and finite, or frames too many
// for float32 times. InputError naming `path` when the file would pass GLB's 4 GiB or cannot be
// written. The GLB is built in memory and written through a temporary file renamed onto `path`
// when complete: on any failure nothing appears there.
#pragma once

#include <span>
#include <string>

#include "skeleton/fk.h"

#include "skeleton/camera.h"
#include "skeleton/character.h"
#include "skeleton/clip.h"
#include "skeleton/mesh_animation.h"

namespace odyssey::io {

struct SceneGlbActor {
  std::string name;                     // the group node's name and the prefix of its mesh nodes
  const Character* character = nullptr;  // not owned; read during the call only
  const Clip* clip = nullptr;            // on character->skeleton, one frame per output frame at fps
  // A vertex-animated actor (one joint, one mesh): the mesh's vertices every output frame, in
  // joint 0's frame; written as morph targets (above). nullptr: the mesh is skinned.
  const MeshAnimation* vertex_animation = nullptr;
};

struct SceneGlbCamera {
  std::string name;                  // the camera node's and the camera's name
  const CameraPath* path = nullptr;  // one pose per output frame at fps
  // An ego camera: the actor whose head carries it, and the joint of that actor's skeleton whose
  // subtree it does not see (the toolkit drops that actor's triangles with a corner whose dominant
  // joint lies there, frame_loop.h). Written as the node's extras "odyssey_rides_on" (the actor's
  // index) and "odyssey_hides_subtree_of" (the joint's name), so a renderer can drop the same
  // triangles. -1: none.
  int rides_on = -1;
  int hidden_joint = -1;
};

// `props` may be nullptr (no props); its meshes are in world coordinates and not skinned.
// `prop_motion` is empty (no prop moves) or holds [frame * props->meshes.size() + prop]. Every
// clip, camera path and the props' motion must have the same frame count; with no actor, no
// camera and no motion the file has no animation.
void write_scene_glb(const std::string& path, std::span<const SceneGlbActor> actors, const Character* props,
                     std::span<const SceneGlbCamera> cameras, double fps, std::span<const RigidTransform<double>> prop_motion = {});

}  // namespace odyssey::io
