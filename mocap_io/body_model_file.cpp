#include "mocap_io/body_model_file.h"

#include <Eigen/SparseCore>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <future>
#include <stdexcept>
#include <string_view>
#include <type_traits>

#include "mocap_io/input_error.h"
#include "mocap_io/npy.h"

namespace odyssey::io {
namespace {

std::string shape_text(const std::vector<std::size_t>& shape) {
  std::string out = "(";
  for (std::size_t i = 0; i < shape.size(); ++i) out += (i ? ", " : "") + std::to_string(shape[i]);
  return out + (shape.size() == 1 ? ",)" : ")");
}

// Reads the members of one model archive, turning every problem into InputError(path, ...).
class ModelArchive {
 public:
  explicit ModelArchive(const std::string& path) : reader_(path) {}

  const std::string& path() const { return reader_.path(); }
  [[noreturn]] void fail(const std::string& problem) const { throw InputError(path(), problem); }

  // The array under `key`, which must exist, be numeric and have exactly `shape`.
  NpyArray load(const std::string& key, const std::vector<std::size_t>& shape) const {
    NpyArray array = load_any_shape(key);
    if (array.shape() != shape) fail(key + ": shape " + shape_text(array.shape()) + ", expected " + shape_text(shape));
    return array;
  }

  NpyArray load_any_shape(const std::string& key) const {
    if (!reader_.contains(key)) fail("missing key '" + key + "'");
    const NpyHeader header = reader_.header(key);
    switch (header.dtype) {
      case DType::Object:
        fail(key + ": a pickled object array (for example a scipy sparse matrix); save it as a dense numeric array");
      case DType::Unicode:
      case DType::Bytes:
        fail(key + ": text (" + dtype_name(header.dtype) + "), expected numbers");
      default:
        break;
    }
    return reader_.load(key);
  }

  // Values as double, refusing NaN and infinities with the position of the first one.
  std::vector<double> finite_doubles(const std::string& key, const NpyArray& array) const {
    std::vector<double> values = array.to_double();
    for (std::size_t i = 0; i < values.size(); ++i) {
      if (!std::isfinite(values[i])) fail(key + ": " + non_finite_text(values[i]) + " at " + index_text(array, i));
    }
    return values;
  }

  std::vector<float> finite_floats(const std::string& key, const NpyArray& array) const {
    std::vector<float> values = array.to_float();
    for (std::size_t i = 0; i < values.size(); ++i) {
      if (!std::isfinite(values[i])) fail(key + ": " + non_finite_text(values[i]) + " at " + index_text(array, i));
    }
    return values;
  }

  // The values converted into `out` (element_count() of them), refusing NaN and infinities as
  // finite_doubles does, in one pass over the data for float32 and float64 arrays: these hold the
  // large dense arrays (shapedirs, posedirs), which are then never walked again.
  template <class Out>
  void decode_finite(const std::string& key, const NpyArray& array, Out* out) const {
    const std::size_t count = array.element_count();
    bool finite = true;
    if (array.dtype() == DType::Float32) {
      finite = convert_finite(reinterpret_cast<const float*>(array.data.data()), count, out);
    } else if (array.dtype() == DType::Float64) {
      finite = convert_finite(reinterpret_cast<const double*>(array.data.data()), count, out);
    } else {
      const std::vector<double> values = finite_doubles(key, array);
      std::copy(values.begin(), values.end(), out);
    }
    if (!finite) finite_doubles(key, array);  // throws, naming the first bad value's index
  }

  std::vector<std::int64_t> integers(const std::string& key, const NpyArray& array) const {
    if (array.dtype() == DType::Float32 || array.dtype() == DType::Float64 || array.dtype() == DType::Bool) {
      fail(key + ": dtype " + dtype_name(array.dtype()) + ", expected integers");
    }
    return array.to_int64();
  }

 private:
  static std::string non_finite_text(double value) { return std::isnan(value) ? "NaN" : "infinite value"; }

  // Converts and tests the exponent bits (all ones: NaN or infinity) without a branch, so the
  // loop vectorises.
  template <class In, class Out>
  static bool convert_finite(const In* in, std::size_t count, Out* out) {
    using Bits = std::conditional_t<sizeof(In) == 4, std::uint32_t, std::uint64_t>;
    constexpr Bits kExponent = sizeof(In) == 4 ? Bits(0x7f800000u) : Bits(0x7ff0000000000000ull);
    Bits non_finite = 0;
    for (std::size_t i = 0; i < count; ++i) {
      Bits bits;
      std::memcpy(&bits, in + i, sizeof bits);
      non_finite |= Bits((bits & kExponent) == kExponent);
      out[i] = static_cast<Out>(in[i]);
    }
    return non_finite == 0;
  }

