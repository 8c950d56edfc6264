#include "skeleton/betas.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace odyssey {
namespace {

std::string number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.6g", value);
  return text;
}

std::string count(int n, const char* one, const char* many) { return std::to_string(n) + " " + (n == 1 ? one : many); }

}  // namespace

const char* betas_policy_name(BetasPolicy policy) {
  switch (policy) {
    case BetasPolicy::fit: return "fit";
    case BetasPolicy::truncate: return "truncate";
    case BetasPolicy::pad: return "pad";
    case BetasPolicy::error: return "error";
  }
  return "unknown";
}

std::optional<BetasPolicy> parse_betas_policy(std::string_view text) {
  for (BetasPolicy policy : {BetasPolicy::fit, BetasPolicy::truncate, BetasPolicy::pad, BetasPolicy::error}) {
    if (text == betas_policy_name(policy)) return policy;
  }
  return std::nullopt;
}

std::string BetasFit::warning() const {
  if (dropped == 0) return {};
  return "dropped " + count(dropped, "beta", "betas") + " beyond the model's " +
         count(model_count, "shape direction", "shape directions") + " (" + std::to_string(file_count) +
         " in the sequence; largest magnitude dropped " + number(largest_dropped) + ")";
}

std::string BetasFit::summary() const {
  std::string text = std::to_string(file_count) + " in the sequence, " +
                     count(model_count, "shape direction", "shape directions") + " in the model, policy " +
                     betas_policy_name(policy) + ": dropped " + std::to_string(dropped);
  if (dropped > 0) text += " (largest magnitude " + number(largest_dropped) + ")";
  return text + ", padded " + std::to_string(padded);
}

BetasFit fit_betas(const BodyModel& model, std::span<const double> betas, BetasPolicy policy) {
  BetasFit fit;
  fit.policy = policy;
  fit.file_count = static_cast<int>(betas.size());
  fit.model_count = model.shape_count;
  const int file = fit.file_count, directions = fit.model_count;
  const std::string counts = count(file, "beta", "betas") + " in the sequence, the model has " +
                             count(directions, "shape direction", "shape directions");
  if (file > directions) {
    if (policy == BetasPolicy::error) {
      throw std::invalid_argument(counts + ": the betas policy 'error' refuses any mismatch (fit or truncate drop the extra betas)");
    }
    if (policy == BetasPolicy::pad) {
      throw std::invalid_argument(counts + ": the betas policy 'pad' only pads missing betas (fit or truncate drop the extra ones)");
    }
  } else if (file < directions && file > 0) {
    // No betas at all is the mean shape, which every policy accepts.
    if (policy == BetasPolicy::error) {
      throw std::invalid_argument(counts + ": the betas policy 'error' refuses any mismatch (fit or pad use zeros for the missing betas)");
    }
    if (policy == BetasPolicy::truncate) {
      throw std::invalid_argument(counts + ": the betas policy 'truncate' only drops extra betas (fit or pad use zeros for the missing ones)");
    }
  }
  const int kept = std::min(file, directions);
  fit.betas.assign(betas.begin(), betas.begin() + kept);
  fit.betas.resize(std::size_t(directions), 0.0);
  fit.dropped = std::max(0, file - directions);
  fit.padded = std::max(0, directions - file);
  for (int i = kept; i < file; ++i) fit.largest_dropped = std::max(fit.largest_dropped, std::abs(betas[std::size_t(i)]));
  return fit;
}

}  // namespace odyssey
