// GCC 12 reports -Wmaybe-uninitialized inside its own AVX-512 intrinsics (_mm512_undefined_ps,
// GCC bug 105593, fixed in GCC 13) when Eigen's float matrix product is inlined here. The
// diagnostic is tied to where the intrinsics are first included, so silence it for those
// headers only; the project's own code keeps the warning.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <Eigen/Core>
#pragma GCC diagnostic pop

#include "skeleton/body_model.h"

#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "skeleton/fk.h"
#include "skeleton/rotation.h"

namespace odyssey {

const char* body_model_kind_name(BodyModelKind kind) {
  switch (kind) {
    case BodyModelKind::SMPL: return "SMPL";
    case BodyModelKind::SMPLH: return "SMPL-H";
    case BodyModelKind::SMPLX: return "SMPL-X";
  }
  return "unknown";
}

namespace {

// SMPL-X joint names in model order, identical to shared/assets/smplx_joints_55.tsv (the smplx
// package's JOINT_NAMES[0:55]). Embedded so that nothing needs the asset file at run time.
constexpr std::array<const char*, 55> kSmplxJointNames = {
    "pelvis",         "left_hip",         "right_hip",     "spine1",        "left_knee",      "right_knee",
    "spine2",         "left_ankle",       "right_ankle",   "spine3",        "left_foot",      "right_foot",
    "neck",           "left_collar",      "right_collar",  "head",          "left_shoulder",  "right_shoulder",
    "left_elbow",     "right_elbow",      "left_wrist",    "right_wrist",   "jaw",            "left_eye_smplhf",
    "right_eye_smplhf", "left_index1",    "left_index2",   "left_index3",   "left_middle1",   "left_middle2",
    "left_middle3",   "left_pinky1",      "left_pinky2",   "left_pinky3",   "left_ring1",     "left_ring2",
    "left_ring3",     "left_thumb1",      "left_thumb2",   "left_thumb3",   "right_index1",   "right_index2",
    "right_index3",   "right_middle1",    "right_middle2", "right_middle3", "right_pinky1",   "right_pinky2",
    "right_pinky3",   "right_ring1",      "right_ring2",   "right_ring3",   "right_thumb1",   "right_thumb2",
    "right_thumb3"};

// The SMPL-X tree (parent of each joint; the root has -1).
constexpr std::array<int, 55> kSmplxParents = {-1, 0,  0,  0,  1,  2,  3,  4,  5,  6,  7,  8,  9,  9,
                                               9,  12, 13, 14, 16, 17, 18, 19, 15, 15, 15, 20, 25, 26,
                                               20, 28, 29, 20, 31, 32, 20, 34, 35, 20, 37, 38, 21, 40,
                                               41, 21, 43, 44, 21, 46, 47, 21, 49, 50, 21, 52, 53};

}  // namespace

// SMPL-X is body 0-21, face 22-24, hands 25-54; SMPL-H drops the face joints; SMPL ends the
// body with one joint per hand, named as in the smplx package.
std::vector<std::string> body_model_joint_names(BodyModelKind kind) {
  std::vector<std::string> names(kSmplxJointNames.begin(), kSmplxJointNames.begin() + BodyParts::kBodyJoints);
  switch (kind) {
    case BodyModelKind::SMPL:
      names.emplace_back("left_hand");
      names.emplace_back("right_hand");
      break;
    case BodyModelKind::SMPLH:
      names.insert(names.end(), kSmplxJointNames.begin() + 25, kSmplxJointNames.end());
      break;
    case BodyModelKind::SMPLX:
      names.insert(names.end(), kSmplxJointNames.begin() + BodyParts::kBodyJoints, kSmplxJointNames.end());
      break;
  }
  return names;
}

std::vector<int> smplx_parents() { return {kSmplxParents.begin(), kSmplxParents.end()}; }

int body_model_joint_count(BodyModelKind kind) {
  switch (kind) {
    case BodyModelKind::SMPL: return 24;
    case BodyModelKind::SMPLH: return 52;
    case BodyModelKind::SMPLX: return 55;
  }
  return 0;
}

namespace {

[[noreturn]] void invalid(const std::string& problem) { throw std::invalid_argument("body model: " + problem); }

std::string shape_text(Eigen::Index rows, Eigen::Index cols) {
  return std::to_string(rows) + " x " + std::to_string(cols);
}

void require_shape(const char* name, Eigen::Index rows, Eigen::Index cols, Eigen::Index want_rows, Eigen::Index want_cols) {
  if (rows != want_rows || cols != want_cols) {
    invalid(std::string(name) + " is " + shape_text(rows, cols) + ", expected " + shape_text(want_rows, want_cols));
  }
}

// True when no value is a NaN or an infinity: the exponent bits are not all ones. Branch-free
// over the whole array so it vectorises (Eigen's allFinite() does not, and cost a tenth of a
// whole `odyssey pose` run on the dense model).
template <class Scalar>
bool all_finite(const Scalar* values, std::size_t count) {
  using Bits = std::conditional_t<sizeof(Scalar) == 4, std::uint32_t, std::uint64_t>;
  constexpr Bits kExponent = sizeof(Scalar) == 4 ? Bits(0x7f800000u) : Bits(0x7ff0000000000000ull);
  Bits non_finite = 0;
  for (std::size_t i = 0; i < count; ++i) {
    Bits bits;
    std::memcpy(&bits, values + i, sizeof bits);
    non_finite |= Bits((bits & kExponent) == kExponent);
  }
  return non_finite == 0;
}

template <class Values>
void require_finite(const char* name, const Values& values) {
  if (!all_finite(values.data(), std::size_t(values.size()))) invalid(std::string(name) + " holds a NaN or infinite value");
}

template <class Sparse>
void require_finite_sparse(const char* name, const Sparse& matrix) {
  if (!all_finite(matrix.valuePtr(), std::size_t(matrix.nonZeros()))) {
    invalid(std::string(name) + " holds a NaN or infinite value");
  }
}

}  // namespace

void BodyModel::validate() const {
  validate_layout();
  require_finite("shapedirs", shapedirs);
  require_finite("posedirs", posedirs);
}

void BodyModel::validate_layout() const {
  const int joints = joint_count();
  const int vertices = vertex_count();
  const int expected_joints = body_model_joint_count(kind);
  if (joints != expected_joints) {
    invalid(std::to_string(joints) + " joints for a " + body_model_kind_name(kind) + " model, expected " +
            std::to_string(expected_joints));
  }
  if (static_cast<int>(joint_names.size()) != joints) {
    invalid(std::to_string(joint_names.size()) + " joint names for " + std::to_string(joints) + " joints");
  }
  if (parents[0] != -1) invalid("joint 0 (the root) has parent " + std::to_string(parents[0]) + ", expected -1");
  for (int j = 1; j < joints; ++j) {
    if (parents[j] < 0 || parents[j] >= j) {
      invalid("joint " + std::to_string(j) + " has parent " + std::to_string(parents[j]) + ", which does not precede it");
    }
  }
  if (vertices == 0) invalid("v_template has no vertices");
  require_shape("v_template", v_template.rows(), v_template.cols(), vertices, 3);
  require_finite("v_template", v_template);
  if (faces.cols() != 3) invalid("faces is " + shape_text(faces.rows(), faces.cols()) + ", expected F x 3");
  if (faces.size() > 0 && (faces.minCoeff() < 0 || faces.maxCoeff() >= vertices)) {
    invalid("faces index a vertex outside 0.." + std::to_string(vertices - 1));
  }
  require_shape("J_regressor", j_regressor.rows(), j_regressor.cols(), joints, vertices);
  require_finite_sparse("J_regressor", j_regressor);
  require_shape("weights", weights.rows(), weights.cols(), vertices, joints);
  require_finite_sparse("weights", weights);
  // Translation is added after blending, so the blend must be affine (weights summing to 1);
  // the tolerance admits float32 storage and catches transposed or unnormalised arrays.
  const Eigen::VectorXd weight_sums = weights * Eigen::VectorXd::Ones(joints);
  for (int v = 0; v < vertices; ++v) {
    if (std::abs(weight_sums[v] - 1.0) > 1e-3) {
      invalid("skinning weights of vertex " + std::to_string(v) + " sum to " + std::to_string(weight_sums[v]) +
              ", expected 1");
    }
  }
  if (shape_count < 0 || expression_count < 0) invalid("negative shape or expression count");
  if (expression_count > 0 && kind != BodyModelKind::SMPLX) invalid("expression directions on a non-SMPL-X model");
  require_shape("shapedirs", shapedirs.rows(), shapedirs.cols(), 3 * Eigen::Index(vertices),
                shape_count + expression_count);
  if (posedirs.size() > 0) {
    require_shape("posedirs", posedirs.rows(), posedirs.cols(), 3 * Eigen::Index(vertices), 9 * (joints - 1));
  }
  // Hand PCA is optional in memory (a model built in code may not need it); when present it
  // must be complete, and SMPL has no separate hands to apply it to.
  const bool has_hands = hands_components_left.size() + hands_components_right.size() + hands_mean_left.size() +
                             hands_mean_right.size() > 0;
  if (has_hands) {
    if (kind == BodyModelKind::SMPL) invalid("hand PCA arrays on an SMPL model");
    require_shape("hands_componentsl", hands_components_left.rows(), hands_components_left.cols(), 45, 45);
    require_shape("hands_componentsr", hands_components_right.rows(), hands_components_right.cols(), 45, 45);
    require_shape("hands_meanl", hands_mean_left.size(), 1, 45, 1);
    require_shape("hands_meanr", hands_mean_right.size(), 1, 45, 1);
    require_finite("hands_componentsl", hands_components_left);
    require_finite("hands_componentsr", hands_components_right);
    require_finite("hands_meanl", hands_mean_left);
    require_finite("hands_meanr", hands_mean_right);
  }
}

void advise_huge_pages(void* data, std::size_t bytes) {
#ifdef MADV_HUGEPAGE
  const long page = ::sysconf(_SC_PAGESIZE);
  if (data == nullptr || page <= 0 || bytes < (std::size_t(2) << 20)) return;
  const std::uintptr_t begin = (reinterpret_cast<std::uintptr_t>(data) + page - 1) / page * page;
  const std::uintptr_t end = (reinterpret_cast<std::uintptr_t>(data) + bytes) / page * page;
  if (end > begin) ::madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);  // advice only
#else
  (void)data;
  (void)bytes;
#endif
}

