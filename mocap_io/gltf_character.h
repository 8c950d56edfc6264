// glTF 2.0 characters (.gltf with external or embedded buffers, and .glb), read with tinygltf into
// a Character in the toolkit's world: Z up, rigid joints, glTF's skinning kept per mesh.
//
// Which nodes become joints. The skeleton is every joint of every skin in the file, every node of
// the displayed scene (the file's `scene`, else scene 0, else every root node) that carries a
// mesh without a skin (a mesh attached rigidly to that node), and every node on the way from a
// root of the node hierarchy down to those: intermediate nodes that are not skin joints become
// joints too, so forward kinematics reproduces the file's transforms exactly. At the top of each
// tree, a chain of nodes that are neither skin joints nor rigid mesh nodes and have one child in
// the skeleton (RobotExpressive's RootNode and 100-scaled RobotArmature, a Z_UP conversion node,
// an empty "Armature") gives no joints: its transforms are folded into the root joint's rest
// transform. Skinned mesh nodes are not joints either, as glTF ignores their transform. Joints
// keep the parent-first order of a depth-first walk of the node hierarchy; a node without a name
// is named "joint_<node index>", and a name already taken gets "_node<node index>" appended (skin
// joints claim names first, so the rig's bones keep the names bone maps look for).
//
// Transforms. A node's local matrix L is its `matrix`, or T R S from translation, rotation
// (normalised) and scale; its world matrix is G(n) = G(parent) L(n) from the hierarchy's roots.
// The rigid skeleton keeps the rotation and position of each G and moves the scale into the
// meshes. Write G(n) = [A | t] with A = U Sigma V^T (SVD), and its closest rotation R = U V^T
// (U diag(1, 1, -1) V^T when det A < 0). With C = y_up_to_z_up(), the joint's world transform is
//   W(n) = C [R | t]                      (the root's rest transform; a joint's rest local
//                                           transform is W(parent)^-1 W(n), so the rest offset
//                                           is R_parent^T (t - t_parent), scale included)
// and its source scale s(n) = cbrt(|det A|). Where the file's scales are uniform, A = s R exactly.
//
// Skinning. glTF skins a vertex v of a skinned mesh with
//   v_gltf = sum_k w_k G(joint_k) IBM_k v           (the mesh node's own transform is ignored)
// and the toolkit (character.h) with v_world = sum_k w_k W(joint_k) inverse_bind_k v. Requiring
// v_world = C v_gltf slot by slot gives
//   inverse_bind_k = W^-1 C G IBM_k = [R | t]^-1 G IBM_k = [R^T A | R^T (t_G - t)] IBM_k
//                  = diag(s, s, s, 1) IBM_k        when A = s R (uniform scale),
// since W^-1 C = [R | t]^-1 C^-1 C. The loader stores the exact product, so the rest pose is
// reproduced to double rounding even where the file's scales are slightly uneven. A rigid mesh
// on node n is a skin of the one joint n with weight 1 and inverse_bind = [R | t]^-1 G(n), which
// is diag(s, s, s, 1) for uniform scale. Missing inverse bind matrices are the identity.
//
// The bind pose. Skinning is exact for any pose the nodes hold, but the rest pose a retarget
// starts from must be the one the mesh was bound in, and some exporters leave the nodes in
// another (an animation's first frame, a pose struck in the editor). At bind, G(joint_k) IBM_k
// is one matrix M for every joint of a skin, so a joint whose parent also has an inverse bind
// matrix sits at Gb(n) = Gb(p) IBM_p IBM_n^-1 relative to it; a joint whose parent is the scene
// root or the skin's `skeleton` node (that node's parent when it is itself a joint) sits at
// IBM_n^-1 relative to it (either local [A | t] taken as [s R | t], R the rotation closest to A
// and s = cbrt(det A), unless it mirrors: float32 matrices leave a shear of about 1e-7 that no
// node's T R S could hold); every other node, joints outside every skin included, keeps its own
// local transform under its parent's bind pose. This is how Blender's importer guesses the
// original bind pose (its default), and a joint listed by several skins takes the last one's
// matrix as there. When some skin joint's rotation in Gb differs from the nodes' by more than
// 1e-4 rad, the nodes hold another pose and Gb replaces G everywhere below (positions alone are
// not compared: a node scale the inverse bind matrices do not hold moves joints without posing
// them, and the rigid skeleton carries such scale as before): skeleton, inverse binds (the mesh then rests
// as stored, M v) and rigid meshes. Character::rest_pose_origin says which pose was used and by
// how much the nodes differed; source_rest_local_of_joint keeps the bind locals for the writer.
// An inverse bind matrix that is not finite, not affine or singular (smallest singular value of
// its linear part under 1e-9 of the largest) is an error naming the skin and the joint.
//
// Scale that the rigid skeleton cannot carry. When a joint is posed, its children move rigidly
// with it; that matches glTF only when the joint's world linear part A is a rotation times one
// scale. So a node that has joints below it must have singular values of A within a ratio of
// 1 + 1e-3 of each other (exporters leave float noise of about 1e-5, a real stretch is far
// larger), a positive determinant (no mirroring) and no zero scale; otherwise the file is
// rejected. Leaf joints and rigid mesh nodes may carry any scale (uneven, mirrored, zero): it
// lives only in their inverse binds, which reproduce the rest pose exactly and, for a TRS node
// whose parent scales uniformly, its rotations too (G' = W' diag(s_parent S) with S its scale).
//
// Meshes. Every TRIANGLES primitive (indexed or not) of every mesh node of the scene becomes one
// CharacterMesh, in node index order and then primitive order, named after the mesh (else the
// node, else "mesh_<index>"), with "#<primitive>" appended when the mesh has several. Other
// primitive modes and primitives without POSITION are skipped with a warning. Positions may be
// float or, as KHR_mesh_quantization allows, integers (normalised or not). Morph targets are
// not animated: their POSITION displacements are baked in at the node's (else the mesh's) default
// weights, so the rest shape is the file's, and a warning says so.
// Vertex indices are unsigned byte, short or int. Influences come from every JOINTS_n / WEIGHTS_n
// pair: JOINTS as unsigned byte or short (indices, like vertex indices, must not be normalised),
// WEIGHTS as float or unsigned byte or short (normalised or not: a constant factor cancels in
// the renormalisation that follows). The four largest weights of a vertex are kept and
// divided by their sum, so each row sums to 1 within float rounding; a warning counts the
// vertices that lost a non-zero weight. A vertex whose weights are all zero would collapse to
// the origin in glTF; it follows its first listed joint (JOINTS_0.x) with weight 1 instead, and a
// warning counts such vertices.
//
// Untrusted input. The GLB container is checked before tinygltf sees it; then every index
// (scene, node, child, mesh, skin, joint, accessor, buffer view, buffer), every component type,
// element type, count, stride and byte range, every sparse substitution and every number
// (finite, weights not negative, joint slots inside the skin, vertex indices inside the mesh) is
// checked, and a problem throws InputError(path, problem). A node with two parents or a cycle in
// the node hierarchy is an error. An accessor without a buffer view reads as zeros (then its
// sparse values, if any). Decoding costs bytes the file may not hold (an accessor without a buffer
// view, one mesh shown by many nodes), so all the accessors a load decodes may take at most
// gltf_decode_budget() bytes as doubles, checked before anything is allocated; and JSON nested
// deeper than kMaxGltfJsonDepth is refused before tinygltf, whose JSON-to-value conversion
// recurses, sees it. Files that require Draco or meshopt geometry
// compression are rejected. tinygltf's warnings (for example an external texture that is missing)
// go into Character::warnings; images are never decoded.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "skeleton/character.h"
#include "skeleton/node_animation.h"

