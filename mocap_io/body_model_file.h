// SMPL / SMPL-H / SMPL-X body model files in the smplx Python package's npz layout:
// v_template (V,3), f (F,3), J_regressor (J,V), weights (V,J), kintree_table (2,J) with the root
// parent stored as -1 or as uint32 -1 (4294967295), shapedirs (V,3,S), posedirs (V,3,9(J-1)),
// hands_componentsl/r (45,45), hands_meanl/r (45), plus landmark arrays the forward pass does
// not use. The kind follows from the joint count (24, 52, 55). For SMPL-X, shapedirs holds shape
// then expression directions: with 400 or more columns expression starts at column 300 (the
// released 300+100 layout), otherwise the columns split in half (the 10+10 layout).
#pragma once

#include <string>
#include <vector>

#include "skeleton/body_model.h"

namespace odyssey::io {

// Throws InputError naming the file and the problem (missing key, wrong shape, NaN, bad tree).
BodyModel load_body_model(const std::string& path);

}  // namespace odyssey::io
