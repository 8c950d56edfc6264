// The synthetic SMPL-X body: the counts, names and tree of the licensed model, an oriented
// surface that is closed but for the face openings, convex skinning weights and regressor,
// plausible proportions, a shape space that does what its columns say, landmarks on the face,
// determinism for a seed, and the file: read back by load_body_model and by numpy exactly the way
// the smplx package reads it, with its forward pass replayed against BodyModelEvaluator.

// GCC 12 reports -Wmaybe-uninitialized inside its own AVX-512 intrinsics when Eigen's reductions
// are inlined (GCC bug 105593, fixed in GCC 13); the diagnostic is tied to where the intrinsics
// are first included, so it is silenced for those headers only, as in skeleton/body_model.cpp.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <Eigen/Core>
#pragma GCC diagnostic pop

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <random>
#include <span>
#include <sstream>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "mocap_io/body_model_file.h"
#include "mocap_io/body_model_writer.h"
#include "mocap_io/npy.h"
#include "synthetic/synthetic_body.h"
#include "test_support.h"

namespace {

namespace fs = std::filesystem;
using odyssey::BodyModel;
using odyssey::FaceLandmarks;
using odyssey::make_synthetic_body;
using odyssey::RowMatrixXd;
using odyssey::SyntheticBody;
using Eigen::Vector3d;

constexpr int kVertices = 10475, kFaces = 20908, kJoints = 55;
constexpr double kFloor = -1.285;  // the design's sole height

const SyntheticBody& body() {
  static const SyntheticBody generated = make_synthetic_body(0);
  return generated;
}
const SyntheticBody& dense_body() {
  static const SyntheticBody generated = make_synthetic_body(0, true);
  return generated;
}

fs::path scratch(const std::string& name) {
  const fs::path dir = odyssey::test_support::scratch_root() / "synthetic_body";
  fs::create_directories(dir);
  return dir / name;
}

Eigen::MatrixXd dense(const Eigen::SparseMatrix<double, Eigen::RowMajor>& m) { return Eigen::MatrixXd(m); }
RowMatrixXd joints_of(const BodyModel& model) { return model.j_regressor * model.v_template; }
Vector3d vertex(const BodyModel& model, int v) { return model.v_template.row(v).transpose(); }

int joint(const BodyModel& model, const std::string& name) {
  const auto it = std::find(model.joint_names.begin(), model.joint_names.end(), name);
  EXPECT_NE(it, model.joint_names.end()) << name;
  return static_cast<int>(it - model.joint_names.begin());
}

// The model's vertices displaced by shape (and expression) coefficients.
RowMatrixXd shaped(const BodyModel& model, const std::map<int, double>& coefficients) {
  RowMatrixXd out = model.v_template;
  for (const auto& [column, value] : coefficients) {
    for (int v = 0; v < model.vertex_count(); ++v) {
      for (int c = 0; c < 3; ++c) out(v, c) += value * model.shapedirs(3 * v + c, column);
    }
  }
  return out;
}
double height(const RowMatrixXd& vertices) { return vertices.col(1).maxCoeff() - vertices.col(1).minCoeff(); }

// Generalised winding number of the surface around p: the solid angles of all triangles over
// 4 pi (Van Oosterom and Strackee: tan(omega / 2) = a.(b x c) / (|a||b||c| + (a.b)|c| +
// (b.c)|a| + (c.a)|b|) with a, b, c the corners relative to p). 1 inside a closed surface, 0
// outside; small openings only dent it.
double winding_number(const BodyModel& model, const Vector3d& p) {
  double total = 0.0;
  for (int f = 0; f < model.faces.rows(); ++f) {
    const Vector3d a = vertex(model, model.faces(f, 0)) - p, b = vertex(model, model.faces(f, 1)) - p,
                   c = vertex(model, model.faces(f, 2)) - p;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    total += 2.0 * std::atan2(a.dot(b.cross(c)), la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb);
  }
  return total / (4.0 * std::numbers::pi);
}

TEST(SyntheticBodyTest, HasTheCountsAndLayoutOfSmplx) {
  const BodyModel& model = body().model;
  EXPECT_NO_THROW(model.validate());
  EXPECT_EQ(model.kind, odyssey::BodyModelKind::SMPLX);
  EXPECT_EQ(model.vertex_count(), kVertices);
  EXPECT_EQ(model.faces.rows(), kFaces);
  EXPECT_EQ(model.joint_count(), kJoints);
  EXPECT_EQ(model.shape_count, 300);
  EXPECT_EQ(model.expression_count, 100);
  EXPECT_EQ(model.shapedirs.rows(), 3 * kVertices);
  EXPECT_EQ(model.posedirs.rows(), 3 * kVertices);
  EXPECT_EQ(model.posedirs.cols(), 9 * (kJoints - 1));
}

TEST(SyntheticBodyTest, JointNamesAndParentsMatchTheSharedTable) {
  std::ifstream table(std::string(ODYSSEY_SHARED_DIR) + "/assets/smplx_joints_55.tsv");
  ASSERT_TRUE(table) << "shared/assets/smplx_joints_55.tsv";
  std::vector<std::string> names;
  std::vector<int> parents;
  for (std::string line; std::getline(table, line);) {
    if (line.empty() || line[0] == '#' || line.rfind("index", 0) == 0) continue;
    std::istringstream row(line);
    int index, parent;
    std::string name;
    row >> index >> name >> parent;
    EXPECT_EQ(index, static_cast<int>(names.size()));
    names.push_back(name);
    parents.push_back(parent);
  }
  EXPECT_EQ(body().model.joint_names, names);
  EXPECT_EQ(body().model.parents, parents);
}

// Every triangle is proper, every edge is used at most once in each direction (one consistent
// orientation), and the only open edges are the rims of the two eye openings (10 edges each)
// and the mouth slit (16): 36 edges, each rim vertex on exactly two of them. The enclosed volume
// is positive (normals point out) and that of a 70 kg adult.
TEST(SyntheticBodyTest, SurfaceIsOrientedAndClosedButForTheFaceOpenings) {
  const BodyModel& model = body().model;
  std::map<std::pair<int, int>, int> directed;
  double volume = 0.0, smallest_area = 1.0;
  for (int f = 0; f < model.faces.rows(); ++f) {
    const int a = model.faces(f, 0), b = model.faces(f, 1), c = model.faces(f, 2);
    ASSERT_TRUE(a >= 0 && a < kVertices && b >= 0 && b < kVertices && c >= 0 && c < kVertices) << "face " << f;
    const Vector3d pa = vertex(model, a), pb = vertex(model, b), pc = vertex(model, c);
    smallest_area = std::min(smallest_area, 0.5 * (pb - pa).cross(pc - pa).norm());
    volume += pa.dot(pb.cross(pc)) / 6.0;
    for (const auto& edge : {std::pair{a, b}, std::pair{b, c}, std::pair{c, a}}) ++directed[edge];
  }
  EXPECT_GT(smallest_area, 1e-7);  // m^2: no degenerate triangles
  int reused = 0, open = 0;
  std::map<int, int> open_edges_at;
  for (const auto& [edge, count] : directed) {
    if (count > 1) ++reused;
    if (!directed.count({edge.second, edge.first})) {
      ++open;
      ++open_edges_at[edge.first];
      ++open_edges_at[edge.second];
    }
  }
  EXPECT_EQ(reused, 0);
  EXPECT_EQ(open, 36);
  for (const auto& [v, count] : open_edges_at) {
    EXPECT_EQ(count, 2) << "vertex " << v;
    EXPECT_GT(model.v_template(v, 1), 0.2) << "an opening away from the face at vertex " << v;
  }
  EXPECT_GT(volume, 0.055);
  EXPECT_LT(volume, 0.085);
}

TEST(SyntheticBodyTest, IsAnUprightTPoseFacingZInTheSmplxFrame) {
  const BodyModel& model = body().model;
  const RowMatrixXd j = joints_of(model);
  EXPECT_NEAR(height(model.v_template), 1.70, 0.02);
  EXPECT_NEAR(model.v_template.col(1).minCoeff(), kFloor, 0.01);
  EXPECT_NEAR(j(0, 0), 0.0, 1e-3);   // pelvis near the origin, as in SMPL-X
  EXPECT_NEAR(j(0, 1), -0.35, 0.03);
  EXPECT_GT(j(joint(model, "head"), 1), j(joint(model, "neck"), 1));
  EXPECT_GT(j(joint(model, "left_wrist"), 0), 0.6);  // left is +X, arms out
  EXPECT_NEAR(j(joint(model, "left_wrist"), 1), j(joint(model, "left_shoulder"), 1), 0.03);
  EXPECT_GT(j(joint(model, "left_foot"), 2), j(joint(model, "left_ankle"), 2) + 0.08);  // toes forward
  EXPECT_GT(j(joint(model, "left_eye_smplhf"), 2), j(joint(model, "head"), 2) + 0.05);  // eyes in front
  // Left-right symmetric: each left joint is the mirror image of its right twin.
  for (int l = 0; l < kJoints; ++l) {
    const std::string& name = model.joint_names[l];
    if (name.rfind("left_", 0) != 0) continue;
    const int r = joint(model, "right_" + name.substr(5));
    EXPECT_NEAR(j(l, 0), -j(r, 0), 1e-3) << name;
    EXPECT_NEAR(j(l, 1), j(r, 1), 1e-3) << name;
    EXPECT_NEAR(j(l, 2), j(r, 2), 1e-3) << name;
  }
}

TEST(SyntheticBodyTest, SkinningWeightsAreConvexWithAtMostFourInfluences) {
  const BodyModel& model = body().model;
  for (int v = 0; v < kVertices; ++v) {
    int count = 0;
    float sum = 0.0f;
    for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(model.weights, v); it; ++it) {
      ASSERT_GT(it.value(), 0.0) << "vertex " << v;
      ++count;
      sum += static_cast<float>(it.value());
    }
    ASSERT_LE(count, 4) << "vertex " << v;
    ASSERT_NEAR(sum, 1.0f, 1e-6f) << "vertex " << v;
  }
}

