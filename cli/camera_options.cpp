#include "cli/camera_options.h"

#include <cmath>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

#include "mocap_io/input_file.h"

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
                  "character's head, looking along its forward axis), file (--camera-file), swoop (a crane arc "
                  "circling the target while rising or falling), dolly-zoom (moving along its view axis while the "
                  "focal length keeps the target's image size), zoom (fixed, the field of view changing), "
                  "realestate10k or colmap (a track from real video, --camera-file, rescaled about the character)",
              default_kind)
      .option("width", "PX", "image width", "960")
      .option("height", "PX", "image height", "540")
      .option("hfov", "DEG", "horizontal field of view, degrees (0 to 180)", "80")
      .option("camera-position", "X,Y,Z",
              "static, dolly-zoom and zoom camera centre (dolly-zoom: at the first frame), metres (default: 2.5 character heights plus the motion's reach in front of "
              "the character, at 0.9 of its height)")
      .option("camera-target", "X,Y,Z",
              "point the cameras look at; realestate10k and colmap paths are centred on it (default: the root's mean position over the clip, at "
              "0.55 of the character's height)")
      .option("camera-radius", "M", "orbit radius (default: as the static camera's distance)")
      .option("camera-height", "M", "orbit camera height above z = 0, swoop height at the first frame, realestate10k and colmap mean height (default: 0.9 of the character's height)")
      .option("camera-period", "S", "seconds per orbit; negative turns clockwise", "10")
      .option("eye-forward", "M", "ego camera: offset along the head's forward axis (default: 0.06 of the height)")
      .option("eye-up", "M", "ego camera: offset along the head's up axis (default: 0.047 of the height)")
      .option("camera-smooth", "S",
              "ego camera: sigma in seconds of a zero-phase Gaussian filter over the head's motion (0: off)", "0")
      .option("camera-file", "FILE",
              "a camera path JSON with one frame per output frame (--camera file), a RealEstate10K camera file "
              "(--camera realestate10k) or a COLMAP text model's folder (--camera colmap)")
      .option("camera-height-end", "M", "swoop: camera height at the last frame (default: 2.5 character heights)")
      .option("camera-sweep", "DEG", "swoop: degrees turned about the target over the shot; negative: clockwise", "90")
      .option("camera-end-distance", "M", "dolly-zoom: distance from the target at the last frame (default: half the first's)")
      .option("hfov-end", "DEG", "zoom: horizontal field of view at the last frame (default: half of --hfov)")
      .option("camera-extent", "M", "realestate10k, colmap: the path is rescaled to fit a circle this wide about the character",
              "8")
      .option("camera-anchor", "WHICH",
              "realestate10k, colmap: the point of the path put on the character: centroid (the cameras' mean, for "
              "walk-throughs) or focus (the point the cameras look at, for captures circling a subject)",
              "centroid")
      .option("camera-speed", "X", "realestate10k, colmap: track seconds per output second", "1")
      .option("camera-fps", "FPS", "colmap: the rate the images were taken at (they are ordered by name)", "30")
      .option("camera-aim", "S",
              "realestate10k, colmap: re-aim every frame at the character, smoothed by a Gaussian of this sigma in "
              "seconds (default: the recorded orientation)")
      .option("handheld", "M", "seeded handheld shake on any camera: bound on the centre's offsets along the camera axes")
      .option("handheld-rotation", "DEG", "handheld shake: bound on the turns about the camera axes", "0.5")
      .option("handheld-band", "LO,HI", "handheld shake: its frequency band in Hz", "0.5,3");
}

namespace {

// --handheld, --handheld-rotation and --handheld-band, when --handheld is given.
std::optional<scene::HandheldOptions> handheld_from_options(const Args& args) {
  if (!args.has("handheld")) return std::nullopt;
  scene::HandheldOptions handheld;
  handheld.amplitude_m = args.get_double("handheld");
  if (!(handheld.amplitude_m >= 0) || !std::isfinite(handheld.amplitude_m)) throw UsageError("--handheld must be 0 or more metres");
  handheld.rotation_deg = args.get_double("handheld-rotation");
  if (!(handheld.rotation_deg >= 0 && handheld.rotation_deg <= 45)) throw UsageError("--handheld-rotation expects 0 to 45 degrees");
  const std::string band = args.get("handheld-band");
  char* end = nullptr;
  handheld.low_hz = std::strtod(band.c_str(), &end);
  const bool comma = *end == ',';
  if (comma) handheld.high_hz = std::strtod(end + 1, &end);
  if (!comma || *end != '\0' || !(handheld.low_hz > 0) || !(handheld.high_hz >= handheld.low_hz) || !std::isfinite(handheld.high_hz)) {
    throw UsageError("--handheld-band expects LO,HI in Hz with 0 < LO <= HI, got '" + band + "'");
  }
  return handheld;
}

}  // namespace