Eigen::VectorXd hand_pose_from_pca(const BodyModel& model, bool left, std::span<const double> coefficients,
                                   bool use_pca, bool add_mean) {
  const RowMatrixXd& components = left ? model.hands_components_left : model.hands_components_right;
  const Eigen::VectorXd& mean = left ? model.hands_mean_left : model.hands_mean_right;
  const Eigen::Map<const Eigen::VectorXd> c(coefficients.data(), Eigen::Index(coefficients.size()));
  if ((use_pca || add_mean) && (components.rows() != 45 || mean.size() != 45)) {
    throw std::invalid_argument(std::string("hand_pose_from_pca: the ") + body_model_kind_name(model.kind) +
                                " model has no hand PCA");
  }
  Eigen::VectorXd pose;
  if (use_pca) {
    if (coefficients.size() > 45) {
      throw std::invalid_argument("hand_pose_from_pca: " + std::to_string(coefficients.size()) +
                                  " coefficients, at most 45");
    }
    // Component k is row k, so pose_j = sum_k c_k components(k, j).
    pose = components.topRows(c.size()).transpose() * c;
  } else {
    if (coefficients.size() != 45) {
      throw std::invalid_argument("hand_pose_from_pca: " + std::to_string(coefficients.size()) +
                                  " numbers for a full hand pose, expected 45");
    }
    pose = c;
  }
  if (add_mean) pose += mean;
  return pose;
}