// Hands follow the fingers, the head its head, jaw and eye joints, and the jaw moves the lower
// face: the lower lip (the 5.5 mm slit is centred at y = 0.225 in the design) but not the upper.
TEST(SyntheticBodyTest, WeightsFollowTheRightBones) {
  const BodyModel& model = body().model;
  const Eigen::MatrixXd w = dense(model.weights);
  const int jaw = joint(model, "jaw"), head = joint(model, "head"), left_eye = joint(model, "left_eye_smplhf");
  const double mouth = joints_of(model)(jaw, 1) - 0.007;  // the design's mouth line, 7 mm below the jaw joint
  int finger_vertices = 0, eyeball_vertices = 0, upper_lip = 0, lower_lip = 0;
  for (int v = 0; v < kVertices; ++v) {
    const Vector3d p = vertex(model, v);
    const double fingers = w.row(v).segment(25, 30).sum();
    if (fingers > 0.5) {
      ++finger_vertices;
      EXPECT_GT(std::abs(p.x()), 0.69) << "vertex " << v;
    }
    if (w(v, jaw) > 0.0) {
      EXPECT_LT(p.y(), 0.25) << "vertex " << v;
      EXPECT_GT(p.z(), 0.0) << "vertex " << v;
    }
    if (std::abs(p.x()) < 0.015 && p.z() > 0.08 && std::abs(p.y() - mouth) < 0.006) {
      if (p.y() > mouth) {
        ++upper_lip;
        EXPECT_EQ(w(v, jaw), 0.0) << "upper lip vertex " << v;
      } else {
        ++lower_lip;
        EXPECT_GT(w(v, jaw), 0.5) << "lower lip vertex " << v;
      }
    }
    if (w(v, left_eye) > 0.0) {
      EXPECT_EQ(w(v, left_eye), 1.0) << "eyeballs are rigid";
      ++eyeball_vertices;
    }
    if (p.y() > 0.27) {
      EXPECT_GT(w(v, head) + w(v, left_eye) + w(v, left_eye + 1), 0.99) << "vertex " << v;
    }
  }
  EXPECT_GT(finger_vertices, 600);
  EXPECT_GT(eyeball_vertices, 100);
  EXPECT_GE(upper_lip, 3);
  EXPECT_GE(lower_lip, 3);
}

