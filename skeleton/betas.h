// What to do when a sequence's betas (shape coefficients) do not match the body model's number
// of shape directions. Real AMASS SMPL-H and SMPL-X files carry 16 betas; SMPL-X model files
// hold 10 or 300 shape directions (and 10 or 100 expression directions after them), so the
// counts differ on nearly every real pair of files.
//
// The model's shape count is BodyModel::shape_count, which comes from the model file's layout
// (mocap_io/body_model_file.h): shapedirs (V,3,S) holds the shape directions then, for SMPL-X,
// the expression directions (S >= 400: 300 shape and the rest expression; S < 400: shape and
// expression halves, the smplx package's 10 + 10 files); SMPL and SMPL-H hold shape directions
// only. The count of betas in the sequence is never used to tell shape from expression: extra
// betas are dropped, never read as expression coefficients.
//
// Policies (CLI `--betas`, scene files' actor key `betas`):
//   fit       (default) the model's shape directions: extra betas are dropped with a warning
//             that says how many and their largest magnitude, missing ones are zeros;
//   truncate  extra betas are dropped (with the same warning); fewer betas than directions is
//             an error;
//   pad       missing betas are zeros; more betas than directions is an error;
//   error     any mismatch is an error naming both counts.
// A sequence with no betas at all is the mean shape (all zeros) under every policy: AMASS files
// without a `betas` key mean exactly that.
#pragma once

#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "skeleton/body_model.h"

namespace odyssey {

enum class BetasPolicy { fit, truncate, pad, error };

const char* betas_policy_name(BetasPolicy policy);
// "fit", "truncate", "pad" or "error"; nullopt for anything else.
std::optional<BetasPolicy> parse_betas_policy(std::string_view text);
// "fit, truncate, pad or error", for messages.
inline constexpr const char* kBetasPolicyNames = "fit, truncate, pad or error";

struct BetasFit {
  std::vector<double> betas;  // exactly model_count values: what set_shape is given
  BetasPolicy policy = BetasPolicy::fit;
  int file_count = 0;             // betas in the sequence
  int model_count = 0;            // the model's shape directions
  int dropped = 0;                // trailing betas dropped (file_count - model_count when positive)
  double largest_dropped = 0;     // the largest |beta| among the dropped ones (0 when none)
  int padded = 0;                 // zeros appended (model_count - file_count when positive)

  // "dropped 6 betas beyond the model's 10 shape directions (largest magnitude 1.234)", or empty
  // when nothing was dropped.
  std::string warning() const;
  // One line: "16 in the sequence, 10 shape directions in the model, policy fit: dropped 6
  // (largest magnitude 1.234), padded 0".
  std::string summary() const;
};

// Fits `betas` to `model`'s shape directions under `policy`. Throws std::invalid_argument when
// the policy refuses the counts, naming both ("16 betas in the sequence, the model has 10 shape
// directions: --betas error refuses any mismatch"); callers add the file.
BetasFit fit_betas(const BodyModel& model, std::span<const double> betas, BetasPolicy policy = BetasPolicy::fit);

}  // namespace odyssey