std::optional<scene::SceneCamera> camera_from_options(const Args& args) {
  const std::string kind = args.get("camera");
  if (kind == "none") return std::nullopt;
  scene::SceneCamera camera;
  camera.name = "camera";
  camera.handheld = handheld_from_options(args);
  if (kind == "file") {
    if (!args.has("camera-file")) throw UsageError("--camera file needs --camera-file");
    camera.rig = scene::FileRig{args.get("camera-file")};
    return camera;
  }
  const bool imported = kind == "realestate10k" || kind == "colmap";
  if (kind != "static" && kind != "orbit" && kind != "ego" && kind != "swoop" && kind != "dolly-zoom" && kind != "zoom" &&
      !imported) {
    throw UsageError("--camera expects none, static, orbit, ego, file, swoop, dolly-zoom, zoom, realestate10k or colmap, got '" +
                     kind + "'");
  }
  if (imported != args.has("camera-file")) {
    throw UsageError(imported ? "--camera " + kind + " needs --camera-file" : "--camera-file is for --camera file, realestate10k or colmap");
  }
  const long long width = args.get_int("width"), height = args.get_int("height");
  if (width < 1 || height < 1) throw UsageError("--width and --height expect at least 1 pixel");
  if (const std::string problem = io::image_size_problem(width, height); !problem.empty()) throw UsageError("--width and --height: " + problem);
  camera.width = static_cast<int>(width);
  camera.height = static_cast<int>(height);
  camera.hfov_deg = args.get_double("hfov");
  if (!(camera.hfov_deg > 0 && camera.hfov_deg < 180)) {
    throw UsageError("--hfov expects degrees between 0 and 180, got " + args.get("hfov"));
  }
  // Parsed for every kind (an ego camera takes none, but a malformed one is still refused).
  std::optional<Eigen::Vector3d> target;
  if (args.has("camera-target")) target = parse_vector3(args, "camera-target");
  if (kind == "static" || kind == "dolly-zoom" || kind == "zoom") {
    std::optional<Eigen::Vector3d> position;
    if (args.has("camera-position")) position = parse_vector3(args, "camera-position");
    if (kind == "static") {
      scene::StaticRig rig;
      rig.position = position;
      rig.target = target;
      camera.rig = rig;
    } else if (kind == "dolly-zoom") {
      scene::DollyZoomRig rig;
      rig.position = position;
      rig.target = target;
      if (args.has("camera-end-distance")) rig.end_distance = positive(args, "camera-end-distance");
      camera.rig = rig;
    } else {
      scene::ZoomRig rig;
      rig.position = position;
      rig.target = target;
      if (args.has("hfov-end")) {
        rig.hfov_end_deg = args.get_double("hfov-end");
        if (!(*rig.hfov_end_deg > 0 && *rig.hfov_end_deg < 180)) {
          throw UsageError("--hfov-end expects degrees between 0 and 180, got " + args.get("hfov-end"));
        }
      }
      camera.rig = rig;
    }
  } else if (kind == "swoop") {
    scene::SwoopRig rig;
    rig.target = target;
    if (args.has("camera-radius")) rig.radius = positive(args, "camera-radius");
    if (args.has("camera-height")) rig.height_m = args.get_double("camera-height");
    if (args.has("camera-height-end")) rig.height_end_m = args.get_double("camera-height-end");
    rig.sweep_deg = args.get_double("camera-sweep");
    if (!std::isfinite(rig.sweep_deg)) throw UsageError("--camera-sweep must be finite");
    camera.rig = rig;
  } else if (imported) {
    scene::ImportedRig rig;
    rig.format = kind == "colmap" ? scene::ImportedRig::Format::colmap : scene::ImportedRig::Format::realestate10k;
    rig.target = target;
    rig.path = args.get("camera-file");
    rig.extent_m = positive(args, "camera-extent");
    const std::string anchor = args.get("camera-anchor");
    if (anchor != "centroid" && anchor != "focus") throw UsageError("--camera-anchor expects centroid or focus, got '" + anchor + "'");
    rig.anchor_focus = anchor == "focus";
    rig.speed = positive(args, "camera-speed");
    rig.source_fps = positive(args, "camera-fps");
    if (args.has("camera-height")) rig.height_m = args.get_double("camera-height");
    if (args.has("camera-aim")) {
      rig.aim_smoothing_s = args.get_double("camera-aim");
      if (!(*rig.aim_smoothing_s >= 0) || !std::isfinite(*rig.aim_smoothing_s)) {
        throw UsageError("--camera-aim must be 0 or more seconds");
      }
    }
    camera.rig = rig;
  } else if (kind == "orbit") {
    scene::OrbitRig rig;
    rig.target = target;
    if (args.has("camera-radius")) rig.radius = positive(args, "camera-radius");
    if (args.has("camera-height")) rig.height_m = args.get_double("camera-height");
    rig.period_s = args.get_double("camera-period");
    if (rig.period_s == 0 || !std::isfinite(rig.period_s)) throw UsageError("--camera-period must not be 0");
    camera.rig = rig;
  } else {
    scene::EgoRig rig;
    rig.actor = 0;
    if (args.has("eye-forward")) rig.eye_forward = args.get_double("eye-forward");
    if (args.has("eye-up")) rig.eye_up = args.get_double("eye-up");
    rig.smoothing_s = args.get_double("camera-smooth");
    if (!(rig.smoothing_s >= 0)) throw UsageError("--camera-smooth must be 0 or more seconds");
    camera.rig = rig;
  }
  return camera;
}

}  // namespace odyssey::cli
