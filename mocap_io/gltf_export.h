// Animated GLB out: the character's own glTF file (meshes, materials, textures, skins, node
// hierarchy, loaded again with tinygltf) plus one animation that plays a Clip on its nodes and,
// optionally, a camera path on a camera node of its own.
//
// What the written file holds. Every node keeps its index, name, children and static
// properties, so Character::source_node_of_joint indexes the written file too; only when the
// character's rest pose is its skins' bind pose rather than its nodes' pose
// (Character::source_rest_local_of_joint, gltf_character.h) do the joints' nodes get that rest
// transform, so that the channels below start from the pose the mesh was bound in. The file's
// animations are removed and replaced by one, named by the options, with LINEAR samplers that
// share one time accessor (frame f at f / fps seconds, float32, min and max set as the spec
// requires): a rotation channel on every joint's node, and a translation channel on each root
// joint's node and on the node of every joint in clip.translated_joints. Rotation samples are
// sign-aligned to the previous sample of their channel (the first to the node's rest rotation),
// so interpolation between frames takes the short way. Joint nodes written as a `matrix` are
// rewritten as translation, rotation and scale (glTF animates only TRS nodes); a matrix with
// shear cannot be, and is rejected. Static node scale stays on the nodes.
// All data goes into one buffer, the GLB's binary chunk, and every buffer view is written afresh:
// each accessor with data gets a view of its own, tightly packed, with its sparse substitutions
// applied (no sparse storage is written); views of vertex attributes and indices carry their
// target, and only a vertex attribute whose elements are not a multiple of 4 bytes has a
// byteStride (each element padded to 4 bytes, as glTF requires). Images, external or data-URI,
// are embedded as views of their own (MIME type from their magic bytes); accessors, views and
// buffers nothing refers to any more (the old animations') are dropped. Accessor min/max are
// recomputed from the data wherever declared (and on every POSITION, which must declare them):
// exporters often get them slightly wrong, and the validator counts a mismatch as an error.
// Files using extensions whose payload refers to accessors or buffer views (Draco, meshopt, GPU
// instancing) are rejected: their references could not be renumbered. Like load_character(), the
// writer refuses JSON nested deeper than kMaxGltfJsonDepth and decodes at most
// gltf_decode_budget() bytes of the file's accessors (data it makes itself counts as input).
//
// Skin weights. The validator requires the weights of a vertex, over all WEIGHTS_n sets, to sum
// to 1 within 2e-7 per non-zero weight (summed in float32), which quantised or unnormalised
// weights miss. Every WEIGHTS_n accessor is therefore rewritten as float32:
// weights of one joint listed twice are merged into its first slot (a repeated joint with
// non-zero weight is an error too), all are divided by their sum, and the largest takes
// 1 - (sum of the others), so the stored floats sum to 1 to float rounding. A vertex whose weights
// are all zero gets weight 1 on its first listed joint, as load_character() skins it. JOINTS_n
// are kept; a negative or non-finite weight or a joint slot outside the skin is an input error.
//
// The maths of the channels. Notation as in gltf_character.h: node n has local matrix L(n) =
// T(u_n) R(r_n) S(sigma_n) and world G(n) = G(parent) L(n) = [A_n | t_n]; joint j on node n has
// rest world W_j = C [R_n | t_n] with R_n the rotation closest to A_n and C = y_up_to_z_up(), and
// rest local [Qr_j | or_j] = W_parent^-1 W_j. A clip frame gives joint j the local rotation Q_j and
// offset o_j (or_j unless j is translated); forward kinematics gives its world W'_j. The posed
// file should move each node's rigid frame with its joint and carry along, unchanged, the part of
// G the rigid skeleton does not hold (its scale R_n^T A_n):
//   G'(n) = C^-1 W'_j [R_n | t_n]^-1 G(n),
// which makes glTF's skinning matrix G'(n) IBM equal C^-1 W'_j inverse_bind_j, the toolkit's
// (character.h), so the file skins exactly the mesh the toolkit skins. Solving for L'(n):
//
// * A non-root joint j (parent joint p on node m, the parent node of n; the loader requires
//   A_m = s_m R_m, one scale s_m = source_scale_of_joint[p]):
//     L'(n) = G'(m)^-1 G'(n) = [ Q_j Qr_j^-1 R(r_n) S(sigma_n) | A_m^-1 R_m o_j ]
//   so  r'_n = Q_j Qr_j^-1 r_n   (= Q_j: C cancels, and Qr_j = r_n unless the node mirrors)
//       u'_n = A_m^-1 R_m o_j    (= o_j / s_m, the offset divided by the parent's scale).
//   The translation is exact for any A_m. The rotation is exact when A_m is uniform; otherwise
//   the exact L'(n) is A_m^-1 R_m (Q Qr^-1) R_m^T A_m R(r_n) S(sigma_n), which no rotation
//   reaches. Writing A_m = s_m R_m (I + E) with E small and symmetric, it differs from the
//   rotation above by a symmetric stretch of order |E| (the first-order correction is
//   symmetric), so r'_n is also the best rotation to first order. The loader bounds |E| by 1e-3.
// * A root joint j on node n, below nodes that are not joints (their transforms folded into the
//   root's rest) with world F = [A_F | t_F], A_F = s_F R_F (F = identity when n is a root node):
//     L'(n) = F^-1 G'(n),  G'(n) = [ C^-1 Q_j R_n^T A_n | C^-1 o_j ],  A_n = A_F R(r_n) S(sigma_n)
//   and with R_n^T = Qr_j^-1 C:
//       r'_n = R_F^-1 C^-1 (Q_j Qr_j^-1) C R_F r_n   (= R_F^-1 C^-1 Q_j unless the node mirrors)
//       u'_n = A_F^-1 (C^-1 o_j - t_F).
//   F must scale uniformly (ratio of singular values within 1 + 1e-3): under an uneven F no
//   rotation of n reproduces a rotated rigid frame, and the file is rejected.
// At rest (Q_j = Qr_j, o_j = or_j) every formula returns the node's own r_n and u_n.
//
// The camera (options.camera set). The file gains one root node, named options.camera_name,
// carrying a perspective camera of that name; it is appended after the existing nodes (whose
// indices stay) and listed in the displayed scene's root nodes: the default scene, else the
// first, as load_character() reads them (a file without scenes shows every root node, this one
// too). The animation gains a translation and a rotation channel on it, LINEAR on the clip's time
// accessor, so camera frame f is shown at f / fps with clip frame f. The node's static
// translation and rotation are frame 0's, for viewers that do not play the animation.
//   Axes: a glTF camera looks along its local -Z with +Y up and +X right; an OpenCV camera looks
// along +z with y down. The node's local axes in the camera's OpenCV axes are therefore
//     X_gl = x_cv,  Y_gl = -y_cv,  Z_gl = -z_cv,   i.e. p_cv = D p_gl,  D = diag(1, -1, -1)
// (a proper rotation: half a turn about x). A camera point goes to the toolkit's Z-up world by
// x_world = R_cv^T (p_cv - t) = R_cv^T p_cv + c (R_cv = pose.rotation, world -> camera;
// c = -R_cv^T t = pose.centre()), and the toolkit's world to glTF's Y-up world by C^-1 = C^T. The
// node is a root, so its local transform is its world one:
//     rotation  Rg = C^-1 R_cv^T D,   translation  ug = C^-1 c.
// Check: the node's viewing axis -Z, taken to the toolkit world, is C Rg (0,0,-1) = R_cv^T (0,0,1)
// = pose.forward(), and its up axis +Y is C Rg (0,1,0) = R_cv^T (0,-1,0) = -pose.down().
// Rotation samples are sign-aligned to the previous sample, as the joints' are.
//   Projection: glTF's perspective camera has a centred principal point and square pixels, so it
// carries the vertical field of view and the image shape:
//     yfov = 2 atan(height / (2 fy)),   aspectRatio = width / height,
// znear = 0.01 m (glTF requires a near plane; 1 cm is closer than anything the toolkit's camera
// rigs frame) and no zfar, which glTF reads as an infinite projection. K's cx, cy and fx are not
// carried: off-centre principal points and non-square pixels are rendered as the ideal camera.
// Core glTF cannot animate camera properties (that needs KHR_animation_pointer), so the camera
// has frame 0's intrinsics, and a path whose intrinsics (K or image size) change is rejected.
// tinygltf writes zfar = 0, its value for "absent", which glTF forbids; the written JSON drops
// a zero zfar from every perspective camera (the source file's cameras included).
//
// Errors. A clip that does not belong to the character's skeleton (joint count, names, parents)
// or is invalid throws std::invalid_argument, and so does a camera path that does not validate
// (CameraPath::validate), has another frame count or fps than the clip, or changes its
// intrinsics; a character that does not come from the file (its joints' nodes or rest positions
// disagree with it), a file that cannot be read or carried over, or an output that cannot be
// written throws InputError naming the file. Everything is built in memory first and written to a
// temporary file beside out_path that is renamed onto it when complete: on any failure nothing
// appears at out_path (an existing file there stays).
#pragma once

#include <string>

#include "skeleton/camera.h"
#include "skeleton/character.h"
#include "skeleton/clip.h"

namespace odyssey::io {

struct GlbExportOptions {
  std::string animation_name = "motion";
  // A camera to animate alongside the clip, one pose per clip frame at the clip's fps (see "The
  // camera" above); not owned, and read only during the call. nullptr: no camera.
  const CameraPath* camera = nullptr;
  std::string camera_name = "camera";  // the camera node's and the camera's name
};

// Writes out_path (a GLB) from the glTF/GLB at character_path, which `character` was loaded from
// with load_character(), animated by `clip`, a clip on character.skeleton (same joint order).
void write_animated_glb(const std::string& character_path, const Character& character, const Clip& clip,
                        const std::string& out_path, const GlbExportOptions& options = {});

}  // namespace odyssey::io