// Per-evaluator state: the skinning weights regrouped for the LBS loop (constant after
// construction) and the per-frame buffers (sized on construction, grown for longer batches).
struct BodyModelEvaluator::Workspace {
  // Vertices with exactly `influences` non-zero weights, as structure of arrays: vertex i of the
  // group is `vertices[i]`, its joints and weights are joints/weights[i*influences .. +influences).
  // A fixed influence count per group lets the blend loop unroll and keeps each vertex's data in
  // one contiguous run.
  struct InfluenceGroup {
    int influences = 0;
    std::vector<int> vertices;
    std::vector<int> joints;
    std::vector<double> weights;
  };
  std::vector<InfluenceGroup> groups;

  std::vector<char> rotation_free;  // per joint: false where options pin it to the rest rotation
  // Pose features 9(j-1)..9j-1 belong to joint j; joints past the last free one always give zero
  // features, so the corrective product uses only the leading `corrective_columns` of posedirs
  // (216 of 486 for SMPL-X without hands: less than half the bytes streamed per frame).
  int corrective_columns = 0;

  // The kinematic chain (parents, as the model has them) and its pose: local translations from
  // set_shape, rotations per frame.
  KinematicModel chain;
  KinematicData<double> pose;
  // Skinning matrices A_j = G_j [I | -J_j] as 4x4 column-major with a zero last row, so blending
  // and applying them are whole-register operations: frame f, joint j at [f * J + j].
  std::vector<Eigen::Matrix4d> skinning;
  Eigen::MatrixXf features;  // corrective_columns x frames (column f: frame f)
  Eigen::MatrixXf offsets;   // 3V x frames: posedirs x features, row 3v+c
  int capacity = 0;          // frames the buffers hold

