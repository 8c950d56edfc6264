// AMASS motion sequences (.npz), both directions.
//
// Keys read:
//   poses         (T,165) SMPL-X, (T,156) SMPL-H or (T,72) SMPL: axis-angle per joint in model
//                 order, which also fixes the kind (55, 52 or 24 joints);
//   or, without `poses`, the SMPL-X split keys root_orient (T,3), pose_body (T,63),
//                 pose_hand (T,90: left 45 then right 45), pose_jaw (T,3), pose_eye (T,6: left 3
//                 then right 3), assembled into the 165-D pose; with root_orient, pose_body and
//                 pose_hand but neither pose_jaw nor pose_eye they make a 156-D SMPL-H pose;
//   trans         (T,3), required;
//   betas         (N) or (1,N), any N; absent means the mean shape (no betas);
//   gender        text (numpy U) or bytes (numpy S), 0-d or one element; absent means "neutral";
//   mocap_frame_rate or mocap_framerate   one number, required (both present must agree).
// Any numeric dtype is accepted for the arrays. When `poses` is present, split keys beside it
// (AMASS SMPL-X files have both) must agree with it to 1e-6. Every key not read (pickled object
// arrays included, which are never unpickled) is listed in AmassFile::skipped_keys. Every
// problem throws InputError(path, ...) naming the key and the
// shapes involved, e.g. "'trans' has shape (10,2), expected (T,3) with T=12 (from 'poses')", and
// a NaN or infinity names the key and the frame (row) it is in.
//
// write_amass writes `poses` (T,3J), `trans` (T,3), `betas` (N), `gender` (0-d unicode),
// `mocap_frame_rate` (0-d float64), and for SMPL-X also the five split keys, all float64 and
// deflated. numpy's np.load reads the result; load_amass reads it back to the same values.
#pragma once

#include <string>
#include <vector>

#include "skeleton/body_sequence.h"

namespace odyssey::io {

// A sequence with what the file held beside it.
struct AmassFile {
  BodySequence sequence;
  std::string pose_keys;                  // "poses" or "split keys" (root_orient, pose_body, ...)
  std::string frame_rate_key;             // mocap_frame_rate or mocap_framerate
  std::vector<std::string> skipped_keys;  // present in the file but not read, in archive order
};

AmassFile load_amass_file(const std::string& path);
// The sequence alone.
BodySequence load_amass(const std::string& path);

// Writes through a temporary file renamed on completion, so a failed write leaves nothing at
// `path`. Throws std::invalid_argument when the sequence does not validate, InputError on I/O.
void write_amass(const std::string& path, const BodySequence& sequence);

}  // namespace odyssey::io
