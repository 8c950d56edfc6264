#include "mocap_io/camera_path_file.h"

#include <cerrno>
#include <climits>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <span>
#include <stdexcept>

#include "mocap_io/input_error.h"
#include "mocap_io/input_file.h"
#include "mocap_io/json_reader.h"
#include "mocap_io/output_file.h"

namespace odyssey::io {
namespace {

// Read into nlohmann::json, whose objects are std::maps: ordered_json inserts each key by a linear
// scan, quadratic in an object's size. Written from ordered_json, so keys appear as written.
using Json = nlohmann::json;
using OrderedJson = nlohmann::ordered_json;

constexpr const char* kFormat = "odyssey camera path";
constexpr int kVersion = 1;
constexpr const char* kConventions =
    "world: right-handed, Z up, metres; extrinsics: world -> camera [R t; 0 0 0 1], x_cam = R x_world + t; "
    "camera axes (OpenCV): x right, y down, z forward; intrinsics: K in pixels, (u, v) = (fx x/z + cx, fy y/z + cy), "
    "image [0, width) x [0, height); centre = -R^T t; time = frame / fps seconds";

OrderedJson rows_of(const Eigen::MatrixXd& matrix) {
  OrderedJson rows = OrderedJson::array();
  for (Eigen::Index r = 0; r < matrix.rows(); ++r) {
    OrderedJson row = OrderedJson::array();
    for (Eigen::Index c = 0; c < matrix.cols(); ++c) row.push_back(matrix(r, c));
    rows.push_back(std::move(row));
  }
  return rows;
}

// Reading: every accessor checks presence, type and finiteness and names what it reads, so each
// problem becomes one InputError line "FILE: frame 3: 'extrinsics' row 1 ...".
class CameraPathReader {
 public:
  explicit CameraPathReader(const std::string& path) : path_(path) {}

  CameraPath read(const std::string& text) const {
    Json document;
    // nlohmann rejects NaN and infinity literals (not JSON) and numbers past double's range
    // (out_of_range, not parse_error), so every number read below is finite.
    document = parse_json(text, path_);
    if (!document.is_object()) fail("a camera path file must be a JSON object");
    const Json& format = member(document, "format", "");
    if (!format.is_string() || format.get<std::string>() != kFormat) {
      fail(std::string("'format' must be \"") + kFormat + "\"");
    }
    const Json& version = member(document, "version", "");
    if (!version.is_number_unsigned() || version.get<std::uint64_t>() != kVersion) {
      fail("'version' must be " + std::to_string(kVersion) + ", the only version this reader knows");
    }
    if (!member(document, "conventions", "").is_string()) fail("'conventions' must be a string");

    CameraPath camera;
    const Json& kind = member(document, "kind", "");
    if (!kind.is_string()) fail("'kind' must be a string");
    camera.kind = kind.get<std::string>();
    camera.fps = number(member(document, "fps", ""), "'fps'");
    if (!(camera.fps > 0)) fail("'fps' must be positive");

    const Json& frames = member(document, "frames", "");
    if (!frames.is_array()) fail("'frames' must be an array");
    if (frames.empty()) fail("'frames' is empty: a camera path has at least one frame");
    const Json& frame_count = member(document, "frame_count", "");
    if (!frame_count.is_number_unsigned() || frame_count.get<std::uint64_t>() != frames.size()) {
      fail("'frame_count' must be the number of entries in 'frames', " + std::to_string(frames.size()));
    }
    for (std::size_t f = 0; f < frames.size(); ++f) {
      const std::string where = "frame " + std::to_string(f) + ": ";
      const Json& frame = frames[f];
      if (!frame.is_object()) fail(where + "not a JSON object");
      const Json& index = member(frame, "frame", where);
      if (!index.is_number_unsigned() || index.get<std::uint64_t>() != f) {
        fail(where + "'frame' must be its position in 'frames', " + std::to_string(f));
      }
      camera.intrinsics.push_back(intrinsics(frame, where));
      camera.poses.push_back(pose(frame, where));
    }
    // Orthonormality, determinant +1 and positive focal lengths: the same checks a writer makes.
    try {
      camera.validate();
    } catch (const std::invalid_argument& error) {
      fail(error.what());
    }
    return camera;
  }

 private:
  [[noreturn]] void fail(const std::string& problem) const { throw InputError(path_, problem); }

  const Json& member(const Json& object, const char* key, const std::string& where) const {
    const auto it = object.find(key);
    if (it == object.end()) fail(where + "missing key '" + key + "'");
    return *it;
  }

  double number(const Json& value, const std::string& what) const {
    if (!value.is_number()) fail(what + " must be a number");
    return value.get<double>();
  }

  int image_size(const Json& frame, const char* key, const std::string& where) const {
    const Json& value = member(frame, key, where);
    if (!value.is_number_unsigned() || value.get<std::uint64_t>() < 1 || value.get<std::uint64_t>() > INT_MAX) {
      fail(where + "'" + key + "' must be a whole number of pixels, at least 1");
    }
    return static_cast<int>(value.get<std::uint64_t>());
  }