TEST(SyntheticBodyTest, RegressorRowsAreConvexAndJointsLieInsideTheBody) {
  const BodyModel& model = body().model;
  const Eigen::MatrixXd r = dense(model.j_regressor);
  EXPECT_GE(r.minCoeff(), 0.0);
  for (int j = 0; j < kJoints; ++j) {
    EXPECT_NEAR(r.row(j).sum(), 1.0, 1e-6) << model.joint_names[j];
    EXPECT_LE((r.row(j).array() > 0).count(), 1000) << model.joint_names[j] << ": a ring of vertices, not the body";
  }
  const RowMatrixXd j = joints_of(model);
  for (int i = 0; i < kJoints; ++i) {
    EXPECT_GT(winding_number(model, j.row(i).transpose()), 0.5) << model.joint_names[i];
  }
  // The eye joints are the eyeball centres.
  const Eigen::MatrixXd w = dense(model.weights);
  for (const char* eye : {"left_eye_smplhf", "right_eye_smplhf"}) {
    const int e = joint(model, eye);
    Vector3d centre = Vector3d::Zero();
    int count = 0;
    for (int v = 0; v < kVertices; ++v) {
      if (w(v, e) > 0.0) centre += vertex(model, v), ++count;
    }
    EXPECT_LT((centre / count - j.row(e).transpose()).norm(), 1e-4) << eye;
  }
}

