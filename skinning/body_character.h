// The SMPL-family body model as a rigged character, so that the skinning engine, point sampling
// and the writers treat the body like any glTF character. At shape beta (the mean shape when no
// betas are given):
//
//   skeleton   the one clip_from_body_sequence (skeleton/body_clip.h) drives: the model's joint
//              names and parents, rest offsets J_j(beta) - J_parent(j)(beta) and J_0(beta) for the
//              root, rest rotations identity except the root's C = y_up_to_z_up();
//   mesh       one mesh, "body": the shaped template v_shaped(beta) in the model's own Y-up frame,
//              with the model's triangles;
//   skin       slot j is joint j with inverse_bind_j = [I | -J_j(beta)]. The rest world transform
//              of joint j is W_j = [C | C J_j + (J_0 - C J_0)], so W_j inverse_bind_j v is the same
//              rigid placement C (v - J_0) + J_0 for every j, and under a body clip's frame
//              (world_0 = [R_0 | transl + J_0]) each slot's matrix is the smplx skinning matrix
//              A_j = G_j [I | -J_j] plus the translation;
//   weights    each vertex's four largest weights divided by their sum (the character holds four
//              influences a vertex); a warning counts the vertices that lost a non-zero weight.
//
// So skinning this character at a body clip's frame is the body model's forward pass without
// pose correctives, exactly so where no vertex has more than four weights. Expression and pose
// correctives are not part of a character.
#pragma once

#include <span>

#include "skeleton/body_model.h"
#include "skeleton/character.h"

namespace odyssey::skinning {

// Throws std::invalid_argument when the model does not validate.
Character body_character(const BodyModel& model, std::span<const double> betas = {});

}  // namespace odyssey::skinning
