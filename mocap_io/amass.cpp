#include "mocap_io/amass.h"

#include <algorithm>
#include <cmath>
#include <span>
#include <string_view>
#include <vector>

#include "mocap_io/input_error.h"
#include "mocap_io/npy.h"

namespace odyssey::io {
namespace {

// numpy's way of printing a shape, without the spaces: (12,165), (10,), ().
std::string shape_text(const std::vector<std::size_t>& shape) {
  std::string text = "(";
  for (std::size_t i = 0; i < shape.size(); ++i) {
    if (i > 0) text += ',';
    text += std::to_string(shape[i]);
  }
  return text + (shape.size() == 1 ? ",)" : ")");
}

std::string quoted(const std::string& key) { return "'" + key + "'"; }

// What the split keys of a pose are: name and width, in the order they sit in the full pose.
struct PosePart {
  const char* key;
  int width;
};
// SMPL-X: root, body, jaw, eyes, left hand, right hand (pose_hand holds both hands).
constexpr PosePart kSmplxParts[] = {
    {"root_orient", 3}, {"pose_body", 63}, {"pose_jaw", 3}, {"pose_eye", 6}, {"pose_hand", 90}};
constexpr PosePart kSmplhParts[] = {{"root_orient", 3}, {"pose_body", 63}, {"pose_hand", 90}};

class AmassReader {
 public:
  explicit AmassReader(const std::string& path) : npz_(path) {}

  AmassFile read() {
    AmassFile file;
    BodySequence& sequence = file.sequence;
    read_poses(sequence, file);
    const auto frames = static_cast<std::size_t>(sequence.poses.rows());
    if (!npz_.contains("trans")) fail("missing key 'trans' (root translation, (T,3))");
    sequence.translations = matrix("trans", 3, frames, frames_source_);
    if (npz_.contains("betas")) read_betas(sequence);
    if (npz_.contains("gender")) read_gender(sequence);
    read_frame_rate(sequence, file);
    for (const std::string& key : npz_.keys()) {
      if (std::find(used_.begin(), used_.end(), key) == used_.end()) file.skipped_keys.push_back(key);
    }
    return file;
  }

 private:
  [[noreturn]] void fail(const std::string& problem) const { throw InputError(npz_.path(), problem); }

  NpyHeader numeric_header(const std::string& key) {
    used_.push_back(key);
    const NpyHeader header = npz_.header(key);
    switch (header.dtype) {
      case DType::Object: fail(quoted(key) + " is a pickled object array, expected numbers");
      case DType::Unicode:
      case DType::Bytes: fail(quoted(key) + " holds text, expected numbers");
      case DType::Bool: fail(quoted(key) + " holds booleans, expected numbers");
      default: return header;
    }
  }

  // A (frames, width) array as doubles, every value finite. `frames_source` names the key that
  // fixed the frame count, for the message when this one disagrees.
  RowMatrixXd matrix(const std::string& key, int width, std::size_t frames, const std::string& frames_source) {
    const NpyHeader header = numeric_header(key);
    if (header.shape.size() != 2 || header.shape[0] != frames || header.shape[1] != std::size_t(width)) {
      fail(quoted(key) + " has shape " + shape_text(header.shape) + ", expected (T," + std::to_string(width) +
           ") with T=" + std::to_string(frames) + " (from " + quoted(frames_source) + ")");
    }
    return load_rows(key, width);
  }

  RowMatrixXd load_rows(const std::string& key, int width) {
    const std::vector<double> values = npz_.load(key).to_double();
    const auto frames = static_cast<Eigen::Index>(values.size() / width);
    RowMatrixXd out = Eigen::Map<const RowMatrixXd>(values.data(), frames, width);
    for (Eigen::Index f = 0; f < frames; ++f) {
      for (Eigen::Index c = 0; c < width; ++c) {
        if (!std::isfinite(out(f, c))) {
          fail(quoted(key) + " frame " + std::to_string(f) + " holds a non-finite value (column " + std::to_string(c) +
               ")");
        }
      }
    }
    return out;
  }

