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

// Metres per BVH unit: "cmu" (0.056444, the CMU conversions), "cm", "mm", "m", "in", or a positive
// number of metres; empty for anything else.
std::optional<double> parse_bvh_units(std::string_view units);
inline constexpr const char* kBvhUnitsHelp = "cmu (0.056444 m, the CMU conversions), cm, mm, m, in, or metres per unit";

}  // namespace odyssey::io