  void reserve(int frames, int joints, int vertices) {
    if (frames <= capacity) return;
    skinning.resize(std::size_t(frames) * joints);
    features.resize(corrective_columns, frames);
    offsets.resize(corrective_columns > 0 ? 3 * Eigen::Index(vertices) : 0, frames);
    advise_huge_pages(offsets.data(), std::size_t(offsets.size()) * sizeof(float));
    capacity = frames;
  }
};

BodyModelEvaluator::BodyModelEvaluator(const BodyModel& model, BodyModelOptions options)
    : model_(model), options_(options), workspace_(std::make_unique<Workspace>()) {
  model_.validate_layout();
  Workspace& ws = *workspace_;
  const int joints = model_.joint_count();
  const int vertices = model_.vertex_count();

  ws.rotation_free.assign(joints, 1);
  if (!options_.face && model_.kind == BodyModelKind::SMPLX) {
    for (int j : {BodyParts::kJaw, BodyParts::kLeftEye, BodyParts::kRightEye}) ws.rotation_free[j] = 0;
  }
  if (!options_.hands && model_.kind != BodyModelKind::SMPL) {
    // The 2 x 15 finger joints close the SMPL-H and SMPL-X joint order, left hand first.
    for (int j = BodyParts::left_hand_first(model_.kind); j < joints; ++j) ws.rotation_free[j] = 0;
  }
  if (options_.pose_correctives && model_.posedirs.size() > 0) {
    int last_free = 0;
    for (int j = 1; j < joints; ++j) {
      if (ws.rotation_free[j]) last_free = j;
    }
    ws.corrective_columns = 9 * last_free;
  }

  std::vector<std::vector<int>> members_by_count(1);
  for (int v = 0; v < vertices; ++v) {
    int count = 0;
    for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(model_.weights, v); it; ++it) {
      if (it.value() != 0.0) ++count;
    }
    if (count >= static_cast<int>(members_by_count.size())) members_by_count.resize(count + 1);
    members_by_count[count].push_back(v);
  }
  // Count 0 cannot occur: validate() demands weights summing to 1.
  for (int count = 1; count < static_cast<int>(members_by_count.size()); ++count) {
    if (members_by_count[count].empty()) continue;
    Workspace::InfluenceGroup group;
    group.influences = count;
    group.vertices = members_by_count[count];
    for (int v : group.vertices) {
      for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(model_.weights, v); it; ++it) {
        if (it.value() == 0.0) continue;
        group.joints.push_back(static_cast<int>(it.col()));
        group.weights.push_back(it.value());
      }
    }
    ws.groups.push_back(std::move(group));
  }

  ws.chain = KinematicModel(model_.parents, {});
  ws.pose = KinematicData<double>(ws.chain);
  ws.reserve(1, joints, vertices);
  set_shape({});
}

BodyModelEvaluator::~BodyModelEvaluator() = default;
BodyModelEvaluator::BodyModelEvaluator(BodyModelEvaluator&&) noexcept = default;

