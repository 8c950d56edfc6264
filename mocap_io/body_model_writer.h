// Writes SMPL-family body models in the smplx Python package's npz layout: the files its SMPL,
// SMPLH and SMPLX classes load with ext='npz', and that load_body_model reads back.
//
//   v_template (V,3) f4, f (F,3) u4, J_regressor (J,V) f4, weights (V,J) f4,
//   kintree_table (2,J) i8 (row 0 parents with the root's stored as 4294967295, row 1 = 0..J-1),
//   shapedirs (V,3,S) f4, posedirs (V,3,9(J-1)) f4,
//   SMPL-H and SMPL-X: hands_componentsl/r (45,45) f4, hands_meanl/r (45,) f4,
//   SMPL-X: lmk_faces_idx (L,) i8, lmk_bary_coords (L,3) f4, and with the contour
//           dynamic_lmk_faces_idx (79,17) i8, dynamic_lmk_bary_coords (79,17,3) f4.
//
// The smplx package takes SMPL-X expression directions from column 300 when shapedirs has 400
// or more columns and from column 10 otherwise, so an SMPL-X model is written as 10 + 10 or
// 300 + 100 columns as it is, and any other split padded with zero columns to 300 + 100 (more
// than 300 shape or 100 expression directions is an error). What the package needs and a model
// in memory may lack is written neutral: zero posedirs, identity hand components with zero means,
// and, for SMPL-X without landmarks, empty lmk_faces_idx (0,) and lmk_bary_coords (0,3) (the
// contour arrays are only read with use_face_contour=True and are then left out).
//
// Float arrays are stored as float32 (the files' precision), deflated. The file is written under
// a temporary name and renamed when complete, so a failed write leaves nothing at `path`.
// Throws std::invalid_argument for a model that fails BodyModel::validate() or landmarks that
// do not fit it, and InputError when the file cannot be written.
#pragma once

#include <string>

#include "skeleton/body_model.h"
#include "synthetic/synthetic_body.h"

namespace odyssey::io {

void write_body_model(const std::string& path, const BodyModel& model, const FaceLandmarks* landmarks = nullptr);
void write_body_model(const std::string& path, const SyntheticBody& body);

}  // namespace odyssey::io