TEST(SyntheticBodyTest, HandPcaIsOrthonormalMirroredAndCurledOnAverage) {
  const BodyModel& model = body().model;
  const Eigen::MatrixXd identity = Eigen::MatrixXd::Identity(45, 45);
  EXPECT_LT((model.hands_components_left * model.hands_components_left.transpose() - identity).cwiseAbs().maxCoeff(),
            1e-6);
  EXPECT_LT((model.hands_components_right * model.hands_components_right.transpose() - identity).cwiseAbs().maxCoeff(),
            1e-6);
  for (int j = 0; j < 15; ++j) {
    // Mirroring through X = 0 maps an axis-angle (x, y, z) to (x, -y, -z).
    EXPECT_EQ(model.hands_mean_right[3 * j], model.hands_mean_left[3 * j]);
    EXPECT_EQ(model.hands_mean_right[3 * j + 1], -model.hands_mean_left[3 * j + 1]);
    EXPECT_EQ(model.hands_mean_right[3 * j + 2], -model.hands_mean_left[3 * j + 2]);
    for (int k = 0; k < 45; ++k) {
      EXPECT_EQ(model.hands_components_right(k, 3 * j + 1), -model.hands_components_left(k, 3 * j + 1));
    }
  }
  // The fingers (not the thumb) curl toward the palm, about -Z on the left hand, by 0.1-0.4 rad.
  for (int j = 0; j < 12; ++j) {
    const Eigen::Vector3d r = model.hands_mean_left.segment<3>(3 * j);
    EXPECT_LT(r.z(), 0.0) << j;
    EXPECT_GT(r.norm(), 0.1) << j;
    EXPECT_LT(r.norm(), 0.4) << j;
  }
}

// Shape directions 0-9 do what the header says, the bulges and expressions are local, and most
// of the 400-column array is exactly zero (which is what keeps the file small).
TEST(SyntheticBodyTest, ShapeSpaceIsMeaningfulAndMostlyZero) {
  const BodyModel& model = body().model;
  const double h = height(model.v_template);
  EXPECT_NEAR(height(shaped(model, {{0, 1.0}})) / h, 1.04, 0.003);
  const RowMatrixXd rest = joints_of(model);
  const RowMatrixXd longer = model.j_regressor * shaped(model, {{2, 1.0}});
  const int ankle = joint(model, "left_ankle"), wrist = joint(model, "left_wrist");
  EXPECT_LT(longer(ankle, 1) - rest(ankle, 1), -0.03);
  EXPECT_GT(longer(wrist, 0) - rest(wrist, 0), 0.02);
  const RowMatrixXd heavier = shaped(model, {{1, 1.0}});
  double waist_before = 0.0, waist_after = 0.0;
  for (int v = 0; v < kVertices; ++v) {
    if (std::abs(model.v_template(v, 1) + 0.18) < 0.02 && std::abs(model.v_template(v, 0)) < 0.2) {
      waist_before += std::abs(model.v_template(v, 0));
      waist_after += std::abs(heavier(v, 0));
    }
  }
  EXPECT_GT(waist_after / waist_before, 1.08);

  int nonzero = 0, mouth_moves = 0;
  for (int v = 0; v < kVertices; ++v) {
    for (int c = 0; c < 3; ++c) {
      for (int k = 0; k < 400; ++k) {
        if (model.shapedirs(3 * v + c, k) == 0.0) continue;
        ++nonzero;
        if (k >= 300) {
          EXPECT_GT(model.v_template(v, 1), 0.15) << "expression " << k - 300 << " off the face at vertex " << v;
          EXPECT_GT(model.v_template(v, 2), 0.0) << "expression " << k - 300 << " off the face at vertex " << v;
        }
        if (k == 300 && c == 1 && model.shapedirs(3 * v + c, k) < 0.0) ++mouth_moves;  // mouth open: down
      }
    }
  }
  EXPECT_LT(nonzero, 0.1 * 3 * kVertices * 400);
  EXPECT_GT(mouth_moves, 20);
}

TEST(SyntheticBodyTest, PoseCorrectivesAreSmallAndZeroAwayFromJoints) {
  const BodyModel& model = body().model;
  int zero_rows = 0;
  for (int r = 0; r < model.posedirs.rows(); ++r) zero_rows += model.posedirs.row(r).cwiseAbs().maxCoeff() == 0.0f;
  EXPECT_GT(zero_rows, 0.15 * model.posedirs.rows());
  // Under a right-angle bend, R - I has entries up to 1: a corrective of at most a few centimetres.
  EXPECT_LT(model.posedirs.cwiseAbs().maxCoeff(), 0.02f);
}

TEST(SyntheticBodyTest, DenseVariantFillsCorrectivesAndSpreadsWeights) {
  const BodyModel& sparse = body().model;
  const BodyModel& model = dense_body().model;
  EXPECT_NO_THROW(model.validate());
  EXPECT_EQ(model.v_template, sparse.v_template);
  EXPECT_EQ(model.shapedirs, sparse.shapedirs);
  int most = 0;
  long total = 0;
  for (int v = 0; v < kVertices; ++v) {
    int count = 0;
    for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(model.weights, v); it; ++it) ++count;
    most = std::max(most, count);
    total += count;
  }
  EXPECT_EQ(most, 8);
  EXPECT_GT(static_cast<double>(total) / kVertices, 4.0);
  for (int r = 0; r < model.posedirs.rows(); ++r) {
    ASSERT_GT(model.posedirs.row(r).cwiseAbs().maxCoeff(), 0.0f) << "row " << r;
  }
}

