#include "mocap_io/camera_import.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <stdexcept>
#include <string_view>

#include "mocap_io/input_error.h"
#include "mocap_io/input_file.h"

namespace odyssey::io {
namespace {

namespace fs = std::filesystem;

// Whitespace-separated fields of a line.
std::vector<std::string_view> fields_of(std::string_view line) {
  std::vector<std::string_view> fields;
  std::size_t at = 0;
  while (true) {
    const std::size_t begin = line.find_first_not_of(" \t\r", at);
    if (begin == std::string_view::npos) break;
    const std::size_t end = line.find_first_of(" \t\r", begin);
    fields.push_back(line.substr(begin, end == std::string_view::npos ? std::string_view::npos : end - begin));
    if (end == std::string_view::npos) break;
    at = end;
  }
  return fields;
}

bool is_comment(std::string_view line) {
  const std::size_t first = line.find_first_not_of(" \t\r");
  return first != std::string_view::npos && line[first] == '#';
}

bool is_blank(std::string_view line) { return line.find_first_not_of(" \t\r") == std::string_view::npos; }

// Reads a file's lines; each reader reports problems as "FILE: line N: PROBLEM".
class LineReader {
 public:
  explicit LineReader(std::string path) : path_(std::move(path)), whole_(read_input_file(path_, kMaxTextInputBytes)), rest_(whole_) {}
  bool next() {
    if (rest_.empty()) return false;
    const std::size_t end = rest_.find('\n');
    text_ = rest_.substr(0, end);
    rest_ = end == std::string_view::npos ? std::string_view{} : rest_.substr(end + 1);
    ++number_;
    return true;
  }
  std::string_view text() const { return text_; }
  long number() const { return number_; }
  [[noreturn]] void fail(const std::string& problem) const {
    throw InputError(path_, "line " + std::to_string(number_) + ": " + problem);
  }
  double number_at(std::string_view field, const char* what) const {
    double value = 0;
    const auto [end, error] = std::from_chars(field.data(), field.data() + field.size(), value);
    if (error != std::errc() || end != field.data() + field.size() || !std::isfinite(value)) {
      fail(std::string(what) + " '" + std::string(field) + "' is not a finite number");
    }
    return value;
  }
  long long integer_at(std::string_view field, const char* what) const {
    long long value = 0;
    const auto [end, error] = std::from_chars(field.data(), field.data() + field.size(), value);
    if (error != std::errc() || end != field.data() + field.size()) {
      fail(std::string(what) + " '" + std::string(field) + "' is not an integer");
    }
    return value;
  }

