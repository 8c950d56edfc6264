// What kind of file a path holds, decided from its contents (npz keys) and extension, and the
// names of BVH length units, for every command, scene and batch file that names a motion.
#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace odyssey::io {

enum class MotionFileKind { Bvh, Amass, BodyModel, Npz, Npy };

// Throws InputError when the file does not exist or is of no supported kind.
MotionFileKind detect_motion_file(const std::string& path);

// Metres per BVH unit: a name of io::kBvhUnits ("cmu" 0.056444, the CMU conversions; "m", "dm",
// "cm", "mm", "in", "ft") or a positive number of metres; empty for anything else ("auto" too:
// callers that infer the unit, see io::guess_bvh_frame, handle it before).
std::optional<double> parse_bvh_units(std::string_view units);
inline constexpr const char* kBvhUnitsHelp =
    "auto (inferred from the skeleton's height, assuming a human performer), cmu (0.056444 m, the CMU conversions), "
    "m, dm, cm, mm, in, ft, or metres per unit";

}  // namespace odyssey::io
