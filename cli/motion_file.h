// What kind of file a path holds, decided from its contents (npz keys) and extension, and the
// BVH unit option shared by the subcommands that read BVH.
#pragma once

#include <string>

#include "cli/args.h"

namespace odyssey::cli {

enum class MotionFileKind { Bvh, Amass, BodyModel, Npz, Npy };

// Throws io::InputError when the file does not exist or is of no supported kind.
MotionFileKind detect_motion_file(const std::string& path);

// --bvh-units: "cmu" (0.056444 m per unit), "cm", "mm", "m", "in", or a number of metres per unit.
void add_bvh_units_option(Args& args);
double bvh_metres_per_unit(const Args& args);

}  // namespace odyssey::cli
