// BVH motion capture files (Biovision hierarchy), read into a Clip in the toolkit's frame:
// Z up, metres.
//
// What a BVH file says. The HIERARCHY section nests ROOT / JOINT blocks, each with an OFFSET
// (the joint's position in its parent's frame at rest) and a CHANNELS list; the MOTION section
// gives "Frames: N", "Frame Time: t" (seconds per frame) and then one line of numbers a frame,
// the channels of every joint in the order the CHANNELS lines appear in the file. A joint's local
// transform in a frame is
//   x -> R (x) + p,   R = R_a1(v1) R_a2(v2) R_a3(v3)
// where a1, a2, a3 are the rotation channels in the order listed (angles in degrees, composed
// left to right as written: "Zrotation Xrotation Yrotation" is Rz Rx Ry), and p is the OFFSET
// with each component that has a position channel replaced by that channel's value. Position
// channels may sit anywhere in the list (interleaved with rotations too): they never change how
// the rotations compose, because the translation applies after the rotation. Any joint may carry
// any subset of the six channels, each at most once, in any order; a joint without a CHANNELS
// line is fixed at its rest transform.
//
// What the Clip holds. Joints are the ROOT and JOINT blocks in file order (depth first, so a
// parent precedes its children), named as in the file; several ROOTs give several roots. End
// Site blocks are not joints (they carry no channels) and are dropped with their offsets. Rest
// rotations are identity, so a frame's rotation is the joint's whole local rotation. Joints with
// at least one position channel are the clip's translated joints, and their per-frame
// translation replaces the rest offset. Both the Y-up BVH world and every joint frame are carried
// into the Z-up world by the change of basis C = y_up_to_z_up() ((x, y, z) -> (x, -z, y)):
//   offsets and translations  p' = s C p            (s = metres_per_unit)
//   rotations                  R' = C R C^T
// so every world position p of the BVH pose becomes s C p, and a rotation about a BVH axis a
// becomes the same rotation about C a (X stays X, Y becomes Z, Z becomes -Y).
//
// Frame rate. fps = 1 / t, except that a frame time written with too few digits to be exact is
// read as the rate it rounds from: when exactly one integer n has 1/n within half a unit of the
// last written digit of t, fps = n. ".0083333" is 1/120 to seven decimals (and no other integer
// rate is), so the CMU files give exactly 120 fps instead of 120.00048.
//
// The file is untrusted: every problem (truncation, fewer or more numbers than channels or frames
// than declared, a token that is not a number, NaN or infinity, an unknown or repeated channel, a
// missing or extra brace, a repeated joint name, a frame time that is not positive) throws
// InputError(path, "line N: problem"). Nesting depth and file size cannot exhaust the stack or
// reserve memory the file does not back. Since the clip stores every joint every frame, joints x
// frames is capped: the clip may take at most 32 times the file's size plus 64 MiB (a file whose
// every joint has a channel needs at most 16 times), else InputError before anything is reserved.
#pragma once

#include <string>

#include "skeleton/clip.h"

namespace odyssey::io {

struct BvhOptions {
  // Length of one BVH unit in metres. 0.01 fits the many exporters that write centimetres.
  double metres_per_unit = 0.01;
};

// The CMU motion capture database's BVH conversions (cgspeed) keep the ASF length unit, where
// lengths are inches divided by 0.45: one unit = 0.0254 / 0.45 m = 0.0564444 m, quoted to five
// significant digits as 0.056444 m. A subject then stands about 1.7 m tall.
constexpr double kCmuMetresPerUnit = 0.056444;

// Reads a BVH file. Throws InputError on a bad file (see above) and std::invalid_argument when
// options.metres_per_unit is not a positive finite number.
Clip load_bvh(const std::string& path, const BvhOptions& options = {});

}  // namespace odyssey::io