  // The C-order multi-index of flat element i, as numpy prints it: [12, 1].
  static std::string index_text(const NpyArray& array, std::size_t flat) {
    const std::vector<std::size_t>& shape = array.shape();
    std::vector<std::size_t> index(shape.size());
    for (std::size_t d = shape.size(); d-- > 0;) {
      index[d] = flat % shape[d];
      flat /= shape[d];
    }
    std::string out = "[";
    for (std::size_t d = 0; d < index.size(); ++d) out += (d ? ", " : "") + std::to_string(index[d]);
    return out + "]";
  }

  NpzReader reader_;
};

// Dense C-order rows x cols values as a sparse row-major matrix; exact zeros are dropped (they
// are most of J_regressor and weights, and the evaluator skips zero influences anyway).
Eigen::SparseMatrix<double, Eigen::RowMajor> sparse_from_dense(std::size_t rows, std::size_t cols,
                                                               const std::vector<double>& values) {
  std::vector<Eigen::Triplet<double>> entries;
  for (std::size_t r = 0; r < rows; ++r) {
    for (std::size_t c = 0; c < cols; ++c) {
      const double value = values[r * cols + c];
      if (value != 0.0) entries.emplace_back(int(r), int(c), value);
    }
  }
  Eigen::SparseMatrix<double, Eigen::RowMajor> matrix{Eigen::Index(rows), Eigen::Index(cols)};
  matrix.setFromTriplets(entries.begin(), entries.end());
  return matrix;
}

// Parents from row 0 of kintree_table. The root's parent is -1, or 4294967295 where the table
// went through uint32 (as in the released files). Every other parent must be an earlier joint,
// which rules out cycles and lets forward kinematics run as one loop. Row 1 holds the joint
// ids 0..J-1 in every released file and, as in the smplx package, is not used.
std::vector<int> parents_from_kintree(const ModelArchive& archive, const std::vector<std::int64_t>& table,
                                      std::size_t joints) {
  constexpr std::int64_t kUint32Root = 4294967295;
  std::vector<int> parents(joints);
  for (std::size_t j = 0; j < joints; ++j) {
    const std::int64_t parent = table[j];
    const bool root_marker = parent == -1 || parent == kUint32Root;
    const std::string joint = "kintree_table: joint " + std::to_string(j);
    if (j == 0) {
      if (!root_marker) {
        archive.fail(joint + " (the root) has parent " + std::to_string(parent) + ", expected -1 or 4294967295");
      }
      parents[j] = -1;
      continue;
    }
    if (root_marker) archive.fail(joint + " has no parent; only joint 0 may be a root");
    if (parent < 0 || parent >= std::int64_t(joints)) {
      archive.fail(joint + " has parent " + std::to_string(parent) + ", not a joint index (0.." +
                   std::to_string(joints - 1) + ")");
    }
    if (parent >= std::int64_t(j)) {
      archive.fail(joint + " has parent " + std::to_string(parent) + ", which does not precede it");
    }
    parents[j] = int(parent);
  }
  return parents;
}

// f (F, 3): vertex indices, each within the template's V vertices.
void read_faces(const ModelArchive& archive, std::size_t vertices, BodyModel& model) {
  const NpyArray faces = archive.load_any_shape("f");
  if (faces.shape().size() != 2 || faces.shape()[1] != 3) {
    archive.fail("f: shape " + shape_text(faces.shape()) + ", expected (F, 3)");
  }
  const std::vector<std::int64_t> face_indices = archive.integers("f", faces);
  model.faces.resize(Eigen::Index(faces.shape()[0]), 3);
  for (std::size_t i = 0; i < face_indices.size(); ++i) {
    if (face_indices[i] < 0 || face_indices[i] >= std::int64_t(vertices)) {
      archive.fail("f: face " + std::to_string(i / 3) + " names vertex " + std::to_string(face_indices[i]) +
                   ", outside 0.." + std::to_string(vertices - 1));
    }
    model.faces.data()[i] = int(face_indices[i]);
  }
}

// How many of shapedirs' directions are shape and how many expression: an SMPL-X file of 400 or
// more carries 300 shape directions then the expressions, a smaller one an even count split in
// halves; SMPL and SMPL-H carry shape only.
void split_shape_directions(const ModelArchive& archive, BodyModel& model) {
  const std::size_t directions = std::size_t(model.shapedirs.cols());
  if (model.kind != BodyModelKind::SMPLX) {
    model.shape_count = int(directions);
    return;
  }
  if (directions >= 400) {
    model.shape_count = 300;
  } else if (directions % 2 == 0) {
    model.shape_count = int(directions / 2);
  } else {
    archive.fail("shapedirs: " + std::to_string(directions) +
                 " directions; an SMPL-X model below 400 needs an even count (shape then expression halves)");
  }
  model.expression_count = int(directions) - model.shape_count;
}

// The hands' pose PCA (SMPL-H and SMPL-X): 45 x 45 components and a 45-vector mean per hand.
void read_hand_pca(const ModelArchive& archive, BodyModel& model) {
  const auto components = [&](const std::string& key) {
    return RowMatrixXd(Eigen::Map<const RowMatrixXd>(archive.finite_doubles(key, archive.load(key, {45, 45})).data(), 45, 45));
  };
  const auto mean = [&](const std::string& key) {
    return Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(archive.finite_doubles(key, archive.load(key, {45})).data(), 45));
  };
  model.hands_components_left = components("hands_componentsl");
  model.hands_components_right = components("hands_componentsr");
  model.hands_mean_left = mean("hands_meanl");
  model.hands_mean_right = mean("hands_meanr");
}

BodyModel read_body_model(const std::string& path) {
  const ModelArchive archive(path);
  BodyModel model;

  // The joint count decides the kind; every other shape follows from it and from v_template.
  const NpyArray kintree = archive.load_any_shape("kintree_table");
  if (kintree.shape().size() != 2 || kintree.shape()[0] != 2) {
    archive.fail("kintree_table: shape " + shape_text(kintree.shape()) + ", expected (2, J)");
  }
  const std::size_t joints = kintree.shape()[1];
  switch (joints) {
    case 24: model.kind = BodyModelKind::SMPL; break;
    case 52: model.kind = BodyModelKind::SMPLH; break;
    case 55: model.kind = BodyModelKind::SMPLX; break;
    default:
      archive.fail("kintree_table: " + std::to_string(joints) +
                   " joints, expected 24 (SMPL), 52 (SMPL-H) or 55 (SMPL-X)");
  }
  model.parents = parents_from_kintree(archive, archive.integers("kintree_table", kintree), joints);
  model.joint_names = body_model_joint_names(model.kind);

  const NpyArray v_template = archive.load_any_shape("v_template");
  if (v_template.shape().size() != 2 || v_template.shape()[1] != 3 || v_template.shape()[0] == 0) {
    archive.fail("v_template: shape " + shape_text(v_template.shape()) + ", expected (V, 3) with V > 0");
  }
  const std::size_t vertices = v_template.shape()[0];
  model.v_template = Eigen::Map<const RowMatrixXd>(archive.finite_doubles("v_template", v_template).data(),
                                                   Eigen::Index(vertices), 3);

  read_faces(archive, vertices, model);

  const NpyArray j_regressor = archive.load("J_regressor", {joints, vertices});
  model.j_regressor = sparse_from_dense(joints, vertices, archive.finite_doubles("J_regressor", j_regressor));
  const NpyArray weights = archive.load("weights", {vertices, joints});
  model.weights = sparse_from_dense(vertices, joints, archive.finite_doubles("weights", weights));

  // shapedirs (V, 3, S) is row-major 3V x S with row 3v+c, the layout BodyModel keeps. It and
  // posedirs are nearly all of the file (the dense SMPL-X: 50 and 61 MB as float32), so
  // shapedirs is read, inflated and decoded on a second thread while this one does the rest.
  std::future<RowMatrixXd> shapedirs_future = std::async(std::launch::async, [&archive, vertices] {
    const NpyArray shapedirs = archive.load_any_shape("shapedirs");
    if (shapedirs.shape().size() != 3 || shapedirs.shape()[0] != vertices || shapedirs.shape()[1] != 3) {
      archive.fail("shapedirs: shape " + shape_text(shapedirs.shape()) + ", expected (" + std::to_string(vertices) +
                   ", 3, S)");
    }
    RowMatrixXd values(Eigen::Index(3 * vertices), Eigen::Index(shapedirs.shape()[2]));
    advise_huge_pages(values.data(), std::size_t(values.size()) * sizeof(double));
    archive.decode_finite("shapedirs", shapedirs, values.data());
    return values;
  });

  // posedirs (V, 3, 9(J-1)) is row-major 3V x 9(J-1), kept in float32 as stored.
  const std::size_t pose_features = 9 * (joints - 1);
  {
    const NpyArray posedirs = archive.load("posedirs", {vertices, 3, pose_features});
    model.posedirs.resize(Eigen::Index(3 * vertices), Eigen::Index(pose_features));
    advise_huge_pages(model.posedirs.data(), std::size_t(model.posedirs.size()) * sizeof(float));
    archive.decode_finite("posedirs", posedirs, model.posedirs.data());
  }

  model.shapedirs = shapedirs_future.get();
  split_shape_directions(archive, model);
  if (model.kind != BodyModelKind::SMPL) read_hand_pca(archive, model);

  // What the file layout cannot show on its own (weights summing to 1, for one). Every value
  // was checked finite as it was decoded, so the dense arrays are not walked again.
  try {
    model.validate_layout();
  } catch (const std::invalid_argument& error) {
    archive.fail(error.what());
  }
  return model;
}

}  // namespace

BodyModel load_body_model(const std::string& path) {
  return naming_out_of_memory(path, [&] { return read_body_model(path); });
}

}  // namespace odyssey::io