TEST(SyntheticBodyTest, SameSeedSameModelOtherSeedOtherProportions) {
  const SyntheticBody a = make_synthetic_body(7), b = make_synthetic_body(7), c = make_synthetic_body(8);
  EXPECT_EQ(a.model.v_template, b.model.v_template);
  EXPECT_EQ(a.model.shapedirs, b.model.shapedirs);
  EXPECT_EQ(a.model.posedirs, b.model.posedirs);
  EXPECT_EQ(dense(a.model.weights), dense(b.model.weights));
  EXPECT_EQ(dense(a.model.j_regressor), dense(b.model.j_regressor));
  EXPECT_EQ(a.model.hands_components_left, b.model.hands_components_left);
  EXPECT_EQ(a.landmarks.faces, b.landmarks.faces);
  EXPECT_EQ(a.model.faces, c.model.faces);  // one topology for every seed
  EXPECT_GT((a.model.v_template - c.model.v_template).cwiseAbs().maxCoeff(), 1e-3);
  EXPECT_GT((a.model.shapedirs.col(100) - c.model.shapedirs.col(100)).cwiseAbs().maxCoeff(), 1e-4);
  EXPECT_NEAR(height(c.model.v_template), 1.70, 0.02);
}

// The vertices the smplx package reads as extra keypoints (smplx/vertex_ids.py) sit on them.
TEST(SyntheticBodyTest, SmplxKeypointVerticesSitOnTheirFeatures) {
  const BodyModel& model = body().model;
  const Eigen::MatrixXd w = dense(model.weights);
  const RowMatrixXd j = joints_of(model);
  int front = 0;
  for (int v = 0; v < kVertices; ++v) {
    if (model.v_template(v, 1) > 0.2 && model.v_template(v, 1) < 0.3 &&
        model.v_template(v, 2) > model.v_template(front, 2))
      front = v;
  }
  EXPECT_EQ(front, 9120) << "the nose tip";
  for (const auto& [id, eye] : {std::pair{9448, "left_eye_smplhf"}, std::pair{9929, "right_eye_smplhf"}}) {
    EXPECT_EQ(w(id, joint(model, eye)), 1.0) << eye;
    EXPECT_NEAR(model.v_template(id, 2) - j(joint(model, eye), 2), 0.0115, 1e-4) << eye << ": front of the eyeball";
  }
  for (const auto& [id, sign] : {std::pair{6, 1.0}, std::pair{616, -1.0}}) {
    EXPECT_GT(sign * model.v_template(id, 0), 0.06) << "ear " << id;
    EXPECT_NEAR(model.v_template(id, 1), 0.275, 0.02) << "ear " << id;
  }
  // Fingertips: the vertex of each finger farthest out along the arm.
  const std::vector<std::pair<int, std::string>> tips = {
      {5361, "left_thumb3"},  {4933, "left_index3"},  {5058, "left_middle3"},  {5169, "left_ring3"},
      {5286, "left_pinky3"},  {8079, "right_thumb3"}, {7669, "right_index3"}, {7794, "right_middle3"},
      {7905, "right_ring3"},  {8022, "right_pinky3"}};
  for (const auto& [id, name] : tips) {
    const int last = joint(model, name);
    EXPECT_GT(w(id, last), 0.5) << name;
    const double reach = (vertex(model, id) - j.row(last).transpose()).norm();
    for (int v = 0; v < kVertices; ++v) {
      if (w(v, last) > 0.5) {
        EXPECT_LE((vertex(model, v) - j.row(last).transpose()).norm(), reach + 1e-9) << name;
      }
    }
  }
  for (const auto& [toe, heel, side] : {std::tuple{5770, 8846, "left"}, std::tuple{8463, 8635, "right"}}) {
    const std::string s = side;
    EXPECT_LT(model.v_template(toe, 1), kFloor + 0.02) << s;
    EXPECT_LT(model.v_template(heel, 1), kFloor + 0.02) << s;
    EXPECT_GT(model.v_template(toe, 2), j(joint(model, s + "_foot"), 2)) << s;
    EXPECT_LT(model.v_template(heel, 2), j(joint(model, s + "_ankle"), 2)) << s;
  }
  EXPECT_LT(std::abs(model.v_template(5770, 0)), std::abs(model.v_template(5780, 0))) << "big toe on the inside";
}

