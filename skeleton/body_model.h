// The SMPL family of body models (SMPL 24 joints, SMPL-H 52, SMPL-X 55) and their forward pass,
// following the smplx Python package exactly:
//
//   v_shaped  = v_template + shapedirs[:, :, shape] beta + shapedirs[:, :, expr] psi
//   J         = J_regressor v_shaped                          (rest joints, before correctives)
//   R_j       = rodrigues(theta_j)                            (one per joint)
//   v_posed   = v_shaped + posedirs vec(R_1..R_{J-1} - I)     (pose correctives, root excluded)
//   G_j       = G_parent(j) [R_j | J_j - J_parent(j)],  G_root = [R_0 | J_0]
//   A_j       = G_j [I | -J_j]                                (skinning matrices)
//   v         = sum_j w_vj A_j v_posed + transl,   joints = translation of G_j + transl
//
// so the root rotates about the pelvis joint J_0(beta) and translation is added last. The model
// here is the arrays of the smplx package's npz layout, in the model's own Y-up frame, with
// storage types chosen for the hot loops (posedirs stay float32 as in the files).
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace odyssey {

enum class BodyModelKind { SMPL, SMPLH, SMPLX };
const char* body_model_kind_name(BodyModelKind kind);

// Joint counts: SMPL 24, SMPL-H 52, SMPL-X 55. Pose vectors hold 3 axis-angle numbers a joint.
int body_model_joint_count(BodyModelKind kind);

// Joint names in model order, as the smplx package names them (SMPL-X: the table in
// shared/assets/smplx_joints_55.tsv; SMPL-H drops jaw and eyes; SMPL ends in two hand joints).
std::vector<std::string> body_model_joint_names(BodyModelKind kind);
// The SMPL-X tree: the parent of each of the 55 joints, -1 for the pelvis.
std::vector<int> smplx_parents();

using RowMatrixXd = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using RowMatrixXf = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using RowMatrixXi = Eigen::Matrix<int, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

struct BodyModel {
  BodyModelKind kind = BodyModelKind::SMPLX;
  std::vector<std::string> joint_names;  // SMPL-X names (shared/assets/smplx_joints_55.tsv order)
  std::vector<int> parents;              // parents[0] == -1, parents[j] < j
  RowMatrixXd v_template;                // V x 3
  RowMatrixXi faces;                     // F x 3
  Eigen::SparseMatrix<double, Eigen::RowMajor> j_regressor;  // J x V
  Eigen::SparseMatrix<double, Eigen::RowMajor> weights;      // V x J, rows sum to 1
  RowMatrixXd shapedirs;                 // 3V x (shape_count + expression_count), row 3v+c
  int shape_count = 0;                   // leading columns of shapedirs
  int expression_count = 0;              // trailing columns (SMPL-X only)
  RowMatrixXf posedirs;                  // 3V x 9(J-1), row 3v+c; may be empty (no correctives)
  // Hand pose PCA (SMPL-H / SMPL-X): 45 x 45 components (row k = component k) and 45-D means.
  RowMatrixXd hands_components_left, hands_components_right;
  Eigen::VectorXd hands_mean_left, hands_mean_right;

  int vertex_count() const { return static_cast<int>(v_template.rows()); }
  int joint_count() const { return static_cast<int>(parents.size()); }
  int pose_size() const { return 3 * joint_count(); }
  // Throws std::invalid_argument on inconsistent shapes or non-finite values: validate_layout()
  // and every shapedirs and posedirs value finite.
  void validate() const;
  // Everything validate() checks except that the dense shapedirs and posedirs values are finite
  // (nearly all of the model's bytes): joint count, names, parents, every array's shape, faces in
  // range, v_template, J_regressor and weights finite, weights summing to 1. O(V + non-zeros).
  // BodyModelEvaluator runs this, not validate(): load_body_model checks every value as it
  // decodes it, so a loaded model is walked once; a model built or edited in code should pass
  // validate() once before it is evaluated.
  void validate_layout() const;
};

// Asks the kernel to back the whole pages inside [data, data + bytes) with transparent huge pages
// (madvise MADV_HUGEPAGE; a no-op where that is unavailable). Call it on a large buffer before
// its first write: the dense model's arrays and the per-batch buffers are hundreds of MB, and
// on virtual machines faulting them in 4 KiB at a time cost more than decoding them.
void advise_huge_pages(void* data, std::size_t bytes);

// First joint of each part in the SMPL-X (and SMPL-H) joint order.
struct BodyParts {
  static constexpr int kBodyJoints = 22;         // pelvis .. right_wrist
  static constexpr int kJaw = 22, kLeftEye = 23, kRightEye = 24;  // SMPL-X only
  static int left_hand_first(BodyModelKind kind) { return kind == BodyModelKind::SMPLX ? 25 : 22; }
  static int right_hand_first(BodyModelKind kind) { return kind == BodyModelKind::SMPLX ? 40 : 37; }
};

// A hand's 45-D axis-angle pose from `coefficients` (k <= 45 PCA weights):
//   pose = sum_i c_i components[i] (+ mean when add_mean).
// With k == 45 and use_pca false the coefficients are the pose itself (+ mean when add_mean).
Eigen::VectorXd hand_pose_from_pca(const BodyModel& model, bool left, std::span<const double> coefficients,
                                   bool use_pca, bool add_mean);

// What the caller needs; anything off is skipped entirely, not computed and discarded.
struct BodyModelOptions {
  bool hands = true;             // false: finger joints keep the rest rotation, hand poses ignored
  bool face = true;              // false: jaw and eyes keep the rest rotation, expression ignored
  bool pose_correctives = true;  // false: posedirs are not applied
};

// Evaluates a body model for one shape over many frames. Construction and set_shape() do the
// per-sequence work (shaped template, rest joints, skinning weights regrouped for the LBS loop);
// evaluate() is the per-frame hot path and does not allocate. One evaluator per thread; the
// model is shared read-only and must outlive the evaluator.
//
// Precision: everything is double except the pose-corrective product, which multiplies the
// float32 posedirs by float32 pose features (accumulated in float32). Corrective offsets are
// centimetres, so float32 rounding stays near 1e-9 m; the result matches a float64 evaluation
// of the float32 model values to about 1e-8 m.
class BodyModelEvaluator {
 public:
  // Checks the model's layout (model.validate_layout(), std::invalid_argument) and sets the
  // shape to the mean (all betas 0).
  BodyModelEvaluator(const BodyModel& model, BodyModelOptions options = {});
  ~BodyModelEvaluator();
  BodyModelEvaluator(BodyModelEvaluator&&) noexcept;
  BodyModelEvaluator(const BodyModelEvaluator&) = delete;
  BodyModelEvaluator& operator=(const BodyModelEvaluator&) = delete;
  BodyModelEvaluator& operator=(BodyModelEvaluator&&) = delete;

  const BodyModel& model() const { return model_; }
  const BodyModelOptions& options() const { return options_; }

  // betas: up to shape_count values (missing ones are 0); expression likewise (ignored with
  // options.face false or for models without expression directions).
  void set_shape(std::span<const double> betas, std::span<const double> expression = {});
  const RowMatrixXd& rest_joints() const { return rest_joints_; }  // J x 3, J(beta)
  const RowMatrixXd& shaped_vertices() const { return v_shaped_; }  // V x 3

  // One frame. full_pose: pose_size() axis-angle numbers in model joint order (hands as full
  // 45-D, already expanded from PCA). joints_out: J x 3 row-major; vertices_out: V x 3
  // row-major or empty to skip the mesh.
  void evaluate(std::span<const double> full_pose, const Eigen::Vector3d& translation, std::span<double> joints_out,
                std::span<double> vertices_out);
  void evaluate(std::span<const double> full_pose, const Eigen::Vector3d& translation, std::span<double> joints_out,
                std::span<float> vertices_out);

  // `frames` frames at once (poses frames x pose_size(), translations frames x 3, joints_out
  // frames x J x 3, vertices_out frames x V x 3 or empty): the pose correctives of the whole
  // batch are one matrix product posedirs x features. Allocates only when a batch is longer
  // than any before it (the buffers grow to fit) and inside Eigen's matrix product, which packs
  // its operands into scratch blocks once per batch.
  void evaluate_batch(int frames, std::span<const double> full_poses, std::span<const double> translations,
                      std::span<double> joints_out, std::span<float> vertices_out);

 private:
  struct Workspace;
  // Rotations, pose features, forward kinematics and skinning matrices of one frame; writes
  // the joints and, when `features` is not null, the pose-corrective features.
  void pose_frame(std::span<const double> full_pose, const Eigen::Vector3d& translation, std::span<double> joints_out,
                  float* features, Eigen::Matrix4d* skinning);
  // Blends the skinning matrices over every vertex; `offsets` (3V pose-corrective offsets) may
  // be null.
  template <class Scalar>
  void skin(const Eigen::Matrix4d* skinning, const float* offsets, const Eigen::Vector3d& translation,
            Scalar* vertices_out) const;
  template <class Scalar>
  void evaluate_one(std::span<const double> full_pose, const Eigen::Vector3d& translation, std::span<double> joints_out,
                    std::span<Scalar> vertices_out);

  const BodyModel& model_;
  BodyModelOptions options_;
  RowMatrixXd v_shaped_;
  RowMatrixXd rest_joints_;
  std::unique_ptr<Workspace> workspace_;
};

}  // namespace odyssey