 private:
  std::string path_;
  std::string whole_;
  std::string_view rest_, text_;
  long number_ = 0;
};

// A 3x3 that is a rotation within 1e-4 (|R^T R - I| largest entry, det > 0), snapped to the
// nearest rotation through its normalised quaternion.
Eigen::Matrix3d checked_rotation(const Eigen::Matrix3d& r, const LineReader& line) {
  const double off = (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (off > 1e-4 || r.determinant() < 0) {
    line.fail("the 3x3 part of the world-to-camera matrix is not a rotation (largest entry of |R^T R - I| " +
              std::to_string(off) + ", det " + std::to_string(r.determinant()) + ")");
  }
  return Eigen::Quaterniond(r).normalized().toRotationMatrix();
}

// Names compared with runs of digits as numbers ("frame9" < "frame10"); equal numbers with more
// leading zeros, then plain byte order, break ties so the order is total.
bool natural_less(const std::string& a, const std::string& b) {
  std::size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    const bool da = std::isdigit(static_cast<unsigned char>(a[i])), db = std::isdigit(static_cast<unsigned char>(b[j]));
    if (da && db) {
      std::size_t ei = i, ej = j;
      while (ei < a.size() && std::isdigit(static_cast<unsigned char>(a[ei]))) ++ei;
      while (ej < b.size() && std::isdigit(static_cast<unsigned char>(b[ej]))) ++ej;
      std::size_t zi = i, zj = j;  // skip leading zeros, then the longer run is the larger number
      while (zi + 1 < ei && a[zi] == '0') ++zi;
      while (zj + 1 < ej && b[zj] == '0') ++zj;
      if (ei - zi != ej - zj) return ei - zi < ej - zj;
      const int order = a.compare(zi, ei - zi, b, zj, ej - zj);
      if (order != 0) return order < 0;
      i = ei;
      j = ej;
    } else {
      if (a[i] != b[j]) return static_cast<unsigned char>(a[i]) < static_cast<unsigned char>(b[j]);
      ++i;
      ++j;
    }
  }
  if (a.size() - i != b.size() - j) return a.size() - i < b.size() - j;
  return a < b;
}

struct ColmapCamera {
  double fx = 0, fy = 0, cx = 0, cy = 0;  // normalised by the image size
  bool distorted = false;
};

std::map<long long, ColmapCamera> read_colmap_cameras(const std::string& path) {
  // Parameters per model: focal lengths, principal point, then distortion.
  struct Model {
    int params;
    bool one_focal;
  };
  static const std::map<std::string, Model, std::less<>> kModels = {
      {"SIMPLE_PINHOLE", {3, true}}, {"PINHOLE", {4, false}}, {"SIMPLE_RADIAL", {4, true}}, {"OPENCV", {8, false}}};
  LineReader line(path);
  std::map<long long, ColmapCamera> cameras;
  while (line.next()) {
    if (is_comment(line.text()) || is_blank(line.text())) continue;
    const std::vector<std::string_view> f = fields_of(line.text());
    if (f.size() < 2) line.fail("a camera line needs CAMERA_ID MODEL WIDTH HEIGHT PARAMS...");
    const auto model = kModels.find(f[1]);
    if (model == kModels.end()) {
      line.fail("unknown camera model '" + std::string(f[1]) + "' (this reader takes SIMPLE_PINHOLE, PINHOLE, "
                "SIMPLE_RADIAL and OPENCV)");
    }
    const std::size_t expected = 4 + model->second.params;
    if (f.size() != expected) {
      line.fail("a " + std::string(f[1]) + " camera line has " + std::to_string(expected) + " fields (CAMERA_ID MODEL WIDTH HEIGHT and " +
                std::to_string(model->second.params) + " parameters), got " + std::to_string(f.size()));
    }
    const long long id = line.integer_at(f[0], "camera id");
    const long long width = line.integer_at(f[2], "width"), height = line.integer_at(f[3], "height");
    if (width < 1 || height < 1) line.fail("the image size " + std::to_string(width) + "x" + std::to_string(height) + " is not positive");
    std::vector<double> p;
    for (std::size_t k = 4; k < f.size(); ++k) p.push_back(line.number_at(f[k], "camera parameter"));
    ColmapCamera camera;
    const double fx = p[0], fy = model->second.one_focal ? p[0] : p[1];
    const std::size_t principal = model->second.one_focal ? 1 : 2;
    if (!(fx > 0 && fy > 0)) line.fail("focal length " + std::string(f[fx > 0 ? 5 : 4]) + " is not positive");
    if (const std::string problem = intrinsics_problem(fx, fy, p[principal], p[principal + 1], double(width), double(height));
        !problem.empty())
      line.fail("camera " + std::to_string(id) + ": " + problem);
    camera.fx = fx / double(width);
    camera.fy = fy / double(height);
    camera.cx = p[principal] / double(width);
    camera.cy = p[principal + 1] / double(height);
    for (std::size_t k = principal + 2; k < p.size(); ++k) camera.distorted |= p[k] != 0;
    if (!cameras.emplace(id, camera).second) line.fail("camera id " + std::to_string(id) + " appears twice");
  }
  if (cameras.empty()) throw InputError(path, "no cameras");
  return cameras;
}

}  // namespace

CameraTrack read_realestate10k(const std::string& path) {
  constexpr std::size_t kFields = 19;
  LineReader line(path);
  CameraTrack track;
  track.path = path;
  track.format = "realestate10k";
  if (!line.next()) throw InputError(path, "empty file: expected the video's URL on line 1, then one line per frame");
  if (fields_of(line.text()).size() == kFields) line.fail("expected the video's URL, found a frame line (19 fields)");
  double previous_time = 0;
  long previous_line = 0;
  while (line.next()) {
    if (is_blank(line.text())) continue;
    const std::vector<std::string_view> f = fields_of(line.text());
    if (f.size() != kFields) {
      line.fail("a frame line has 19 numbers (timestamp, fx fy cx cy, two unused, a 3x4 world-to-camera matrix), got " +
                std::to_string(f.size()));
    }
    double v[kFields];
    for (std::size_t k = 0; k < kFields; ++k) v[k] = line.number_at(f[k], "value");
    CameraTrackFrame frame;
    frame.time_s = v[0] * 1e-6;
    if (previous_line > 0 && !(v[0] > previous_time)) {
      line.fail("timestamp " + std::string(f[0]) + (v[0] == previous_time ? " repeats" : " comes before") + " line " +
                std::to_string(previous_line) + "'s (timestamps must strictly increase)");
    }
    previous_time = v[0];
    previous_line = line.number();
    frame.fx = v[1];
    frame.fy = v[2];
    frame.cx = v[3];
    frame.cy = v[4];
    if (!(frame.fx > 0 && frame.fy > 0)) {
      line.fail("focal length " + std::string(f[frame.fx > 0 ? 2 : 1]) + " is not positive");
    }
    // RealEstate10K's intrinsics are normalised by the image size.
    if (const std::string problem = intrinsics_problem(frame.fx, frame.fy, frame.cx, frame.cy, 1, 1); !problem.empty()) {
      line.fail("normalised intrinsics: " + problem);
    }
    Eigen::Matrix3d r;
    for (int row = 0; row < 3; ++row) {
      for (int col = 0; col < 3; ++col) r(row, col) = v[7 + 4 * row + col];
      frame.pose.translation[row] = v[7 + 4 * row + 3];
    }
    frame.pose.rotation = checked_rotation(r, line);
    track.frames.push_back(frame);
  }
  if (track.frames.empty()) throw InputError(path, "no frames after the URL line");
  return track;
}

CameraTrack read_colmap_text(const std::string& path, double fps) {
  if (!(fps > 0 && std::isfinite(fps))) throw std::invalid_argument("COLMAP import: fps must be positive, got " + std::to_string(fps));
  const fs::path folder = fs::is_directory(path) ? fs::path(path) : fs::path(path).parent_path();
  const std::string cameras_path = (folder / "cameras.txt").string();
  const std::string images_path = (folder / "images.txt").string();
  const std::map<long long, ColmapCamera> cameras = read_colmap_cameras(cameras_path);

  struct Image {
    std::string name;
    CameraTrackFrame frame;
    long long camera;
  };
  std::vector<Image> images;
  std::set<long long> image_ids;
  std::map<std::string, long> line_of_name;
  LineReader line(images_path);
  bool points_line_next = false;  // every image line is followed by its 2D points line
  while (line.next()) {
    if (is_comment(line.text())) continue;
    if (points_line_next) {
      points_line_next = false;
      continue;
    }
    if (is_blank(line.text())) continue;
    const std::vector<std::string_view> f = fields_of(line.text());
    if (f.size() != 10) {
      line.fail("an image line has 10 fields (IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME), got " + std::to_string(f.size()));
    }
    const long long id = line.integer_at(f[0], "image id");
    if (!image_ids.insert(id).second) line.fail("image id " + std::to_string(id) + " appears twice");
    double v[7];
    for (int k = 0; k < 7; ++k) v[k] = line.number_at(f[1 + k], "value");
    const Eigen::Quaterniond q(v[0], v[1], v[2], v[3]);  // Hamilton, w first
    if (std::abs(q.norm() - 1) > 1e-3) {
      line.fail("the quaternion QW QX QY QZ has norm " + std::to_string(q.norm()) + ", not 1: not a rotation");
    }
    Image image;
    image.frame.pose.rotation = q.normalized().toRotationMatrix();
    image.frame.pose.translation = Eigen::Vector3d(v[4], v[5], v[6]);
    image.camera = line.integer_at(f[8], "camera id");
    const auto camera = cameras.find(image.camera);
    if (camera == cameras.end()) line.fail("camera id " + std::to_string(image.camera) + " is not in cameras.txt");
    image.frame.fx = camera->second.fx;
    image.frame.fy = camera->second.fy;
    image.frame.cx = camera->second.cx;
    image.frame.cy = camera->second.cy;
    image.name = std::string(f[9]);
    if (const auto [at, fresh] = line_of_name.emplace(image.name, line.number()); !fresh) {
      line.fail("image name '" + image.name + "' is also on line " + std::to_string(at->second) + " (names order the frames)");
    }
    images.push_back(std::move(image));
    points_line_next = true;
  }
  if (images.empty()) throw InputError(images_path, "no images");

  std::stable_sort(images.begin(), images.end(), [](const Image& a, const Image& b) { return natural_less(a.name, b.name); });
  CameraTrack track;
  track.path = folder.string();
  track.format = "colmap";
  std::set<long long> distorted;
  for (std::size_t k = 0; k < images.size(); ++k) {
    images[k].frame.time_s = static_cast<double>(k) / fps;
    track.frames.push_back(images[k].frame);
    if (cameras.at(images[k].camera).distorted) distorted.insert(images[k].camera);
  }
  if (!distorted.empty()) {
    std::string ids;
    for (const long long id : distorted) ids += (ids.empty() ? "" : ", ") + std::to_string(id);
    track.notes.push_back(cameras_path + ": lens distortion of camera(s) " + ids + " not applied (pinhole part only)");
  }
  return track;
}

}  // namespace odyssey::io
