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
// parent precedes its children), named as in the file (a name is every word on its ROOT or JOINT
// line, joined by single spaces: 3ds Max writes "Bip01 L Thigh"); several ROOTs give several
// roots. End
// Site blocks are not joints (they carry no channels) and are dropped with their offsets. Rest
// rotations are identity (load_bvh; load_bvh_inferring_frame may take a frame as the rest pose),
// and a frame's rotation is the joint's whole local rotation either way. Joints with
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

#include <array>
#include <optional>
#include <string>

#include "skeleton/clip.h"

namespace odyssey::io {

// Which BVH axis points up. BVH is Y up by convention; some exporters (MakeHuman) write Z up.
// Y up is carried into the toolkit's world by C = y_up_to_z_up() as above; Z up (right-handed)
// is the toolkit's own frame, C = identity.
enum class BvhUp { y, z };

struct BvhOptions {
  // Length of one BVH unit in metres. 0.01 fits the many exporters that write centimetres.
  double metres_per_unit = 0.01;
  BvhUp up = BvhUp::y;
};

// The CMU motion capture database's BVH conversions (cgspeed) keep the ASF length unit, where
// lengths are inches divided by 0.45: one unit = 0.0254 / 0.45 m = 0.0564444 m, quoted to five
// significant digits as 0.056444 m. A subject then stands about 1.7 m tall.
constexpr double kCmuMetresPerUnit = 0.056444;

// The length units BVH files are written in: metres, decimetres (MakeHuman), centimetres,
// millimetres, inches, feet, and CMU units.
struct BvhUnit {
  const char* name;
  double metres;
};
inline constexpr std::array<BvhUnit, 7> kBvhUnits = {
    {{"m", 1.0}, {"dm", 0.1}, {"cm", 0.01}, {"mm", 0.001}, {"in", 0.0254}, {"ft", 0.3048}, {"cmu", kCmuMetresPerUnit}}};

// Reads a BVH file. Throws InputError on a bad file (see above) and std::invalid_argument when
// options.metres_per_unit is not a positive finite number.
Clip load_bvh(const std::string& path, const BvhOptions& options = {});

// Units and up axis inferred from the skeleton, assuming a human performer.
//
// The up axis: a human is far taller than deep, so in the pose measured the BVH axis (Y or Z)
// along which the joints spread furthest is up, Z only when its spread is more than 1.5 times
// Y's (a T-pose spreads as far along X, the side axis in both conventions, so X is not a
// candidate). The height is the joints' spread along that axis, head joint to the lowest foot
// joint (End Sites are not joints). It is measured in the rest pose, or, when the rest pose is
// degenerate (its height is under a quarter of its bounding box's diagonal: every offset zero,
// or offsets that lie along one axis, as some datasets write them), in the first frame that
// stands: the first, else up to 200 frames spread evenly over the clip. Such a frame then
// becomes the clip's rest pose too (load_bvh_inferring_frame, with_rest_from_frame), since
// retargeting pairs, checks and aligns rigs in their rest pose; the motion is unchanged. The unit: among kBvhUnits the one that makes
// the height nearest 1.6 m (a human's head-joint-to-sole span) in ratio, |log(h u / 1.6 m)|.
// The ranges in which each unit gives 1.0-2.2 m barely overlap (dm 10-22 units, CMU 17.7-39,
// in 39.4-87, cm 100-220), so the nearest is the only plausible one except between 17.7 and 22
// units, where dm and CMU both fit and the nearer to 1.6 m wins. When the height is outside
// 1.0-2.2 m in every unit (not a human, or a child smaller than 1 m) or neither pose stands up,
// the guess is not plausible and its warning() says so: the nearest unit is still used (or
// centimetres when nothing could be measured), and an explicit unit is the user's fix.
struct BvhFrameGuess {
  double metres_per_unit = 0.01;
  std::string unit;            // a kBvhUnits name, or the number given
  bool unit_inferred = false;  // false: the caller gave the unit
  BvhUp up = BvhUp::y;
  std::string measured_on;     // "rest pose", "first frame", "frame K", or empty when none stands up
  int reference_frame = -1;    // the frame measured when the rest pose does not stand up, else -1
  double height_units = 0;     // the joints' spread along the up axis, in the file's units
  bool plausible = true;       // the height, in the unit used, is a human's 1.0-2.2 m

  double height_m() const { return height_units * metres_per_unit; }
  // "cmu (0.056444 m per unit, inferred: 25.5 units tall in the rest pose, 1.44 m), Y up", and when
  // a frame stands in for the rest pose "; the rest pose does not stand up, so the first frame is
  // the rest pose"
  std::string description() const;
  // Why the guess is doubtful, naming the file; empty when plausible.
  std::string warning(const std::string& path) const;
};

// Infers from `raw`, a clip loaded with metres_per_unit 1 and up Y (the file's numbers as they
// are); `metres_per_unit`, when given, is used instead of the inferred unit.
BvhFrameGuess guess_bvh_frame(const Clip& raw, std::optional<double> metres_per_unit = std::nullopt);

// `raw` (loaded as above) in another unit and up axis: what load_bvh gives with those options,
// offsets and translations bit for bit (C only permutes axes and flips signs), rotations to
// double rounding. Throws std::invalid_argument for a unit that is not positive and finite.
Clip with_bvh_frame(Clip raw, double metres_per_unit, BvhUp up);

// The clip with frame `frame`'s local pose as its skeleton's rest pose (rest offsets and
// rotations): every frame poses exactly as before, since a frame's rotations and translations
// replace the rest ones. Throws std::invalid_argument for a frame the clip does not have.
Clip with_rest_from_frame(Clip clip, int frame);

struct LoadedBvh {
  Clip clip;
  BvhFrameGuess frame;
};
// Loads a BVH file with the given unit, or the inferred one when none is given, and the inferred
// up axis; when the rest pose does not stand up, the frame measured instead is the rest pose
// (frame.reference_frame). Throws as load_bvh.
LoadedBvh load_bvh_inferring_frame(const std::string& path, std::optional<double> metres_per_unit = std::nullopt);

}  // namespace odyssey::io
