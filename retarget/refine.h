// Refinement of a transferred clip with Ceres (qualities `balanced` and `accurate`). DRAFT
// INTERFACE by the lead: the refinement engineer owns this file and may extend it, keeping
// Quality, parse_quality, quality_name, default_refine_options and refine() as declared.
#pragma once

#include <optional>
#include <string_view>

#include "retarget/retarget.h"

namespace odyssey::retarget {

enum class Quality { fast, balanced, accurate };
std::optional<Quality> parse_quality(std::string_view text);
const char* quality_name(Quality quality);

struct RefineOptions {
  // Term weights and solver settings; defaults per quality from default_refine_options().
  int threads = 1;  // independent windows solved in parallel
};

RefineOptions default_refine_options(Quality quality);

// Refines result.transfer.clip in place and recomputes result.report.result_metrics (and sets
// report.quality and the refine timing). `source` is the clip the result was transferred from.
void refine(RetargetResult& result, const Clip& source, const RefineOptions& options);

}  // namespace odyssey::retarget