namespace odyssey::io {

// Deepest nesting of JSON arrays and objects a glTF file may have, the root object being level 1.
// Real files need fewer than 20 levels; 128 leaves room for deep `extras`, and tinygltf's
// recursion overflows the stack only thousands of levels down.
inline constexpr int kMaxGltfJsonDepth = 128;

// Throws InputError(path, ...) naming the JSON path and byte offset where `json` (a .gltf, or a
// GLB's JSON chunk) opens an array or object deeper than kMaxGltfJsonDepth. One linear pass that
// skips string literals (escapes included), in constant memory; nothing else about the text is
// checked (the parser does that).
void check_gltf_json_depth(const std::string& path, std::string_view json);

// Bytes that decoding one file's accessors may take in all, in one load (as doubles) or one GLB
// export (as copies and doubles): 16 MiB plus 64 per byte of input (the file and its external
// buffers), so a small file cannot cost gigabytes.
std::uint64_t gltf_decode_budget(std::uint64_t input_bytes);

// Loads a .gltf or .glb (told apart by the GLB magic bytes, not by the extension). Character.name
// is the file's stem. Throws InputError naming the file for anything it cannot read exactly.
Character load_character(const std::string& path);

// What a glTF file holds besides the character load_character() builds: its skins and its
// animations, as `odyssey inspect` lists them.
struct GltfSkinSummary {
  std::string name;  // the skin's name, else "skin_<index>"
  int joint_count = 0;
};
struct GltfAnimationSummary {
  std::string name;  // the animation's name, else "animation_<index>"
  int channels = 0;
  int samplers = 0;
  std::size_t keyframes = 0;  // the most keyframes (input times) of any of its samplers
  double start = 0.0;         // seconds: the earliest and latest input time of all its samplers
  double end = 0.0;
  double duration() const { return end - start; }
};
struct GltfFileSummary {
  std::vector<GltfSkinSummary> skins;
  std::vector<GltfAnimationSummary> animations;
};

// Reads the skins and animations of a .gltf or .glb with the same checks as load_character (the
// container, the JSON depth, every index; each sampler's input times decoded as float scalars,
// within the same decoding budget, finite). Throws InputError naming the file.
GltfFileSummary summarize_gltf_file(const std::string& path);

// The animation called `name` (its name, else "animation_<index>" as the summary lists it), decoded
// for playback on the character load_character() builds from the same file
// (skeleton/node_animation.h): the file's whole node hierarchy with its rest transforms (the same
// checks as load_character), and per channel its node, property and keyframe track (LINEAR, STEP
// or CUBICSPLINE; input times as floats; translations and scales as floats, rotations as floats or
// normalised integers; every index, count and number checked, within the decoding budget). A
// channel on morph target weights is not played and a warning in NodeAnimation::warnings says so;
// a channel with no target node (an extension's) is skipped. Throws InputError naming the file
// and the animation, channel or sampler; for an animation the file does not have, the message
// lists the names it has.
NodeAnimation load_gltf_animation(const std::string& path, const std::string& name);

}  // namespace odyssey::io
