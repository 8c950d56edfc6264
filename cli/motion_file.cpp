#include "cli/motion_file.h"

#include "mocap_io/motion_file.h"

namespace odyssey::cli {

void add_bvh_units_option(Args& args) {
  args.option("bvh-units", "UNITS", std::string("BVH length unit: ") + io::kBvhUnitsHelp, "auto");
}

std::optional<double> bvh_metres_per_unit(const Args& args) {
  const std::string units = args.get("bvh-units");
  if (units == "auto") return std::nullopt;
  const std::optional<double> value = io::parse_bvh_units(units);
  if (!value) throw UsageError("--bvh-units expects auto, cmu, m, dm, cm, mm, in, ft or a positive number, got '" + units + "'");
  return value;
}

void add_betas_option(Args& args) {
  args.option("betas", "POLICY",
              "an AMASS sequence's betas against the model's shape directions: fit (extra betas dropped with a "
              "warning, missing ones zero), truncate (drop extras, refuse fewer), pad (zeros for missing ones, "
              "refuse extras) or error (refuse any mismatch)",
              "fit");
}

BetasPolicy betas_policy(const Args& args) {
  const std::string text = args.get("betas");
  const std::optional<BetasPolicy> policy = parse_betas_policy(text);
  if (!policy) throw UsageError(std::string("--betas expects ") + kBetasPolicyNames + ", got '" + text + "'");
  return *policy;
}

}  // namespace odyssey::cli