// Landmarks, resolved the way the smplx package does (sum of barycentric weights times the
// corners of the named triangle), lie on the face and mirror each other across X = 0.
TEST(SyntheticBodyTest, LandmarksLieOnTheFaceSymmetrically) {
  const BodyModel& model = body().model;
  const FaceLandmarks& lm = body().landmarks;
  const auto point = [&](int face, const Eigen::RowVector3d& bary) {
    Vector3d p = Vector3d::Zero();
    for (int c = 0; c < 3; ++c) p += bary[c] * vertex(model, model.faces(face, c));
    return p;
  };
  ASSERT_EQ(static_cast<int>(lm.faces.size()), FaceLandmarks::kStaticCount);
  std::vector<Vector3d> points;
  for (int i = 0; i < FaceLandmarks::kStaticCount; ++i) {
    EXPECT_GE(lm.barycentric.row(i).minCoeff(), 0.0);
    EXPECT_NEAR(lm.barycentric.row(i).sum(), 1.0, 1e-6);
    points.push_back(point(lm.faces[i], lm.barycentric.row(i)));
    EXPECT_GT(points.back().y(), 0.18) << "landmark " << i + 17;
    EXPECT_LT(points.back().y(), 0.34) << "landmark " << i + 17;
    EXPECT_GT(points.back().z(), 0.06) << "landmark " << i + 17;
  }
  // iBUG-68 mirror pairs: brows, eye corners, nose wings, mouth corners (indices from 17).
  for (const auto& [a, b] : std::vector<std::pair<int, int>>{
           {17, 26}, {18, 25}, {19, 24}, {20, 23}, {21, 22}, {36, 45}, {39, 42}, {31, 35}, {48, 54}, {60, 64}}) {
    const Vector3d& p = points[a - 17];
    const Vector3d& q = points[b - 17];
    EXPECT_NEAR(p.x(), -q.x(), 3e-3) << a << "/" << b;
    EXPECT_NEAR(p.y(), q.y(), 3e-3) << a << "/" << b;
    EXPECT_LT(p.x(), 0.0) << a << " is on the subject's right";
  }
  ASSERT_EQ(lm.contour_faces.rows(), FaceLandmarks::kYawBins);
  ASSERT_EQ(lm.contour_faces.cols(), FaceLandmarks::kContourCount);
  const auto contour = [&](int bin, int k) {
    const int row = bin * FaceLandmarks::kContourCount + k;
    return point(lm.contour_faces(bin, k), lm.contour_barycentric.row(row));
  };
  EXPECT_NEAR(contour(0, 8).x(), 0.0, 3e-3) << "the chin, head straight";
  for (int k = 0; k < 8; ++k) EXPECT_NEAR(contour(0, k).x(), -contour(0, 16 - k).x(), 3e-3) << k;
  // Bin 20 is a yaw of +20 degrees (the head turned toward -X), bin 59 one of -20: the outline
  // seen from the front slides over the face toward +X and -X respectively.
  EXPECT_GT(contour(20, 8).x(), 0.02);
  EXPECT_LT(contour(59, 8).x(), -0.02);
}

// The writer's file read back by the project's own loader: the same model, array for array
// (the generated model holds float32-representable values, so nothing is lost).
TEST(SyntheticBodyTest, WrittenFileLoadsBackUnchangedAndIsSmall) {
  const std::string path = scratch("synthetic_smplx.npz").string();
  odyssey::io::write_body_model(path, body());
  // A few MB for 400 directions: the mostly-zero arrays compress to almost nothing.
  EXPECT_LT(fs::file_size(path), 3u * 1024 * 1024);
  const BodyModel loaded = odyssey::io::load_body_model(path);
  const BodyModel& model = body().model;
  EXPECT_EQ(loaded.kind, model.kind);
  EXPECT_EQ(loaded.joint_names, model.joint_names);
  EXPECT_EQ(loaded.parents, model.parents);
  EXPECT_EQ(loaded.v_template, model.v_template);
  EXPECT_EQ(loaded.faces, model.faces);
  EXPECT_EQ(dense(loaded.j_regressor), dense(model.j_regressor));
  EXPECT_EQ(dense(loaded.weights), dense(model.weights));
  EXPECT_EQ(loaded.shapedirs, model.shapedirs);
  EXPECT_EQ(loaded.shape_count, 300);
  EXPECT_EQ(loaded.expression_count, 100);
  EXPECT_EQ(loaded.posedirs, model.posedirs);
  EXPECT_EQ(loaded.hands_components_left, model.hands_components_left);
  EXPECT_EQ(loaded.hands_components_right, model.hands_components_right);
  EXPECT_EQ(loaded.hands_mean_left, model.hands_mean_left);
  EXPECT_EQ(loaded.hands_mean_right, model.hands_mean_right);
}

TEST(SyntheticBodyTest, WriterRejectsLandmarksOffTheMesh) {
  FaceLandmarks landmarks = body().landmarks;
  landmarks.faces[3] = kFaces;
  const std::string path = scratch("bad_landmarks.npz").string();
  EXPECT_THROW(odyssey::io::write_body_model(path, body().model, &landmarks), std::invalid_argument);
  EXPECT_FALSE(fs::exists(path));
}

