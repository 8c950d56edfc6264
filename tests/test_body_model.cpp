// The SMPL-family forward pass against the smplx package's float64 output (fixtures/smplx), the
// options against equivalent inputs, hand-chained joint positions, SMPL-H and SMPL models cut
// from the SMPL-X fixture, and the model loader's refusal of damaged files.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>

#include "mocap_io/body_model_file.h"
#include "mocap_io/input_error.h"
#include "mocap_io/npy.h"
#include "skeleton/body_model.h"
#include "test_support.h"

namespace odyssey {
namespace {

namespace fs = std::filesystem;
using io::InputError;
using io::NpyArray;
using io::NpzReader;
using io::NpzWriter;

const fs::path kFixtureDir = fs::path(ODYSSEY_SHARED_DIR) / "fixtures/smplx";
const std::string kModelPath = (kFixtureDir / "SMPLX_FIXTURE.npz").string();

// The reference's own agreement with exact Rodrigues is ~1e-8 m; the contract is 1e-6 m.
constexpr double kReferenceTolerance = 1e-6;

const BodyModel& fixture_model() {
  static const BodyModel model = io::load_body_model(kModelPath);
  return model;
}

std::vector<double> doubles(const NpzReader& reader, const std::string& key) { return reader.load(key).to_double(); }

double max_abs_difference(std::span<const double> a, std::span<const double> b) {
  EXPECT_EQ(a.size(), b.size());
  double worst = 0.0;
  for (std::size_t i = 0; i < std::min(a.size(), b.size()); ++i) worst = std::max(worst, std::abs(a[i] - b[i]));
  return worst;
}

// One reference frame's inputs and outputs.
struct ReferenceFrame {
  std::string name;
  std::vector<double> betas, expression, full_pose, joints, vertices;
  // Root, body, jaw, left eye and right eye rotations (25 joints), as separate inputs of the
  // reference; the hands follow them in the full pose.
  std::vector<double> pose_before_hands;
  std::vector<double> left_hand, right_hand;  // as stored: 45-D or PCA coefficients
  std::vector<double> left_hand_full, right_hand_full;  // PCA file only: the expanded 45-D poses
  Eigen::Vector3d translation;
};

std::vector<ReferenceFrame> read_reference(const std::string& file) {
  const NpzReader reader((kFixtureDir / file).string());
  const std::size_t frames = reader.header("betas").shape[0];
  const std::vector<std::string> cases = reader.load("case").to_strings();
  // Frame f's row of every per-frame array, each array read once.
  const auto rows = [&](const std::string& key) {
    const std::vector<double> values = doubles(reader, key);
    const std::size_t width = values.size() / frames;
    std::vector<std::vector<double>> out(frames);
    for (std::size_t f = 0; f < frames; ++f) out[f].assign(values.begin() + f * width, values.begin() + (f + 1) * width);
    return out;
  };
  std::vector<ReferenceFrame> out(frames);
  const auto fill = [&](const std::string& key, std::vector<double> ReferenceFrame::*member) {
    std::vector<std::vector<double>> values = rows(key);
    for (std::size_t f = 0; f < frames; ++f) out[f].*member = std::move(values[f]);
  };
  fill("betas", &ReferenceFrame::betas);
  fill("expression", &ReferenceFrame::expression);
  fill("full_pose", &ReferenceFrame::full_pose);
  fill("joints", &ReferenceFrame::joints);
  fill("vertices", &ReferenceFrame::vertices);
  fill("left_hand_pose", &ReferenceFrame::left_hand);
  fill("right_hand_pose", &ReferenceFrame::right_hand);
  if (reader.contains("left_hand_pose_full")) {
    fill("left_hand_pose_full", &ReferenceFrame::left_hand_full);
    fill("right_hand_pose_full", &ReferenceFrame::right_hand_full);
  }
  for (const char* key : {"global_orient", "body_pose", "jaw_pose", "leye_pose", "reye_pose"}) {
    const std::vector<std::vector<double>> part = rows(key);
    for (std::size_t f = 0; f < frames; ++f) {
      out[f].pose_before_hands.insert(out[f].pose_before_hands.end(), part[f].begin(), part[f].end());
    }
  }
  const std::vector<std::vector<double>> translations = rows("transl");
  for (std::size_t f = 0; f < frames; ++f) {
    out[f].name = cases[f];
    out[f].translation = Eigen::Vector3d(translations[f][0], translations[f][1], translations[f][2]);
  }
  return out;
}

std::span<const double> values_of(const Eigen::VectorXd& vector) { return {vector.data(), std::size_t(vector.size())}; }

// The full pose in model joint order: root, body, jaw, left eye, right eye, left hand, right hand.
std::vector<double> assemble_pose(const ReferenceFrame& frame, std::span<const double> left_hand,
                                  std::span<const double> right_hand) {
  std::vector<double> pose = frame.pose_before_hands;
  pose.insert(pose.end(), left_hand.begin(), left_hand.end());
  pose.insert(pose.end(), right_hand.begin(), right_hand.end());
  return pose;
}

struct Result {
  std::vector<double> joints, vertices;
};

Result evaluate(BodyModelEvaluator& evaluator, std::span<const double> pose, const Eigen::Vector3d& translation) {
  const BodyModel& model = evaluator.model();
  Result result{std::vector<double>(3 * model.joint_count()), std::vector<double>(3 * model.vertex_count())};
  evaluator.evaluate(pose, translation, result.joints, std::span<double>(result.vertices));
  return result;
}

// ---------------------------------------------------------------------------------------------
// Loading

TEST(BodyModelFileTest, LoadsFixtureWithTheSmplxTree) {
  const BodyModel& model = fixture_model();
  EXPECT_EQ(model.kind, BodyModelKind::SMPLX);
  EXPECT_EQ(model.joint_count(), 55);
  EXPECT_EQ(model.vertex_count(), 10475);
  EXPECT_EQ(model.faces.rows(), 20908);
  EXPECT_EQ(model.shape_count, 10);
  EXPECT_EQ(model.expression_count, 10);
  EXPECT_EQ(model.posedirs.rows(), 3 * 10475);
  EXPECT_EQ(model.posedirs.cols(), 486);
  // At most 4 influences a vertex in the fixture: the zeros of the dense array are dropped.
  EXPECT_LE(model.weights.nonZeros(), 4 * 10475);

  // Names and parents agree with the shared asset table.
  std::ifstream table(fs::path(ODYSSEY_SHARED_DIR) / "assets/smplx_joints_55.tsv");
  ASSERT_TRUE(table) << "cannot open smplx_joints_55.tsv";
  std::string line;
  int rows = 0;
  while (std::getline(table, line)) {
    if (line.empty() || line[0] == '#' || line.rfind("index", 0) == 0) continue;
    std::istringstream fields(line);
    int index = 0, parent = 0;
    std::string name;
    fields >> index >> name >> parent;
    ASSERT_LT(index, 55);
    EXPECT_EQ(model.joint_names[index], name);
    EXPECT_EQ(model.parents[index], parent) << name;
    ++rows;
  }
  EXPECT_EQ(rows, 55);
}

// ---------------------------------------------------------------------------------------------
// Agreement with the reference implementation

TEST(BodyModelTest, MatchesReferenceWithFullHandPoses) {
  const BodyModel& model = fixture_model();
  const std::vector<ReferenceFrame> frames = read_reference("reference_flat.npz");
  ASSERT_EQ(frames.size(), 15u);
  BodyModelEvaluator evaluator(model);
  double worst_joint = 0.0, worst_vertex = 0.0;
  for (std::size_t f = 0; f < frames.size(); ++f) {
    const ReferenceFrame& frame = frames[f];
    // flat_hand_mean: the 45-D hand poses are the joint rotations themselves.
    const std::vector<double> pose = assemble_pose(frame, frame.left_hand, frame.right_hand);
    EXPECT_LT(max_abs_difference(pose, frame.full_pose), 1e-15) << frame.name;
    evaluator.set_shape(frame.betas, frame.expression);
    const Result result = evaluate(evaluator, pose, frame.translation);
    const double joint_error = max_abs_difference(result.joints, frame.joints);
    const double vertex_error = max_abs_difference(result.vertices, frame.vertices);
    EXPECT_LT(joint_error, kReferenceTolerance) << frame.name;
    EXPECT_LT(vertex_error, kReferenceTolerance) << frame.name;
    worst_joint = std::max(worst_joint, joint_error);
    worst_vertex = std::max(worst_vertex, vertex_error);
  }
  std::printf("reference_flat: max |joint error| %.3g m, max |vertex error| %.3g m over %zu frames\n", worst_joint,
              worst_vertex, frames.size());
}

TEST(BodyModelTest, MatchesReferenceWithPcaHands) {
  const BodyModel& model = fixture_model();
  const std::vector<ReferenceFrame> frames = read_reference("reference_pca.npz");
  ASSERT_EQ(frames.size(), 8u);
  BodyModelEvaluator evaluator(model);
  double worst_hand = 0.0, worst_joint = 0.0, worst_vertex = 0.0;
  for (std::size_t f = 0; f < frames.size(); ++f) {
    const ReferenceFrame& frame = frames[f];
    ASSERT_EQ(frame.left_hand.size(), 12u);
    // pose = sum_k c_k components[k] + hands_mean (the file was made without flat_hand_mean).
    const Eigen::VectorXd left = hand_pose_from_pca(model, true, frame.left_hand, true, true);
    const Eigen::VectorXd right = hand_pose_from_pca(model, false, frame.right_hand, true, true);
    const double hand_error = std::max(max_abs_difference(values_of(left), frame.left_hand_full),
                                       max_abs_difference(values_of(right), frame.right_hand_full));
    EXPECT_LT(hand_error, 1e-12) << frame.name;
    worst_hand = std::max(worst_hand, hand_error);

    const std::vector<double> pose = assemble_pose(frame, values_of(left), values_of(right));
    EXPECT_LT(max_abs_difference(pose, frame.full_pose), 1e-12) << frame.name;
    evaluator.set_shape(frame.betas, frame.expression);
    const Result result = evaluate(evaluator, pose, frame.translation);
    const double joint_error = max_abs_difference(result.joints, frame.joints);
    const double vertex_error = max_abs_difference(result.vertices, frame.vertices);
    EXPECT_LT(joint_error, kReferenceTolerance) << frame.name;
    EXPECT_LT(vertex_error, kReferenceTolerance) << frame.name;
    worst_joint = std::max(worst_joint, joint_error);
    worst_vertex = std::max(worst_vertex, vertex_error);
  }
  std::printf("reference_pca: max |hand pose error| %.3g rad, max |joint error| %.3g m, max |vertex error| %.3g m\n",
              worst_hand, worst_joint, worst_vertex);
}

TEST(BodyModelTest, HandPoseFromPcaWithoutPcaIsThePoseItself) {
  const BodyModel& model = fixture_model();
  std::vector<double> pose(45);
  for (int i = 0; i < 45; ++i) pose[i] = 0.01 * i - 0.2;
  const Eigen::VectorXd plain = hand_pose_from_pca(model, true, pose, false, false);
  EXPECT_EQ(max_abs_difference(values_of(plain), pose), 0.0);
  const Eigen::VectorXd with_mean = hand_pose_from_pca(model, false, pose, false, true);
  const Eigen::VectorXd expected = plain + model.hands_mean_right;
  EXPECT_EQ(max_abs_difference(values_of(with_mean), values_of(expected)), 0.0);
  EXPECT_THROW(hand_pose_from_pca(model, true, std::vector<double>(44), false, false), std::invalid_argument);
  EXPECT_THROW(hand_pose_from_pca(model, true, std::vector<double>(46), true, false), std::invalid_argument);
}

// ---------------------------------------------------------------------------------------------
// Batches and options, against single-frame evaluation of equivalent inputs

TEST(BodyModelTest, BatchEqualsSingleFrames) {
  const BodyModel& model = fixture_model();
  const std::vector<ReferenceFrame> frames = read_reference("reference_flat.npz");
  const int count = static_cast<int>(frames.size());
  const std::size_t pose_size = model.pose_size(), vertex_numbers = 3 * std::size_t(model.vertex_count());
  std::vector<double> poses, translations;
  for (const ReferenceFrame& frame : frames) {
    poses.insert(poses.end(), frame.full_pose.begin(), frame.full_pose.end());
    translations.insert(translations.end(), frame.translation.data(), frame.translation.data() + 3);
  }
  for (bool correctives : {true, false}) {
    BodyModelEvaluator evaluator(model, {.pose_correctives = correctives});
    evaluator.set_shape(frames.back().betas, frames.back().expression);
    std::vector<double> batch_joints(count * pose_size);
    std::vector<float> batch_vertices(count * vertex_numbers);
    evaluator.evaluate_batch(count, poses, translations, batch_joints, batch_vertices);
    std::vector<double> mesh_free_joints(count * pose_size);
    evaluator.evaluate_batch(count, poses, translations, mesh_free_joints, {});

    std::vector<double> joints(pose_size);
    std::vector<float> vertices(vertex_numbers);
    double worst = 0.0;
    for (int f = 0; f < count; ++f) {
      evaluator.evaluate(std::span(poses).subspan(f * pose_size, pose_size), frames[f].translation, joints,
                         std::span<float>(vertices));
      for (std::size_t i = 0; i < pose_size; ++i) {
        ASSERT_EQ(batch_joints[f * pose_size + i], joints[i]);
        ASSERT_EQ(mesh_free_joints[f * pose_size + i], joints[i]);
      }
      for (std::size_t i = 0; i < vertex_numbers; ++i) {
        worst = std::max(worst, double(std::abs(batch_vertices[f * vertex_numbers + i] - vertices[i])));
      }
    }
    // The batch's corrective product sums in another order than the single-frame one; after
    // rounding to float32 the two may differ by one unit in the last place (1.2e-7 at 1-2 m).
    EXPECT_LE(worst, 2.5e-7) << "correctives " << correctives;
  }
}

TEST(BodyModelTest, NoCorrectivesMovesVerticesNotJoints) {
  const BodyModel& model = fixture_model();
  const ReferenceFrame frame = read_reference("reference_flat.npz").back();
  BodyModelEvaluator with(model), without(model, {.pose_correctives = false});
  with.set_shape(frame.betas, frame.expression);
  without.set_shape(frame.betas, frame.expression);
  const Result a = evaluate(with, frame.full_pose, frame.translation);
  const Result b = evaluate(without, frame.full_pose, frame.translation);
  EXPECT_EQ(a.joints, b.joints);
  // The fixture's correctives are centimetres on every 7th vertex.
  EXPECT_GT(max_abs_difference(a.vertices, b.vertices), 1e-3);
}

TEST(BodyModelTest, HandsOffEqualsZeroHandPose) {
  const BodyModel& model = fixture_model();
  const ReferenceFrame frame = read_reference("reference_flat.npz").back();
  std::vector<double> zero_hands = frame.full_pose;
  std::fill(zero_hands.begin() + 3 * BodyParts::left_hand_first(model.kind), zero_hands.end(), 0.0);
  ASSERT_NE(zero_hands, frame.full_pose);
  BodyModelEvaluator full(model), handless(model, {.hands = false});
  full.set_shape(frame.betas, frame.expression);
  handless.set_shape(frame.betas, frame.expression);
  const Result a = evaluate(full, zero_hands, frame.translation);
  const Result b = evaluate(handless, frame.full_pose, frame.translation);
  // Only the float32 summation order of the corrective product differs (fewer columns).
  EXPECT_LT(max_abs_difference(a.joints, b.joints), 1e-12);
  EXPECT_LT(max_abs_difference(a.vertices, b.vertices), 1e-9);
}

TEST(BodyModelTest, FaceOffEqualsZeroJawEyesAndExpression) {
  const BodyModel& model = fixture_model();
  const std::vector<ReferenceFrame> frames = read_reference("reference_flat.npz");
  // Frame 8 opens the jaw by 0.24 rad; frame 4 has the largest expression coefficients.
  const ReferenceFrame& posed = frames[8];
  const std::vector<double>& expression = frames[4].expression;
  std::vector<double> still_face = posed.full_pose;
  std::fill(still_face.begin() + 3 * BodyParts::kJaw, still_face.begin() + 3 * (BodyParts::kRightEye + 1), 0.0);
  ASSERT_NE(still_face, posed.full_pose);
  ASSERT_GT(max_abs_difference(expression, std::vector<double>(expression.size(), 0.0)), 1.0);
  BodyModelEvaluator full(model), faceless(model, {.face = false});
  full.set_shape(posed.betas);
  faceless.set_shape(posed.betas, expression);
  const Result a = evaluate(full, still_face, posed.translation);
  const Result b = evaluate(faceless, posed.full_pose, posed.translation);
  EXPECT_LT(max_abs_difference(a.joints, b.joints), 1e-12);
  EXPECT_LT(max_abs_difference(a.vertices, b.vertices), 1e-9);
  // And the face does matter with the option on.
  BodyModelEvaluator expressive(model);
  expressive.set_shape(posed.betas, expression);
  EXPECT_GT(max_abs_difference(evaluate(expressive, posed.full_pose, posed.translation).vertices, b.vertices), 1e-3);
}

// ---------------------------------------------------------------------------------------------
// Hand-chained kinematics

Eigen::Vector3d joint(const std::vector<double>& joints, int j) {
  return Eigen::Vector3d(joints[3 * j], joints[3 * j + 1], joints[3 * j + 2]);
}

// Descendants of `ancestor` (itself excluded), from the parent table.
bool descends_from(const BodyModel& model, int j, int ancestor) {
  for (int p = model.parents[j]; p >= 0; p = model.parents[p]) {
    if (p == ancestor) return true;
  }
  return false;
}

TEST(BodyModelTest, KneeRotationMovesOnlyTheLowerLeg) {
  const BodyModel& model = fixture_model();
  BodyModelEvaluator evaluator(model);
  const RowMatrixXd rest = evaluator.rest_joints();  // zero shape
  const int knee = 4;
  ASSERT_EQ(model.joint_names[knee], "left_knee");
  std::vector<double> pose(model.pose_size(), 0.0);
  pose[3 * knee] = std::numbers::pi / 2;  // 90 degrees about x
  const Eigen::Vector3d translation(0.1, -0.2, 0.3);
  const Result result = evaluate(evaluator, pose, translation);

  // Joints below the knee swing about it, x -> x, y -> -z, z -> y; everything else stays at
  // its rest position; translation is added to all.
  const Eigen::Vector3d knee_position = rest.row(knee).transpose();
  int moved = 0;
  for (int j = 0; j < model.joint_count(); ++j) {
    Eigen::Vector3d expected = rest.row(j).transpose();
    if (descends_from(model, j, knee)) {
      const Eigen::Vector3d d = expected - knee_position;
      expected = knee_position + Eigen::Vector3d(d.x(), -d.z(), d.y());
      ++moved;
    }
    EXPECT_LT((joint(result.joints, j) - (expected + translation)).norm(), 1e-12) << model.joint_names[j];
  }
  EXPECT_EQ(moved, 2);  // left_ankle, left_foot
}

TEST(BodyModelTest, RootTurnsAboutThePelvisJoint) {
  const BodyModel& model = fixture_model();
  BodyModelEvaluator evaluator(model);
  const ReferenceFrame frame = read_reference("reference_flat.npz").back();
  evaluator.set_shape(frame.betas, frame.expression);
  // 90 degrees about y: x -> -z, z -> x. Only the root turns, so every pose feature is zero
  // and the whole shaped mesh turns rigidly about J_0(beta): v = J_0 + R (v_shaped - J_0) + t.
  std::vector<double> pose(model.pose_size(), 0.0);
  pose[1] = std::numbers::pi / 2;
  const Eigen::Vector3d translation(-0.4, 0.05, 1.5);
  const Result result = evaluate(evaluator, pose, translation);
  const Eigen::Vector3d pelvis = evaluator.rest_joints().row(0).transpose();
  const auto turned = [&](const Eigen::Vector3d& p) -> Eigen::Vector3d {
    const Eigen::Vector3d d = p - pelvis;
    return Eigen::Vector3d(pelvis.x() + d.z(), p.y(), pelvis.z() - d.x()) + translation;
  };
  double worst_joint = 0.0, worst_vertex = 0.0;
  for (int j = 0; j < model.joint_count(); ++j) {
    worst_joint = std::max(worst_joint, (joint(result.joints, j) - turned(evaluator.rest_joints().row(j).transpose())).norm());
  }
  for (int v = 0; v < model.vertex_count(); ++v) {
    worst_vertex = std::max(worst_vertex, (joint(result.vertices, v) - turned(evaluator.shaped_vertices().row(v).transpose())).norm());
  }
  EXPECT_LT(worst_joint, 1e-12);
  // Blending 4 weights that sum to 1 within float32 rounding: rigid to ~1e-7 of the distance.
  EXPECT_LT(worst_vertex, 1e-6);
}

// ---------------------------------------------------------------------------------------------
// SMPL-H and SMPL, cut from the SMPL-X fixture. With the dropped joints at rest, every dropped
// joint's skinning matrix equals its parent's (A_j = G_p [I | J_j - J_p] [I | -J_j] = A_p), so
// moving its weights onto the kept ancestor changes nothing: the smaller model must reproduce
// the SMPL-X result with those joints at rest.

// Keeps the SMPL-X joints listed in `kept` (in order); every other joint's weights go to its
// nearest kept ancestor, its regressor row and pose features are dropped.
BodyModel cut_model(const BodyModel& full, BodyModelKind kind, const std::vector<int>& kept) {
  std::vector<int> new_index(full.joint_count(), -1);
  for (std::size_t k = 0; k < kept.size(); ++k) new_index[kept[k]] = int(k);
  BodyModel model;
  model.kind = kind;
  for (int j : kept) {
    model.joint_names.push_back(full.joint_names[j]);
    int parent = full.parents[j];
    while (parent >= 0 && new_index[parent] < 0) parent = full.parents[parent];
    model.parents.push_back(parent < 0 ? -1 : new_index[parent]);
  }
  const int joints = int(kept.size());
  model.v_template = full.v_template;
  model.faces = full.faces;
  const Eigen::MatrixXd regressor = full.j_regressor;
  Eigen::MatrixXd cut_regressor(joints, full.vertex_count());
  for (int k = 0; k < joints; ++k) cut_regressor.row(k) = regressor.row(kept[k]);
  model.j_regressor = cut_regressor.sparseView();
  const Eigen::MatrixXd weights = full.weights;
  Eigen::MatrixXd cut_weights = Eigen::MatrixXd::Zero(full.vertex_count(), joints);
  for (int j = 0; j < full.joint_count(); ++j) {
    int owner = j;
    while (new_index[owner] < 0) owner = full.parents[owner];
    cut_weights.col(new_index[owner]) += weights.col(j);
  }
  model.weights = cut_weights.sparseView();
  model.shape_count = full.shape_count;
  model.shapedirs = full.shapedirs.leftCols(full.shape_count);
  model.posedirs.resize(full.posedirs.rows(), 9 * (joints - 1));
  for (int k = 1; k < joints; ++k) model.posedirs.middleCols(9 * (k - 1), 9) = full.posedirs.middleCols(9 * (kept[k] - 1), 9);
  if (kind == BodyModelKind::SMPLH) {
    model.hands_components_left = full.hands_components_left;
    model.hands_components_right = full.hands_components_right;
    model.hands_mean_left = full.hands_mean_left;
    model.hands_mean_right = full.hands_mean_right;
  }
  return model;
}

// Writes a model in the smplx npz layout (float32 arrays, uint32 root parent).
void save_model(const BodyModel& model, const std::string& path) {
  NpzWriter writer(path, false);
  const std::size_t v = model.vertex_count(), j = model.joint_count();
  const auto floats = [](const auto& dense) {
    std::vector<float> out(dense.size());
    const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> rows = dense.template cast<double>();
    for (Eigen::Index i = 0; i < rows.size(); ++i) out[i] = float(rows.data()[i]);
    return out;
  };
  writer.add("v_template", NpyArray::from_float32(floats(model.v_template), {v, 3}));
  const RowMatrixXi faces = model.faces;
  std::vector<std::uint32_t> face_indices(faces.data(), faces.data() + faces.size());
  writer.add("f", NpyArray::from_uint32(face_indices, {std::size_t(faces.rows()), 3}));
  writer.add("J_regressor", NpyArray::from_float32(floats(Eigen::MatrixXd(model.j_regressor)), {j, v}));
  writer.add("weights", NpyArray::from_float32(floats(Eigen::MatrixXd(model.weights)), {v, j}));
  std::vector<std::int64_t> kintree(2 * j);
  for (std::size_t i = 0; i < j; ++i) {
    kintree[i] = model.parents[i] < 0 ? 4294967295 : model.parents[i];
    kintree[j + i] = std::int64_t(i);
  }
  writer.add("kintree_table", NpyArray::from_int64(kintree, {2, j}));
  writer.add("shapedirs", NpyArray::from_float32(floats(model.shapedirs), {v, 3, std::size_t(model.shapedirs.cols())}));
  writer.add("posedirs", NpyArray::from_float32(floats(model.posedirs), {v, 3, std::size_t(model.posedirs.cols())}));
  if (model.kind != BodyModelKind::SMPL) {
    writer.add("hands_componentsl", NpyArray::from_float32(floats(model.hands_components_left), {45, 45}));
    writer.add("hands_componentsr", NpyArray::from_float32(floats(model.hands_components_right), {45, 45}));
    writer.add("hands_meanl", NpyArray::from_float32(floats(model.hands_mean_left), {45}));
    writer.add("hands_meanr", NpyArray::from_float32(floats(model.hands_mean_right), {45}));
  }
  writer.close();
}

fs::path scratch_dir() {
  const fs::path dir = odyssey::test_support::scratch_root() / "body_model";
  fs::create_directories(dir);
  return dir;
}

TEST(BodyModelTest, SmplhAndSmplReproduceSmplxWithTheirJointsOnly) {
  const BodyModel& smplx = fixture_model();
  const ReferenceFrame frame = read_reference("reference_flat.npz").back();
  // SMPL-X with jaw and eyes at rest and no expression.
  std::vector<double> pose = frame.full_pose;
  std::fill(pose.begin() + 3 * BodyParts::kJaw, pose.begin() + 3 * (BodyParts::kRightEye + 1), 0.0);

  std::vector<int> smplh_joints, smpl_joints;
  for (int j = 0; j < 55; ++j) {
    if (j < BodyParts::kJaw || j > BodyParts::kRightEye) smplh_joints.push_back(j);
    if (j < BodyParts::kBodyJoints) smpl_joints.push_back(j);
  }
  // SMPL's two hand joints stand where the index fingers start; with every finger at rest the
  // whole SMPL-X hand follows them rigidly.
  smpl_joints.push_back(25);
  smpl_joints.push_back(40);
  std::vector<double> fingers_at_rest = pose;
  std::fill(fingers_at_rest.begin() + 3 * 25, fingers_at_rest.end(), 0.0);

  struct Case {
    BodyModelKind kind;
    const std::vector<int>& kept;
    const std::vector<double>& smplx_pose;
  };
  for (const Case& c : {Case{BodyModelKind::SMPLH, smplh_joints, pose}, Case{BodyModelKind::SMPL, smpl_joints, fingers_at_rest}}) {
    SCOPED_TRACE(body_model_kind_name(c.kind));
    const std::string path = (scratch_dir() / (std::string(body_model_kind_name(c.kind)) + ".npz")).string();
    save_model(cut_model(smplx, c.kind, c.kept), path);
    const BodyModel model = io::load_body_model(path);
    fs::remove(path);
    ASSERT_EQ(model.kind, c.kind);
    ASSERT_EQ(model.joint_count(), body_model_joint_count(c.kind));
    EXPECT_EQ(model.expression_count, 0);
    if (c.kind == BodyModelKind::SMPL) {
      EXPECT_EQ(model.joint_names[22], "left_hand");
      EXPECT_EQ(model.joint_names[23], "right_hand");
    } else {
      EXPECT_EQ(model.joint_names[BodyParts::left_hand_first(c.kind)], "left_index1");
      EXPECT_EQ(model.joint_names[BodyParts::right_hand_first(c.kind)], "right_index1");
    }

    BodyModelEvaluator reference(smplx), evaluator(model);
    reference.set_shape(frame.betas);
    evaluator.set_shape(frame.betas, frame.expression);  // no expression directions: ignored
    std::vector<double> cut_pose;
    for (int j : c.kept) cut_pose.insert(cut_pose.end(), c.smplx_pose.begin() + 3 * j, c.smplx_pose.begin() + 3 * j + 3);
    const Result expected = evaluate(reference, c.smplx_pose, frame.translation);
    const Result result = evaluate(evaluator, cut_pose, frame.translation);
    for (std::size_t k = 0; k < c.kept.size(); ++k) {
      EXPECT_LT((joint(result.joints, int(k)) - joint(expected.joints, c.kept[k])).norm(), 1e-9) << model.joint_names[k];
    }
    // Weights were summed in double from float32 values and written back as float32.
    EXPECT_LT(max_abs_difference(result.vertices, expected.vertices), 1e-6);
  }
}

// ---------------------------------------------------------------------------------------------
// Damaged model files

// Copies the fixture into `name` with `key` replaced by `replacement` (or dropped when null).
std::string damaged_copy(const std::string& name, const std::string& key, const NpyArray* replacement) {
  const std::string path = (scratch_dir() / name).string();
  const NpzReader source(kModelPath);
  NpzWriter writer(path, false);
  for (const std::string& member : source.keys()) {
    if (member != key) {
      writer.add(member, source.load(member));
    } else if (replacement != nullptr) {
      writer.add(member, *replacement);
    }
  }
  writer.close();
  return path;
}

// Loads `path` expecting an InputError that names the file and contains `problem`, then
// removes the file (each copy is some 70 MB uncompressed).
void expect_rejected(const std::string& path, const std::string& problem) {
  try {
    io::load_body_model(path);
    ADD_FAILURE() << path << " loaded; expected: " << problem;
  } catch (const InputError& error) {
    EXPECT_EQ(error.file(), path);
    EXPECT_NE(std::string(error.what()).find(fs::path(path).filename().string()), std::string::npos) << error.what();
    EXPECT_NE(error.problem().find(problem), std::string::npos) << error.what();
  }
  fs::remove(path);
}

NpyArray fixture_array(const std::string& key) { return NpzReader(kModelPath).load(key); }

TEST(BodyModelFileTest, RejectsMissingKey) {
  expect_rejected(damaged_copy("no_posedirs.npz", "posedirs", nullptr), "missing key 'posedirs'");
}

TEST(BodyModelFileTest, RejectsWrongWeightsShape) {
  const std::vector<float> weights = fixture_array("weights").to_float();
  std::vector<float> narrow;  // drop the last joint's column
  for (std::size_t v = 0; v < 10475; ++v) narrow.insert(narrow.end(), weights.begin() + v * 55, weights.begin() + v * 55 + 54);
  const NpyArray bad = NpyArray::from_float32(narrow, {10475, 54});
  expect_rejected(damaged_copy("narrow_weights.npz", "weights", &bad), "weights: shape (10475, 54), expected (10475, 55)");
}

TEST(BodyModelFileTest, RejectsNanInTemplate) {
  std::vector<float> vertices = fixture_array("v_template").to_float();
  vertices[3 * 12 + 1] = std::nanf("");
  const NpyArray bad = NpyArray::from_float32(vertices, {10475, 3});
  expect_rejected(damaged_copy("nan_template.npz", "v_template", &bad), "v_template: NaN at [12, 1]");
}

TEST(BodyModelFileTest, RejectsParentAfterChild) {
  std::vector<std::int64_t> kintree = fixture_array("kintree_table").to_int64();
  kintree[5] = 9;  // right_knee under spine3
  const NpyArray bad = NpyArray::from_int64(kintree, {2, 55});
  expect_rejected(damaged_copy("late_parent.npz", "kintree_table", &bad),
                  "kintree_table: joint 5 has parent 9, which does not precede it");
}

TEST(BodyModelFileTest, RejectsKintreeCycle) {
  std::vector<std::int64_t> kintree = fixture_array("kintree_table").to_int64();
  kintree[1] = 4;  // left_hip under left_knee, which is under left_hip
  const NpyArray bad = NpyArray::from_int64(kintree, {2, 55});
  expect_rejected(damaged_copy("cycle.npz", "kintree_table", &bad),
                  "kintree_table: joint 1 has parent 4, which does not precede it");
}

TEST(BodyModelFileTest, RejectsUnknownJointCount) {
  const NpyArray bad = NpyArray::from_int64(std::vector<std::int64_t>(2 * 30, 0), {2, 30});
  expect_rejected(damaged_copy("thirty_joints.npz", "kintree_table", &bad), "30 joints, expected 24");
}

TEST(BodyModelFileTest, RejectsUnnormalisedWeights) {
  std::vector<float> weights = fixture_array("weights").to_float();
  for (std::size_t j = 0; j < 55; ++j) weights[7 * 55 + j] *= 2.0f;
  const NpyArray bad = NpyArray::from_float32(weights, {10475, 55});
  expect_rejected(damaged_copy("heavy_weights.npz", "weights", &bad), "weights of vertex 7 sum to 2");
}

// ---------------------------------------------------------------------------------------------
// Caller mistakes

TEST(BodyModelTest, RejectsWrongBufferSizes) {
  const BodyModel& model = fixture_model();
  BodyModelEvaluator evaluator(model);
  std::vector<double> pose(model.pose_size()), joints(3 * model.joint_count()), vertices(3 * model.vertex_count());
  std::vector<double> short_pose(model.pose_size() - 3), short_vertices(vertices.size() - 1);
  const Eigen::Vector3d zero = Eigen::Vector3d::Zero();
  EXPECT_THROW(evaluator.evaluate(short_pose, zero, joints, std::span<double>(vertices)), std::invalid_argument);
  EXPECT_THROW(evaluator.evaluate(pose, zero, joints, std::span<double>(short_vertices)), std::invalid_argument);
  EXPECT_THROW(evaluator.set_shape(std::vector<double>(11)), std::invalid_argument);
  EXPECT_THROW(evaluator.evaluate_batch(2, pose, std::vector<double>(6), joints, {}), std::invalid_argument);
}

}  // namespace
}  // namespace odyssey
