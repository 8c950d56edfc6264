// The BVH unit option shared by the subcommands that read BVH.
#pragma once

#include "cli/args.h"

namespace odyssey::cli {

// --bvh-units: see io::parse_bvh_units.
void add_bvh_units_option(Args& args);
double bvh_metres_per_unit(const Args& args);

}  // namespace odyssey::cli