// numpy reads the file as the smplx package does (np.load with allow_pickle, SMPLX.__init__'s
// slicing and reshapes, lbs()), checks every key's dtype and shape, and replays lbs() on poses
// that BodyModelEvaluator also evaluated: the same vertices and joints to 1e-6 m. A second model
// without landmarks, correctives or hand PCA (and with a 16 + 10 shape split) checks that the
// writer still produces what SMPLX.__init__ needs.
TEST(SyntheticBodyTest, NumpyReadsTheFileLikeTheSmplxPackage) {
  if (std::string(ODYSSEY_PYTHON).empty()) GTEST_SKIP() << "no python3 with numpy";
  const BodyModel& model = body().model;
  const std::string path = scratch("synthetic_smplx_for_numpy.npz").string();
  odyssey::io::write_body_model(path, body());

  constexpr int kFrames = 3;
  std::mt19937 rng(5);
  std::normal_distribution<double> normal(0.0, 1.0);
  RowMatrixXd poses(kFrames, 165), betas(kFrames, 10), expression(kFrames, 10), translations(kFrames, 3);
  for (int f = 0; f < kFrames; ++f) {
    for (int i = 0; i < 165; ++i) poses(f, i) = 0.3 * normal(rng);
    for (int i = 0; i < 10; ++i) betas(f, i) = normal(rng), expression(f, i) = normal(rng);
    for (int i = 0; i < 3; ++i) translations(f, i) = 0.5 * normal(rng);
  }
  RowMatrixXd vertices(kFrames, 3 * kVertices), joints(kFrames, 3 * kJoints);
  odyssey::BodyModelEvaluator evaluator(model);
  for (int f = 0; f < kFrames; ++f) {
    evaluator.set_shape(std::span<const double>(betas.row(f).data(), 10),
                        std::span<const double>(expression.row(f).data(), 10));
    evaluator.evaluate(std::span<const double>(poses.row(f).data(), 165), translations.row(f).transpose(),
                       std::span<double>(joints.row(f).data(), 3 * kJoints),
                       std::span<double>(vertices.row(f).data(), 3 * kVertices));
  }
  const std::string expected = scratch("evaluator_frames.npz").string();
  {
    using odyssey::io::NpyArray;
    odyssey::io::NpzWriter npz(expected);
    const auto add = [&](const char* key, const RowMatrixXd& m, std::vector<std::size_t> shape) {
      npz.add(key, NpyArray::from_float64(std::span<const double>(m.data(), std::size_t(m.size())), std::move(shape)));
    };
    add("poses", poses, {kFrames, 165});
    add("betas", betas, {kFrames, 10});
    add("expression", expression, {kFrames, 10});
    add("transl", translations, {kFrames, 3});
    add("vertices", vertices, {kFrames, kVertices, 3});
    add("joints", joints, {kFrames, kJoints, 3});
    npz.close();
  }

  BodyModel bare = model;
  bare.posedirs.resize(0, 0);
  bare.hands_components_left.resize(0, 0);
  bare.hands_components_right.resize(0, 0);
  bare.hands_mean_left.resize(0);
  bare.hands_mean_right.resize(0);
  bare.shapedirs = RowMatrixXd(bare.shapedirs.leftCols(16));
  bare.shapedirs.conservativeResize(Eigen::NoChange, 26);
  bare.shapedirs.rightCols(10) = model.shapedirs.middleCols(300, 10);
  bare.shape_count = 16;
  bare.expression_count = 10;
  const std::string bare_path = scratch("bare_smplx.npz").string();
  odyssey::io::write_body_model(bare_path, bare);

  const std::string script = scratch("check_smplx_layout.py").string();
  std::ofstream(script) << R"(import sys, numpy as np
V, F, J = 10475, 20908, 55
expected = {
    'v_template': ('float32', (V, 3)), 'f': ('uint32', (F, 3)), 'J_regressor': ('float32', (J, V)),
    'weights': ('float32', (V, J)), 'kintree_table': ('int64', (2, J)), 'shapedirs': ('float32', (V, 3, 400)),
    'posedirs': ('float32', (V, 3, 486)), 'hands_componentsl': ('float32', (45, 45)),
    'hands_componentsr': ('float32', (45, 45)), 'hands_meanl': ('float32', (45,)), 'hands_meanr': ('float32', (45,)),
    'lmk_faces_idx': ('int64', (51,)), 'lmk_bary_coords': ('float32', (51, 3)),
    'dynamic_lmk_faces_idx': ('int64', (79, 17)), 'dynamic_lmk_bary_coords': ('float32', (79, 17, 3))}

def smplx_arrays(path, num_betas, num_expression):
    # smplx.body_models.SMPLX.__init__ (commit 1265df7b): np.load(allow_pickle=True) into a Struct,
    # then SMPL.__init__, SMPLH.__init__ and its own slicing.
    d = dict(np.load(path, allow_pickle=True))
    shapedirs = d['shapedirs']
    start = 300 if shapedirs.shape[-1] >= 400 else 10
    m = {'v_template': d['v_template'].astype(np.float64),
         'shapedirs': np.concatenate([shapedirs[:, :, :num_betas], shapedirs[:, :, start:start + num_expression]], 2),
         'J_regressor': d['J_regressor'].astype(np.float64),
         'posedirs': np.reshape(d['posedirs'], [-1, d['posedirs'].shape[-1]]).T.astype(np.float64),
         'lbs_weights': d['weights'].astype(np.float64),
         'faces': d['f'].astype(np.int64)}
    parents = d['kintree_table'][0].astype(np.int64)
    parents[0] = -1
    m['parents'] = parents
    for key in ('hands_componentsl', 'hands_componentsr', 'hands_meanl', 'hands_meanr', 'lmk_faces_idx',
                'lmk_bary_coords'):
        m[key] = d[key]
    return d, m

def rodrigues(r):  # smplx.lbs.batch_rodrigues, with its 1e-8
    angle = np.linalg.norm(r + 1e-8)
    k = r / angle
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K

def lbs(m, coefficients, pose):  # smplx.lbs.lbs
    v_shaped = m['v_template'] + np.einsum('l,mkl->mk', coefficients, m['shapedirs'])
    joints = m['J_regressor'] @ v_shaped
    rot = np.stack([rodrigues(r) for r in pose.reshape(-1, 3)])
    pose_feature = (rot[1:] - np.eye(3)).reshape(-1)
    v_posed = v_shaped + (pose_feature @ m['posedirs']).reshape(-1, 3)
    parents = m['parents']
    chain = []
    for i in range(len(parents)):
        t = np.eye(4)
        t[:3, :3] = rot[i]
        t[:3, 3] = joints[i] - (joints[parents[i]] if i else 0)
        chain.append(t if i == 0 else chain[parents[i]] @ t)
    chain = np.stack(chain)
    posed_joints = chain[:, :3, 3].copy()
    rel = chain.copy()
    rel[:, :3, 3] -= np.einsum('jab,jb->ja', chain[:, :3, :3], joints)
    T = np.einsum('vj,jab->vab', m['lbs_weights'], rel)
    return np.einsum('vab,vb->va', T[:, :3, :3], v_posed) + T[:, :3, 3], posed_joints

d, m = smplx_arrays(sys.argv[1], 10, 10)
for key, (dtype, shape) in expected.items():
    assert d[key].dtype == dtype and d[key].shape == shape, (key, d[key].dtype, d[key].shape)
assert (m['parents'][1:] >= 0).all() and (m['parents'][1:] < np.arange(1, J)).all()
assert (d['f'] < V).all() and (d['lmk_faces_idx'] < F).all() and (d['dynamic_lmk_faces_idx'] < F).all()
vertex_ids = [9120, 9929, 9448, 616, 6, 8079, 7669, 7794, 7905, 8022, 5361, 4933, 5058, 5169, 5286, 5770, 5780, 8846,
              8463, 8474, 8635]  # smplx/vertex_ids.py, 'smplx'
assert max(vertex_ids) < V
e = np.load(sys.argv[2])
for f in range(e['poses'].shape[0]):
    vertices, joints = lbs(m, np.concatenate([e['betas'][f], e['expression'][f]]), e['poses'][f])
    vertices += e['transl'][f]
    joints += e['transl'][f]
    assert np.abs(vertices - e['vertices'][f]).max() < 1e-6, np.abs(vertices - e['vertices'][f]).max()
    assert np.abs(joints - e['joints'][f]).max() < 1e-6, np.abs(joints - e['joints'][f]).max()
    # vertices2landmarks
    landmarks = np.einsum('lfi,lf->li', vertices[m['faces'][m['lmk_faces_idx']]], m['lmk_bary_coords'])
    assert np.isfinite(landmarks).all()

d, m = smplx_arrays(sys.argv[3], 10, 10)
assert d['shapedirs'].shape == (V, 3, 400), d['shapedirs'].shape
assert np.array_equal(d['shapedirs'][:, :, 300:310], np.load(sys.argv[1])['shapedirs'][:, :, 300:310])
assert not d['shapedirs'][:, :, 16:300].any() and not d['posedirs'].any()
assert np.array_equal(d['hands_componentsl'], np.eye(45)) and not d['hands_meanl'].any()
assert d['lmk_faces_idx'].shape == (0,) and d['lmk_bary_coords'].shape == (0, 3)
assert 'dynamic_lmk_faces_idx' not in d
)";
  const std::string command =
      std::string(ODYSSEY_PYTHON) + " " + script + " " + path + " " + expected + " " + bare_path;
  EXPECT_EQ(std::system(command.c_str()), 0) << command;
}

}  // namespace