void BodyModelEvaluator::set_shape(std::span<const double> betas, std::span<const double> expression) {
  const int vertices = model_.vertex_count();
  const int joints = model_.joint_count();
  if (betas.size() > std::size_t(model_.shape_count)) {
    throw std::invalid_argument("set_shape: " + std::to_string(betas.size()) + " betas for a model with " +
                                std::to_string(model_.shape_count) + " shape directions");
  }
  const bool use_expression = options_.face && model_.expression_count > 0;
  if (use_expression && expression.size() > std::size_t(model_.expression_count)) {
    throw std::invalid_argument("set_shape: " + std::to_string(expression.size()) +
                                " expression coefficients for a model with " +
                                std::to_string(model_.expression_count) + " expression directions");
  }
  // v_shaped (flattened to 3V, entry 3v+c) = v_template + S[:, :|beta|] beta + E[:, :|psi|] psi,
  // where the expression directions E are the shapedirs columns after the shape ones.
  v_shaped_ = model_.v_template;
  Eigen::Map<Eigen::VectorXd> shaped(v_shaped_.data(), 3 * Eigen::Index(vertices));
  const Eigen::Map<const Eigen::VectorXd> beta(betas.data(), Eigen::Index(betas.size()));
  shaped.noalias() += model_.shapedirs.leftCols(beta.size()) * beta;
  if (use_expression) {
    const Eigen::Map<const Eigen::VectorXd> psi(expression.data(), Eigen::Index(expression.size()));
    shaped.noalias() += model_.shapedirs.middleCols(model_.shape_count, psi.size()) * psi;
  }
  // Rest joints come from the shaped template before pose correctives, as in the reference.
  rest_joints_ = model_.j_regressor * v_shaped_;

  // Local translations of the kinematic chain: G_root = [R_0 | J_0], then J_j - J_parent(j).
  Workspace& ws = *workspace_;
  for (int j = 0; j < joints; ++j) {
    const int parent = model_.parents[j];
    ws.pose.local[j].translation = rest_joints_.row(j).transpose();
    if (parent >= 0) ws.pose.local[j].translation -= rest_joints_.row(parent).transpose();
  }
}

void BodyModelEvaluator::pose_frame(std::span<const double> full_pose, const Eigen::Vector3d& translation,
                                    std::span<double> joints_out, float* features, Eigen::Matrix4d* skinning) {
  Workspace& ws = *workspace_;
  const int joints = model_.joint_count();
  for (int j = 0; j < joints; ++j) {
    Eigen::Matrix3d& rotation = ws.pose.local[j].rotation;
    if (ws.rotation_free[j]) {
      rotation = rodrigues(Eigen::Vector3d(full_pose[3 * j], full_pose[3 * j + 1], full_pose[3 * j + 2]));
    } else {
      rotation.setIdentity();
    }
    // Pose feature of joint j >= 1: vec(R_j - I), row-major, at 9(j-1).
    if (features != nullptr && j >= 1 && 9 * j <= ws.corrective_columns) {
      float* feature = features + 9 * (j - 1);
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) feature[3 * r + c] = static_cast<float>(rotation(r, c) - (r == c ? 1.0 : 0.0));
      }
    }
  }
  forward_kinematics(ws.chain, ws.pose);
  for (int j = 0; j < joints; ++j) {
    const RigidTransform<double>& g = ws.pose.world[j];
    for (int c = 0; c < 3; ++c) joints_out[3 * j + c] = g.translation[c] + translation[c];
    if (skinning != nullptr) {
      // A_j = G_j [I | -J_j] = [R_j^world | t_j^world - R_j^world J_j].
      Eigen::Matrix4d& a = skinning[j];
      a.topLeftCorner<3, 3>() = g.rotation;
      a.topRightCorner<3, 1>().noalias() = g.translation - g.rotation * rest_joints_.row(j).transpose();
      a.row(3).setZero();
    }
  }
}