  void read_poses(BodySequence& sequence, AmassFile& file) {
    if (npz_.contains("poses")) {
      const NpyHeader header = numeric_header("poses");
      const std::size_t width = header.shape.size() == 2 ? header.shape[1] : 0;
      if (width == 165) {
        sequence.kind = BodyModelKind::SMPLX;
      } else if (width == 156) {
        sequence.kind = BodyModelKind::SMPLH;
      } else if (width == 72) {
        sequence.kind = BodyModelKind::SMPL;
      } else {
        fail("'poses' has shape " + shape_text(header.shape) +
             ", expected (T,165) SMPL-X, (T,156) SMPL-H or (T,72) SMPL");
      }
      if (header.shape[0] == 0) fail("'poses' has shape " + shape_text(header.shape) + ": no frames");
      sequence.poses = load_rows("poses", static_cast<int>(width));
      frames_source_ = "poses";
      file.pose_keys = "poses";
      check_split_keys_agree(sequence);
      return;
    }
    if (!npz_.contains("root_orient")) {
      fail(
          "no pose: neither 'poses' nor the split keys 'root_orient', 'pose_body', 'pose_hand', 'pose_jaw', "
          "'pose_eye'");
    }
    const bool face = npz_.contains("pose_jaw") || npz_.contains("pose_eye");
    const std::span<const PosePart> parts =
        face ? std::span<const PosePart>(kSmplxParts) : std::span<const PosePart>(kSmplhParts);
    for (const PosePart& part : parts) {
      if (!npz_.contains(part.key)) {
        fail(std::string("missing key ") + quoted(part.key) +
             (face ? " (SMPL-X split pose: root_orient, pose_body, pose_jaw, pose_eye, pose_hand)"
                   : " (split pose without jaw and eyes: root_orient, pose_body, pose_hand)"));
      }
    }
    sequence.kind = face ? BodyModelKind::SMPLX : BodyModelKind::SMPLH;
    const NpyHeader root = numeric_header("root_orient");
    if (root.shape.size() != 2 || root.shape[1] != 3 || root.shape[0] == 0) {
      fail("'root_orient' has shape " + shape_text(root.shape) + ", expected (T,3) with T >= 1");
    }
    frames_source_ = "root_orient";
    const std::size_t frames = root.shape[0];
    // The frame count is only a header's word: every part is loaded (which checks its data against
    // its shape) before the pose is allocated from it.
    std::vector<RowMatrixXd> columns;
    for (const PosePart& part : parts) columns.push_back(matrix(part.key, part.width, frames, frames_source_));
    sequence.poses.resize(static_cast<Eigen::Index>(frames), 3 * body_model_joint_count(sequence.kind));
    Eigen::Index column = 0;
    for (const RowMatrixXd& part : columns) {
      sequence.poses.middleCols(column, part.cols()) = part;
      column += part.cols();
    }
    file.pose_keys = "split keys";
  }

  // AMASS SMPL-X files carry the split keys beside `poses`; they must hold the same numbers (to
  // float32 rounding, 1e-6 rad), or the file contradicts itself. For SMPL only root_orient and
  // pose_body have a place in the pose.
  void check_split_keys_agree(const BodySequence& sequence) {
    std::span<const PosePart> parts = kSmplhParts;
    if (sequence.kind == BodyModelKind::SMPLX) parts = kSmplxParts;
    if (sequence.kind == BodyModelKind::SMPL) parts = parts.first(2);
    const auto frames = static_cast<std::size_t>(sequence.poses.rows());
    int column = 0;
    for (const PosePart& part : parts) {
      if (npz_.contains(part.key)) {
        const RowMatrixXd split = matrix(part.key, part.width, frames, "poses");
        for (Eigen::Index f = 0; f < split.rows(); ++f) {
          for (int c = 0; c < part.width; ++c) {
            if (std::abs(split(f, c) - sequence.poses(f, column + c)) > 1e-6) {
              fail(quoted(part.key) + " disagrees with columns " + std::to_string(column) + ".." +
                   std::to_string(column + part.width - 1) + " of 'poses' at frame " + std::to_string(f));
            }
          }
        }
      }
      column += part.width;
    }
  }

