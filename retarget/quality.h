// Retargeting at a quality, the one entry every caller uses: fast is retarget_fast (retarget.h:
// pair and align the rigs, contacts, transfer, metrics); balanced and accurate refine its result
// with Ceres (refine.h) from the quality's defaults or the options given. The choice between the
// qualities lives here alone.
#pragma once

#include <optional>
#include <string>

#include "retarget/refine.h"
#include "retarget/retarget.h"

namespace odyssey::retarget {

struct Retargeting {
  RetargetResult result;                // result.transfer.clip: the target's motion
  std::optional<RefineSummary> refined;  // balanced and accurate
  double fast_seconds = 0;              // wall clock of retarget_fast
};

// `refine_options` (default: default_refine_options(quality)) must be the quality's: a refinement
// of another quality is std::invalid_argument; so are what retarget_fast and refine throw.
Retargeting retarget(const Clip& source, const BoneMap& source_map, const Character& target, const BoneMap& target_map,
                     Quality quality, const RetargetOptions& options = {},
                     const std::optional<RefineOptions>& refine_options = std::nullopt,
                     const std::string& source_name = "source");

}  // namespace odyssey::retarget