  Eigen::MatrixXd matrix(const Json& frame, const char* key, int rows, int cols, const std::string& where) const {
    const Json& value = member(frame, key, where);
    const std::string shape = std::to_string(rows) + " rows of " + std::to_string(cols) + " numbers";
    if (!value.is_array() || value.size() != std::size_t(rows)) fail(where + "'" + key + "' must be " + shape);
    Eigen::MatrixXd m(rows, cols);
    for (int r = 0; r < rows; ++r) {
      if (!value[r].is_array() || value[r].size() != std::size_t(cols)) fail(where + "'" + key + "' must be " + shape);
      for (int c = 0; c < cols; ++c) {
        m(r, c) = number(value[r][c], where + "'" + key + "' row " + std::to_string(r) + " column " + std::to_string(c));
      }
    }
    return m;
  }

  PinholeIntrinsics intrinsics(const Json& frame, const std::string& where) const {
    PinholeIntrinsics k;
    k.width = image_size(frame, "width", where);
    k.height = image_size(frame, "height", where);
    if (const std::string problem = image_size_problem(k.width, k.height); !problem.empty()) fail(where + problem);
    const Eigen::MatrixXd m = matrix(frame, "intrinsics", 3, 3, where);
    // PinholeIntrinsics has no skew and no projective row: anything but these zeros and the one
    // would be silently dropped, so it is an error.
    if (m(0, 1) != 0 || m(1, 0) != 0 || m(2, 0) != 0 || m(2, 1) != 0 || m(2, 2) != 1) {
      fail(where + "'intrinsics' must be [[fx,0,cx],[0,fy,cy],[0,0,1]]");
    }
    k.fx = m(0, 0);
    k.fy = m(1, 1);
    k.cx = m(0, 2);
    k.cy = m(1, 2);
    return k;
  }

  CameraPose pose(const Json& frame, const std::string& where) const {
    const Eigen::MatrixXd m = matrix(frame, "extrinsics", 4, 4, where);
    if (m(3, 0) != 0 || m(3, 1) != 0 || m(3, 2) != 0 || m(3, 3) != 1) {
      fail(where + "'extrinsics' last row must be [0,0,0,1]");
    }
    CameraPose pose;
    pose.rotation = m.topLeftCorner<3, 3>();
    pose.translation = m.topRightCorner<3, 1>();
    return pose;
  }

  const std::string& path_;
};

}  // namespace

void write_camera_path_json(const std::string& path, const CameraPath& camera) {
  camera.validate();
  // validate() allows an empty path, but the reader rejects one: refuse to write a file that
  // could not be read back.
  if (camera.poses.empty()) throw std::invalid_argument("camera path has no frames");
  // The text is what dump(2) of the whole document gives, written a frame at a time so memory
  // does not grow with the frame count (a 100,000-frame path is about 90 MB of text). The head
  // is the document without "frames", its closing "\n}" replaced by the opening of "frames";
  // each frame is dumped alone and indented by the two levels it sits at (dump(2) of an element
  // at depth d is its own dump(2) with 2d spaces after every newline; a frame holds numbers
  // only, so every newline in it is layout). nlohmann writes doubles with the shortest digits
  // that read back to the same double, so a round trip through the file is exact.
  OrderedJson head;
  head["format"] = kFormat;
  head["version"] = kVersion;
  head["kind"] = camera.kind;
  head["fps"] = camera.fps;
  head["frame_count"] = camera.poses.size();
  head["conventions"] = kConventions;
  std::string text = head.dump(2);  // throws before any file exists when kind is not UTF-8
  text.resize(text.size() - 2);     // "\n}"
  text += ",\n  \"frames\": [\n";

  TempFile file(path);
  const auto write = [&file](const std::string& bytes) { file.write(std::as_bytes(std::span(bytes.data(), bytes.size()))); };
  for (std::size_t f = 0; f < camera.poses.size(); ++f) {
    const PinholeIntrinsics& k = camera.intrinsics[f];
    const CameraPose& pose = camera.poses[f];
    OrderedJson frame;
    frame["frame"] = f;
    frame["time"] = double(f) / camera.fps;
    frame["width"] = k.width;
    frame["height"] = k.height;
    frame["intrinsics"] = rows_of(k.matrix());
    frame["extrinsics"] = rows_of(pose.extrinsics());
    const Eigen::Vector3d centre = pose.centre();
    frame["centre"] = OrderedJson::array({centre.x(), centre.y(), centre.z()});
    text += "    ";
    for (const char c : frame.dump(2)) {
      text += c;
      if (c == '\n') text += "    ";
    }
    text += f + 1 < camera.poses.size() ? ",\n" : "\n  ]\n}\n";
    write(text);
    text.clear();
  }
  file.commit();
}

CameraPath read_camera_path_json(const std::string& path) {
  return naming_out_of_memory(path, [&] {
    return CameraPathReader(path).read(read_input_file(path, kMaxJsonInputBytes));
  });
}

}  // namespace odyssey::io