  void read_betas(BodySequence& sequence) {
    const NpyHeader header = numeric_header("betas");
    const bool flat = header.shape.size() == 1;
    const bool one_row = header.shape.size() == 2 && header.shape[0] == 1;
    if (!flat && !one_row) fail("'betas' has shape " + shape_text(header.shape) + ", expected (N,) or (1,N)");
    const std::vector<double> betas = npz_.load("betas").to_double();
    for (std::size_t k = 0; k < betas.size(); ++k) {
      if (!std::isfinite(betas[k])) fail("'betas' value " + std::to_string(k) + " is not finite");
    }
    sequence.betas = betas;
  }

  void read_gender(BodySequence& sequence) {
    used_.push_back("gender");
    const NpyHeader header = npz_.header("gender");
    if (header.dtype != DType::Unicode && header.dtype != DType::Bytes) {
      fail(std::string("'gender' has dtype ") + dtype_name(header.dtype) + ", expected text (numpy U or S)");
    }
    if (header.element_count() != 1) fail("'gender' has shape " + shape_text(header.shape) + ", expected one string");
    std::string gender = npz_.load("gender").to_strings().at(0);
    const auto not_space = [](unsigned char c) { return c > ' '; };
    gender.erase(gender.begin(), std::find_if(gender.begin(), gender.end(), not_space));
    gender.erase(std::find_if(gender.rbegin(), gender.rend(), not_space).base(), gender.end());
    if (gender.empty()) fail("'gender' is empty");
    sequence.gender = gender;
  }

  double frame_rate(const std::string& key) {
    const NpyHeader header = numeric_header(key);
    if (header.element_count() != 1 || header.shape.size() > 1) {
      fail(quoted(key) + " has shape " + shape_text(header.shape) + ", expected one number");
    }
    const double fps = npz_.load(key).to_double().at(0);
    if (!(fps > 0) || !std::isfinite(fps))
      fail(quoted(key) + " is " + std::to_string(fps) + ", expected a positive frame rate");
    return fps;
  }

  void read_frame_rate(BodySequence& sequence, AmassFile& file) {
    const bool underscored = npz_.contains("mocap_frame_rate");
    const bool joined = npz_.contains("mocap_framerate");
    if (!underscored && !joined) fail("missing frame rate: neither 'mocap_frame_rate' nor 'mocap_framerate'");
    if (underscored && joined) {
      const double a = frame_rate("mocap_frame_rate"), b = frame_rate("mocap_framerate");
      if (a != b)
        fail("'mocap_frame_rate' (" + std::to_string(a) + ") and 'mocap_framerate' (" + std::to_string(b) +
             ") disagree");
    }
    file.frame_rate_key = underscored ? "mocap_frame_rate" : "mocap_framerate";
    sequence.fps = frame_rate(file.frame_rate_key);
  }

  NpzReader npz_;
  std::vector<std::string> used_;
  std::string frames_source_;
};

void add_matrix(NpzWriter& writer, const std::string& key, const RowMatrixXd& matrix) {
  writer.add(key, NpyArray::from_float64(std::span<const double>(matrix.data(), std::size_t(matrix.size())),
                                         {std::size_t(matrix.rows()), std::size_t(matrix.cols())}));
}

}  // namespace

AmassFile load_amass_file(const std::string& path) {
  return naming_out_of_memory(path, [&] { return AmassReader(path).read(); });
}

BodySequence load_amass(const std::string& path) { return load_amass_file(path).sequence; }

void write_amass(const std::string& path, const BodySequence& sequence) {
  sequence.validate();
  NpzWriter writer(path, /*compress=*/true);
  add_matrix(writer, "poses", sequence.poses);
  add_matrix(writer, "trans", sequence.translations);
  writer.add("betas", NpyArray::from_float64(sequence.betas, {sequence.betas.size()}));
  writer.add("gender", NpyArray::scalar_string(sequence.gender));
  writer.add("mocap_frame_rate", NpyArray::scalar_float64(sequence.fps));
  if (sequence.kind == BodyModelKind::SMPLX) {
    int column = 0;
    for (const PosePart& part : kSmplxParts) {
      add_matrix(writer, part.key, sequence.poses.middleCols(column, part.width));
      column += part.width;
    }
  }
  writer.close();
}

}  // namespace odyssey::io
