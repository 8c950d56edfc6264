#include "cli/motion_file.h"

#include <algorithm>
#include <charconv>
#include <filesystem>

#include "mocap_io/bvh.h"
#include "mocap_io/input_error.h"
#include "mocap_io/npy.h"

namespace odyssey::cli {

MotionFileKind detect_motion_file(const std::string& path) {
  if (!std::filesystem::is_regular_file(path)) throw io::InputError(path, "no such file");
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if (extension == ".bvh") return MotionFileKind::Bvh;
  if (extension == ".npy") return MotionFileKind::Npy;
  if (extension != ".npz") throw io::InputError(path, "unsupported file type '" + extension + "' (expected .bvh, .npz or .npy)");
  const io::NpzReader archive(path);
  if (archive.contains("v_template")) return MotionFileKind::BodyModel;
  if (archive.contains("poses") || archive.contains("root_orient")) return MotionFileKind::Amass;
  return MotionFileKind::Npz;
}

void add_bvh_units_option(Args& args) {
  args.option("bvh-units", "UNITS",
              "BVH length unit: cmu (0.056444 m, the CMU conversions), cm, mm, m, in, or metres per unit", "cm");
}

double bvh_metres_per_unit(const Args& args) {
  const std::string units = args.get("bvh-units");
  if (units == "cmu") return io::kCmuMetresPerUnit;
  if (units == "cm") return 0.01;
  if (units == "mm") return 0.001;
  if (units == "m") return 1.0;
  if (units == "in") return 0.0254;
  double value = 0;
  const auto [end, error] = std::from_chars(units.data(), units.data() + units.size(), value);
  if (error != std::errc() || end != units.data() + units.size() || !(value > 0)) {
    throw UsageError("--bvh-units expects cmu, cm, mm, m, in or a positive number, got '" + units + "'");
  }
  return value;
}

}  // namespace odyssey::cli
