// A synthetic SMPL-X body model: a plausible 1.70 m T-pose humanoid in exactly the array layout of
// the licensed SMPL-X file (10,475 vertices, 20,908 triangles, 55 joints, 300 shape + 100
// expression directions, 486 pose-corrective directions, hand PCA, face landmarks), so that the
// whole toolkit runs without that file. It is built, not learned:
//
// - Geometry. One skin swept along the skeleton as tubes of rings (torso, neck and head as one
//   tube; arms ending in flat palms; legs ending in heels; feet; fingers), joined where a limb
//   leaves its parent by cutting a rectangular block of quads out of the parent and using the
//   block's rim as the child's first ring. The hip and palm ends are closed by quad lids that the
//   legs and fingers leave from in the same way; the other ends close on a pole. Two eyeball
//   spheres sit behind eye openings, and the mouth is a slit that opens with the jaw. The counts
//   force this topology: a closed surface of sphere type has F = 2V - 4, and 10,475 and 20,908
//   need 2V - F = 42, which is this skin with three openings (4 - 2 * 3 + 36 rim edges = 34)
//   plus the two closed eyeballs (4 each). Every triangle faces outward.
// - Skinning weights fall off smoothly with the distance to each bone, among the bones a body
//   part may follow (a finger never follows its neighbour), with at most 4 influences a vertex.
//   The jaw moves the lower lip and chin only; the eyeballs follow the eyes rigidly.
// - J_regressor rows are the maximum-entropy convex combinations of the vertices around each
//   joint that reproduce the joint centre exactly, so shape changes move joints with the surface.
// - Shape directions 0-9 are skeletal deformations blended by the skinning weights (0 size,
//   1 girth, 2 limb length, 3 shoulder width, 4 hip width, 5 torso length, 6 head size, 7 torso
//   depth, 8 arm versus leg girth, 9 hand and foot size); 10-299 are small smooth bulges with
//   compact support. Expression directions (columns 300-399) move face vertices only: 0 mouth
//   open, 1 smile, 2 brows up, 3 frown, 4 pucker, 5 cheeks puffed, 6 eyes closed, 7 mouth corners
//   down, 8 nose wrinkle, 9 jaw sideways, then small local bulges.
// - Pose correctives turn the vertices of each joint's blend zone a little further with the
//   joint, countering the collapse of linear blend skinning; they are exactly zero away from the
//   joints, so the file compresses to about 2 MB.
// - The smplx package's extra keypoint vertices (nose 9120, eyes, ears, toes, heels, fingertips;
//   its vertex_ids.py) sit on those features, so its OpenPose-style joints land where they should.
//
// The dense variant, for benchmarks that must not time a mostly-zero model, has the same
// geometry and shape space but spreads skinning weights over up to 8 joints (4.5 on average) and
// fills the pose correctives on every vertex, as the licensed model does.
//
// Model frame as in SMPL-X: Y up, facing +Z, the body's left is +X, pelvis near the origin
// (y = -0.355), soles at y = -1.285. Every array holds float32-representable values, so a model
// and the file written from it evaluate identically. The seed varies the proportions slightly (a
// small random mix of shape directions 1-9 baked into the template, then direction 0 holds the
// height at 1.70 +- 0.008 m) and the random directions; the random draws do not depend on the
// standard library.
#pragma once

#include <vector>

#include "skeleton/body_model.h"

namespace odyssey {

// Points on the mesh given as a triangle and barycentric coordinates, in the smplx package's
// SMPL-X layout (lmk_faces_idx / lmk_bary_coords and their dynamic counterparts).
struct FaceLandmarks {
  static constexpr int kStaticCount = 51;   // iBUG-68 points 17-67: brows, nose, eyes, lips
  static constexpr int kContourCount = 17;  // iBUG-68 points 0-16: the jaw line, right ear to left
  static constexpr int kYawBins = 79;       // head yaw bins, see contour_faces

  std::vector<int> faces;    // kStaticCount triangle indices
  RowMatrixXd barycentric;   // kStaticCount x 3, rows sum to 1
  // The jaw line seen from the front moves over the face as the head turns. Row b holds the
  // contour for a yaw of a(b) degrees, a(b) = b for b <= 39 and 39 - b above (so 40..78 are
  // -1..-39), where the smplx package computes a = -(rotation of the neck chain about y) and
  // clamps it to [-39, 39]: a turn to the body's left (toward +X) is a negative a.
  RowMatrixXi contour_faces;               // kYawBins x kContourCount
  RowMatrixXd contour_barycentric;         // (kYawBins * kContourCount) x 3, row b * 17 + k
};

struct SyntheticBody {
  BodyModel model;
  FaceLandmarks landmarks;
};

// Deterministic for a seed; takes a fraction of a second. `dense`: the benchmark variant above.
SyntheticBody make_synthetic_body(unsigned seed, bool dense = false);

}  // namespace odyssey