namespace {

// Linear blend skinning of `count` vertices that each have `influences` weights (a compile-time
// K when 1 <= K <= 8, so the blend unrolls; K = 0 reads the count at run time):
//   M_v = sum_k w_vk A_{j_vk}   (3x4, 12 multiply-adds per influence)
//   v'  = M_v [p_v; 1] + transl, p_v = v_shaped + corrective offset (12 multiply-adds per vertex)
// Blending the matrices first, rather than transforming the point once per influence, leaves
// one matrix-vector product per vertex. The 3x4 blocks sit in 4x4 column-major storage with a
// zero last row, so a blend step is two 8-wide FMAs on AVX-512 and the product four 4-wide ones.
template <int K, bool kCorrectives, class Scalar>
void skin_vertices(int influences, std::size_t count, const int* vertices, const int* joints, const double* weights,
                   const Eigen::Matrix4d* skinning, const double* shaped, const float* offsets,
                   const Eigen::Vector3d& translation, Scalar* out) {
  const int k_count = K > 0 ? K : influences;
  for (std::size_t i = 0; i < count; ++i, joints += k_count, weights += k_count) {
    Eigen::Matrix4d m = weights[0] * skinning[joints[0]];
    for (int k = 1; k < k_count; ++k) m.noalias() += weights[k] * skinning[joints[k]];
    const std::size_t v = 3 * std::size_t(vertices[i]);
    double x = shaped[v], y = shaped[v + 1], z = shaped[v + 2];
    if constexpr (kCorrectives) {
      x += offsets[v];
      y += offsets[v + 1];
      z += offsets[v + 2];
    }
    const Eigen::Vector4d posed = m.col(0) * x + m.col(1) * y + m.col(2) * z + m.col(3);
    out[v] = static_cast<Scalar>(posed[0] + translation[0]);
    out[v + 1] = static_cast<Scalar>(posed[1] + translation[1]);
    out[v + 2] = static_cast<Scalar>(posed[2] + translation[2]);
  }
}

template <bool kCorrectives, class Scalar>
void skin_group(int influences, std::size_t count, const int* vertices, const int* joints, const double* weights,
                const Eigen::Matrix4d* skinning, const double* shaped, const float* offsets,
                const Eigen::Vector3d& translation, Scalar* out) {
  switch (influences) {
#define ODYSSEY_SKIN_CASE(K)                                                                                 \
  case K:                                                                                                    \
    return skin_vertices<K, kCorrectives>(K, count, vertices, joints, weights, skinning, shaped, offsets, \
                                          translation, out);
    ODYSSEY_SKIN_CASE(1)
    ODYSSEY_SKIN_CASE(2)
    ODYSSEY_SKIN_CASE(3)
    ODYSSEY_SKIN_CASE(4)
    ODYSSEY_SKIN_CASE(5)
    ODYSSEY_SKIN_CASE(6)
    ODYSSEY_SKIN_CASE(7)
    ODYSSEY_SKIN_CASE(8)
#undef ODYSSEY_SKIN_CASE
    default:
      return skin_vertices<0, kCorrectives>(influences, count, vertices, joints, weights, skinning, shaped, offsets,
                                            translation, out);
  }
}

}  // namespace

template <class Scalar>
void BodyModelEvaluator::skin(const Eigen::Matrix4d* skinning, const float* offsets, const Eigen::Vector3d& translation,
                              Scalar* vertices_out) const {
  for (const Workspace::InfluenceGroup& g : workspace_->groups) {
    if (offsets != nullptr) {
      skin_group<true>(g.influences, g.vertices.size(), g.vertices.data(), g.joints.data(), g.weights.data(), skinning,
                       v_shaped_.data(), offsets, translation, vertices_out);
    } else {
      skin_group<false>(g.influences, g.vertices.size(), g.vertices.data(), g.joints.data(), g.weights.data(), skinning,
                        v_shaped_.data(), offsets, translation, vertices_out);
    }
  }
}

namespace {

void require_size(const char* what, std::size_t size, std::size_t expected) {
  if (size != expected) {
    throw std::invalid_argument(std::string("BodyModelEvaluator: ") + what + " has " + std::to_string(size) +
                                " numbers, expected " + std::to_string(expected));
  }
}

}  // namespace

