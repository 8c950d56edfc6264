#include "cli/camera_options.h"

#include <cmath>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>


namespace odyssey::cli {
namespace {

// "x,y,z" as three finite numbers.
Eigen::Vector3d parse_vector3(const Args& args, const std::string& name) {
  const std::string text = args.get(name);
  Eigen::Vector3d value;
  const char* at = text.c_str();
  for (int i = 0; i < 3; ++i) {
    char* end = nullptr;
    value[i] = std::strtod(at, &end);
    const char expected = i < 2 ? ',' : '\0';
    if (end == at || *end != expected || !std::isfinite(value[i])) {
      throw UsageError("--" + name + " expects three numbers X,Y,Z in metres, got '" + text + "'");
    }
    at = end + 1;
  }
  return value;
}

double positive(const Args& args, const std::string& name) {
  const double value = args.get_double(name);
  if (!(value > 0) || !std::isfinite(value)) throw UsageError("--" + name + " must be positive, got " + args.get(name));
  return value;
}

}  // namespace

void add_camera_options(Args& args, const std::string& default_kind) {
  args.option("camera", "RIG",
              std::string(default_kind == "none" ? "none, " : "") +
                  "static (fixed, looking at the target), orbit (circling the target), ego (riding on the "
                  "character's head, looking along its forward axis) or file (--camera-file)",
              default_kind)
      .option("width", "PX", "image width", "960")
      .option("height", "PX", "image height", "540")
      .option("hfov", "DEG", "horizontal field of view, degrees (0 to 180)", "80")
      .option("camera-position", "X,Y,Z",
              "static camera centre, metres (default: 2.5 character heights plus the motion's reach in front of "
              "the character, at 0.9 of its height)")
      .option("camera-target", "X,Y,Z",
              "point the static and orbiting cameras look at (default: the root's mean position over the clip, at "
              "0.55 of the character's height)")
      .option("camera-radius", "M", "orbit radius (default: as the static camera's distance)")
      .option("camera-height", "M", "orbit camera height above z = 0 (default: 0.9 of the character's height)")
      .option("camera-period", "S", "seconds per orbit; negative turns clockwise", "10")
      .option("eye-forward", "M", "ego camera: offset along the head's forward axis (default: 0.06 of the height)")
      .option("eye-up", "M", "ego camera: offset along the head's up axis (default: 0.047 of the height)")
      .option("camera-smooth", "S",
              "ego camera: sigma in seconds of a zero-phase Gaussian filter over the head's motion (0: off)", "0")
      .option("camera-file", "FILE", "a camera path JSON with one frame per output frame (--camera file)");
}

std::optional<scene::SceneCamera> camera_from_options(const Args& args) {
  const std::string kind = args.get("camera");
  if (kind == "none") return std::nullopt;
  scene::SceneCamera camera;
  camera.name = "camera";
  if (kind == "file") {
    if (!args.has("camera-file")) throw UsageError("--camera file needs --camera-file");
    camera.kind = scene::SceneCamera::Kind::file;
    camera.path = args.get("camera-file");
    return camera;
  }
  if (kind != "static" && kind != "orbit" && kind != "ego") {
    throw UsageError("--camera expects none, static, orbit, ego or file, got '" + kind + "'");
  }
  if (args.has("camera-file")) throw UsageError("--camera-file is for --camera file");
  const long long width = args.get_int("width"), height = args.get_int("height");
  if (width < 1 || height < 1 || width > 1 << 16 || height > 1 << 16) {
    throw UsageError("--width and --height expect 1 to 65536 pixels");
  }
  camera.width = static_cast<int>(width);
  camera.height = static_cast<int>(height);
  camera.hfov_deg = args.get_double("hfov");
  if (!(camera.hfov_deg > 0 && camera.hfov_deg < 180)) {
    throw UsageError("--hfov expects degrees between 0 and 180, got " + args.get("hfov"));
  }
  if (args.has("camera-target")) camera.target = parse_vector3(args, "camera-target");
  if (kind == "static") {
    camera.kind = scene::SceneCamera::Kind::fixed;
    if (args.has("camera-position")) camera.position = parse_vector3(args, "camera-position");
  } else if (kind == "orbit") {
    camera.kind = scene::SceneCamera::Kind::orbit;
    if (args.has("camera-radius")) camera.radius = positive(args, "camera-radius");
    if (args.has("camera-height")) camera.height_m = args.get_double("camera-height");
    camera.period_s = args.get_double("camera-period");
    if (camera.period_s == 0 || !std::isfinite(camera.period_s)) throw UsageError("--camera-period must not be 0");
  } else {
    camera.kind = scene::SceneCamera::Kind::ego;
    camera.actor = 0;
    if (args.has("eye-forward")) camera.eye_forward = args.get_double("eye-forward");
    if (args.has("eye-up")) camera.eye_up = args.get_double("eye-up");
    camera.smoothing_s = args.get_double("camera-smooth");
    if (!(camera.smoothing_s >= 0)) throw UsageError("--camera-smooth must be 0 or more seconds");
  }
  return camera;
}

}  // namespace odyssey::cli
