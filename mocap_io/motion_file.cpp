#include "mocap_io/motion_file.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>

#include "mocap_io/bvh.h"
#include "mocap_io/input_error.h"
#include "mocap_io/input_file.h"
#include "mocap_io/npy.h"

namespace odyssey::io {

MotionFileKind detect_motion_file(const std::string& path) {
  require_input_file(path);
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if (extension == ".bvh") return MotionFileKind::Bvh;
  if (extension == ".npy") return MotionFileKind::Npy;
  if (extension != ".npz") throw InputError(path, "unsupported file type '" + extension + "' (expected .bvh, .npz or .npy)");
  const NpzReader archive(path);
  if (archive.contains("v_template")) return MotionFileKind::BodyModel;
  if (archive.contains("poses") || archive.contains("root_orient")) return MotionFileKind::Amass;
  return MotionFileKind::Npz;
}

std::optional<double> parse_bvh_units(std::string_view units) {
  for (const BvhUnit& unit : kBvhUnits) {
    if (units == unit.name) return unit.metres;
  }
  double value = 0;
  const auto [end, error] = std::from_chars(units.data(), units.data() + units.size(), value);
  if (error != std::errc() || end != units.data() + units.size() || !(value > 0) || !std::isfinite(value)) return std::nullopt;
  return value;
}

}  // namespace odyssey::io
