#include "mocap_io/body_model_writer.h"

#include <cstddef>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <vector>

#include "mocap_io/npy.h"

namespace odyssey::io {
namespace {

// Streams `count` values value(i) (flat C-order index) as float32 in bounded chunks, so the
// 400-column shapedirs never exist twice in memory.
template <class Value>
void add_float32(NpzWriter& npz, const std::string& key, std::vector<std::size_t> shape, Value value) {
  constexpr std::size_t kChunk = std::size_t(1) << 16;
  std::size_t count = 1;
  for (std::size_t extent : shape) count *= extent;
  npz.begin_array(key, DType::Float32, std::move(shape));
  std::vector<float> chunk;
  chunk.reserve(kChunk);
  for (std::size_t i = 0; i < count; ++i) {
    chunk.push_back(static_cast<float>(value(i)));
    if (chunk.size() == kChunk || i + 1 == count) {
      npz.append(std::span<const float>(chunk));
      chunk.clear();
    }
  }
  npz.end_array();
}

// A sparse matrix as a dense float32 array of its shape.
void add_dense(NpzWriter& npz, const std::string& key, const Eigen::SparseMatrix<double, Eigen::RowMajor>& matrix) {
  const RowMatrixXf dense = RowMatrixXf(matrix.cast<float>());
  npz.add(key, NpyArray::from_float32(std::span<const float>(dense.data(), std::size_t(dense.size())),
                                      {std::size_t(dense.rows()), std::size_t(dense.cols())}));
}

void check_landmarks(const BodyModel& model, const FaceLandmarks& landmarks) {
  const auto check_faces = [&](const char* what, const int* faces, Eigen::Index count) {
    for (Eigen::Index i = 0; i < count; ++i) {
      if (faces[i] < 0 || faces[i] >= model.faces.rows()) {
        throw std::invalid_argument(std::string(what) + " " + std::to_string(i) + " names triangle " +
                                    std::to_string(faces[i]) + ", outside 0.." +
                                    std::to_string(model.faces.rows() - 1));
      }
    }
  };
  const Eigen::Index count = Eigen::Index(landmarks.faces.size());
  if (landmarks.barycentric.rows() != count || landmarks.barycentric.cols() != 3 ||
      !landmarks.barycentric.allFinite()) {
    throw std::invalid_argument("landmark barycentric coordinates are not " + std::to_string(count) +
                                " finite rows of 3");
  }
  check_faces("landmark", landmarks.faces.data(), count);
  if (landmarks.contour_faces.size() == 0) return;
  if (landmarks.contour_faces.rows() != FaceLandmarks::kYawBins ||
      landmarks.contour_faces.cols() != FaceLandmarks::kContourCount ||
      landmarks.contour_barycentric.rows() != landmarks.contour_faces.size() ||
      landmarks.contour_barycentric.cols() != 3 || !landmarks.contour_barycentric.allFinite()) {
    throw std::invalid_argument("contour landmarks are not 79 x 17 triangles with finite barycentric rows of 3");
  }
  check_faces("contour landmark", landmarks.contour_faces.data(), landmarks.contour_faces.size());
}

}  // namespace

void write_body_model(const std::string& path, const BodyModel& model, const FaceLandmarks* landmarks) {
  model.validate();
  if (landmarks) check_landmarks(model, *landmarks);
  const std::size_t vertices = std::size_t(model.vertex_count());
  const std::size_t joints = std::size_t(model.joint_count());
  const bool smplx = model.kind == BodyModelKind::SMPLX;

  // Column c of the file's shapedirs holds model column source[c], or zeros where source[c] < 0.
  std::vector<int> source;
  const bool as_stored = !smplx || (model.shape_count == 10 && model.expression_count == 10) ||
                         (model.shape_count == 300 && model.expression_count == 100);
  if (as_stored) {
    for (int c = 0; c < model.shape_count + model.expression_count; ++c) source.push_back(c);
  } else {
    if (model.shape_count > 300 || model.expression_count > 100) {
      throw std::invalid_argument("an SMPL-X model with " + std::to_string(model.shape_count) + " shape and " +
                                  std::to_string(model.expression_count) +
                                  " expression directions does not fit the smplx layout (at most 300 + 100)");
    }
    source.assign(400, -1);
    for (int c = 0; c < model.shape_count; ++c) source[c] = c;
    for (int c = 0; c < model.expression_count; ++c) source[300 + c] = model.shape_count + c;
  }

  NpzWriter npz(path);
  add_float32(npz, "v_template", {vertices, 3}, [&](std::size_t i) { return model.v_template.data()[i]; });
  std::vector<std::uint32_t> faces(std::size_t(model.faces.size()));
  for (std::size_t i = 0; i < faces.size(); ++i) faces[i] = std::uint32_t(model.faces.data()[i]);
  npz.add("f", NpyArray::from_uint32(faces, {std::size_t(model.faces.rows()), 3}));
  add_dense(npz, "J_regressor", model.j_regressor);
  add_dense(npz, "weights", model.weights);

  // SMPL-family files store the root's parent as uint32 -1 in an int64 table.
  std::vector<std::int64_t> kintree(2 * joints);
  for (std::size_t j = 0; j < joints; ++j) {
    kintree[j] = model.parents[j] < 0 ? std::int64_t(0xffffffffu) : std::int64_t(model.parents[j]);
    kintree[joints + j] = std::int64_t(j);
  }
  npz.add("kintree_table", NpyArray::from_int64(kintree, {2, joints}));

  const std::size_t columns = source.size();
  add_float32(npz, "shapedirs", {vertices, 3, columns}, [&](std::size_t i) {
    const int column = source[i % columns];
    return column < 0 ? 0.0 : model.shapedirs(Eigen::Index(i / columns), column);
  });

  // posedirs (V, 3, P) in C order is the row-major 3V x P matrix as it is.
  const std::size_t pose_features = 9 * (joints - 1);
  if (model.posedirs.size() > 0) {
    npz.begin_array("posedirs", DType::Float32, {vertices, 3, pose_features});
    npz.append(std::span<const float>(model.posedirs.data(), std::size_t(model.posedirs.size())));
    npz.end_array();
  } else {
    add_float32(npz, "posedirs", {vertices, 3, pose_features}, [](std::size_t) { return 0.0; });
  }

  if (model.kind != BodyModelKind::SMPL) {
    const bool has_hands = model.hands_components_left.size() > 0;
    const auto components = [&](const char* key, const RowMatrixXd& stored) {
      const RowMatrixXd matrix = has_hands ? stored : RowMatrixXd::Identity(45, 45);
      add_float32(npz, key, {45, 45}, [&](std::size_t i) { return matrix.data()[i]; });
    };
    const auto mean = [&](const char* key, const Eigen::VectorXd& stored) {
      add_float32(npz, key, {45}, [&](std::size_t i) { return has_hands ? stored[Eigen::Index(i)] : 0.0; });
    };
    components("hands_componentsl", model.hands_components_left);
    components("hands_componentsr", model.hands_components_right);
    mean("hands_meanl", model.hands_mean_left);
    mean("hands_meanr", model.hands_mean_right);
  }

  if (smplx) {
    const std::size_t count = landmarks ? landmarks->faces.size() : 0;
    std::vector<std::int64_t> landmark_faces(count);
    for (std::size_t i = 0; i < count; ++i) landmark_faces[i] = landmarks->faces[i];
    npz.add("lmk_faces_idx", NpyArray::from_int64(landmark_faces, {count}));
    add_float32(npz, "lmk_bary_coords", {count, 3},
                [&](std::size_t i) { return landmarks->barycentric(Eigen::Index(i / 3), Eigen::Index(i % 3)); });
    if (landmarks && landmarks->contour_faces.size() > 0) {
      const RowMatrixXi& contour = landmarks->contour_faces;
      std::vector<std::int64_t> contour_faces(contour.data(), contour.data() + contour.size());
      const std::size_t bins = FaceLandmarks::kYawBins, points = FaceLandmarks::kContourCount;
      npz.add("dynamic_lmk_faces_idx", NpyArray::from_int64(contour_faces, {bins, points}));
      add_float32(npz, "dynamic_lmk_bary_coords", {bins, points, 3}, [&](std::size_t i) {
        return landmarks->contour_barycentric(Eigen::Index(i / 3), Eigen::Index(i % 3));
      });
    }
  }
  npz.close();
}

void write_body_model(const std::string& path, const SyntheticBody& body) {
  write_body_model(path, body.model, &body.landmarks);
}

}  // namespace odyssey::io
