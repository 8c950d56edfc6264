#include "retarget/quality.h"

#include <chrono>
#include <stdexcept>

namespace odyssey::retarget {

Retargeting retarget(const Clip& source, const BoneMap& source_map, const Character& target, const BoneMap& target_map,
                     Quality quality, const RetargetOptions& options, const std::optional<RefineOptions>& refine_options,
                     const std::string& source_name) {
  if (quality != Quality::fast && refine_options && refine_options->quality != quality) {
    throw std::invalid_argument("the refinement options are " + std::string(quality_name(refine_options->quality)) +
                                "'s, the request asks for " + quality_name(quality));
  }
  Retargeting out;
  const auto start = std::chrono::steady_clock::now();
  out.result = retarget_fast(source, source_map, target, target_map, options, source_name);
  out.fast_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (quality != Quality::fast) out.refined = refine(out.result, source, refine_options.value_or(default_refine_options(quality)));
  return out;
}

}  // namespace odyssey::retarget
