#include "cli/motion_file.h"

#include "mocap_io/motion_file.h"

namespace odyssey::cli {

void add_bvh_units_option(Args& args) {
  args.option("bvh-units", "UNITS", std::string("BVH length unit: ") + io::kBvhUnitsHelp, "cm");
}

double bvh_metres_per_unit(const Args& args) {
  const std::string units = args.get("bvh-units");
  const std::optional<double> value = io::parse_bvh_units(units);
  if (!value) throw UsageError("--bvh-units expects cmu, cm, mm, m, in or a positive number, got '" + units + "'");
  return *value;
}

}  // namespace odyssey::cli