template <class Scalar>
void BodyModelEvaluator::evaluate_one(std::span<const double> full_pose, const Eigen::Vector3d& translation,
                                      std::span<double> joints_out, std::span<Scalar> vertices_out) {
  const std::size_t joints = model_.joint_count();
  const std::size_t vertices = model_.vertex_count();
  require_size("full_pose", full_pose.size(), 3 * joints);
  require_size("joints_out", joints_out.size(), 3 * joints);
  if (!vertices_out.empty()) require_size("vertices_out", vertices_out.size(), 3 * vertices);

  Workspace& ws = *workspace_;
  const bool mesh = !vertices_out.empty();
  const bool correctives = mesh && ws.corrective_columns > 0;
  pose_frame(full_pose, translation, joints_out, correctives ? ws.features.data() : nullptr,
             mesh ? ws.skinning.data() : nullptr);
  if (!mesh) return;
  const float* offsets = nullptr;
  if (correctives) {
    // One float32 matrix-vector product, 3V x C times C: memory bound (posedirs streams once).
    Eigen::Map<Eigen::VectorXf> frame_offsets(ws.offsets.data(), ws.offsets.rows());
    frame_offsets.noalias() = model_.posedirs.leftCols(ws.corrective_columns) * ws.features.col(0);
    offsets = frame_offsets.data();
  }
  skin(ws.skinning.data(), offsets, translation, vertices_out.data());
}

void BodyModelEvaluator::evaluate(std::span<const double> full_pose, const Eigen::Vector3d& translation,
                                  std::span<double> joints_out, std::span<double> vertices_out) {
  evaluate_one<double>(full_pose, translation, joints_out, vertices_out);
}

void BodyModelEvaluator::evaluate(std::span<const double> full_pose, const Eigen::Vector3d& translation,
                                  std::span<double> joints_out, std::span<float> vertices_out) {
  evaluate_one<float>(full_pose, translation, joints_out, vertices_out);
}

void BodyModelEvaluator::evaluate_batch(int frames, std::span<const double> full_poses,
                                        std::span<const double> translations, std::span<double> joints_out,
                                        std::span<float> vertices_out) {
  if (frames < 0) throw std::invalid_argument("BodyModelEvaluator: negative frame count");
  const std::size_t joints = model_.joint_count();
  const std::size_t vertices = model_.vertex_count();
  const std::size_t n = frames;
  require_size("full_poses", full_poses.size(), n * 3 * joints);
  require_size("translations", translations.size(), n * 3);
  require_size("joints_out", joints_out.size(), n * 3 * joints);
  if (!vertices_out.empty()) require_size("vertices_out", vertices_out.size(), n * 3 * vertices);

  const auto frame_translation = [&](std::size_t f) {
    return Eigen::Vector3d(translations[3 * f], translations[3 * f + 1], translations[3 * f + 2]);
  };
  Workspace& ws = *workspace_;
  if (vertices_out.empty() || ws.corrective_columns == 0) {
    // Nothing to share between frames without the corrective product.
    for (std::size_t f = 0; f < n; ++f) {
      evaluate_one<float>(full_poses.subspan(f * 3 * joints, 3 * joints), frame_translation(f),
                          joints_out.subspan(f * 3 * joints, 3 * joints),
                          vertices_out.empty() ? vertices_out : vertices_out.subspan(f * 3 * vertices, 3 * vertices));
    }
    return;
  }
  ws.reserve(frames, int(joints), int(vertices));
  for (std::size_t f = 0; f < n; ++f) {
    pose_frame(full_poses.subspan(f * 3 * joints, 3 * joints), frame_translation(f),
               joints_out.subspan(f * 3 * joints, 3 * joints), ws.features.col(Eigen::Index(f)).data(),
               ws.skinning.data() + f * joints);
  }
  // The whole batch's correctives as one float32 matrix product (3V x C) (C x frames): posedirs
  // streams from memory once per batch instead of once per frame, so this is compute bound.
  ws.offsets.leftCols(frames).noalias() =
      model_.posedirs.leftCols(ws.corrective_columns) * ws.features.leftCols(frames);
  for (std::size_t f = 0; f < n; ++f) {
    skin(ws.skinning.data() + f * joints, ws.offsets.col(Eigen::Index(f)).data(), frame_translation(f),
         vertices_out.data() + f * 3 * vertices);
  }
}

}  // namespace odyssey
