// The motion options shared by the subcommands: the BVH unit (commands that read BVH) and the
// betas policy (commands that take --model).
#pragma once

#include <optional>

#include "cli/args.h"
#include "skeleton/betas.h"

namespace odyssey::cli {

// --bvh-units: see io::parse_bvh_units; empty for "auto" (the default: io::guess_bvh_frame infers it).
void add_bvh_units_option(Args& args);
std::optional<double> bvh_metres_per_unit(const Args& args);

// --betas fit|truncate|pad|error (default fit): see skeleton/betas.h.
void add_betas_option(Args& args);
BetasPolicy betas_policy(const Args& args);

}  // namespace odyssey::cli
