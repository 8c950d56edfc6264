#include "cli/camera_options.h"

#include <cmath>
#include <cstdlib>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "mocap_io/camera_path_file.h"
#include "mocap_io/input_error.h"
#include "retarget/canonical.h"
#include "scene_layouts/camera_rigs.h"

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

// What the defaults are made of (see the header).
struct Framing {
  double height;             // h
  Eigen::Vector3d target;    // (m.x, m.y, 0.55 h)
  double distance;           // 2.5 h + e
  Eigen::Vector3d facing;    // f
};

Framing frame_character(const Character& character, const retarget::BoneMap& map, const Clip& clip) {
  Framing framing;
  const Eigen::AlignedBox3d bounds = character.rest_bounds();
  framing.height = bounds.sizes().z();
  if (!(framing.height > 0)) throw std::invalid_argument("the character has no height at rest");
  const int root = map.mapped(retarget::canonical::pelvis) ? map.joints[retarget::canonical::pelvis] : 0;
  std::vector<RigidTransform<double>> world(clip.joint_count());
  std::vector<Eigen::Vector2d> path(clip.frame_count());
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (int f = 0; f < clip.frame_count(); ++f) {
    clip.world_pose(f, world);
    path[f] = world[root].translation.head<2>();
    mean += path[f];
  }
  mean /= clip.frame_count();
  double extent = 0;
  for (const Eigen::Vector2d& p : path) extent = std::max(extent, (p - mean).norm());
  framing.target = Eigen::Vector3d(mean.x(), mean.y(), bounds.min().z() + 0.55 * framing.height);
  framing.distance = 2.5 * framing.height + extent;
  framing.facing = scene::rest_facing(character.skeleton, map.joints[retarget::canonical::left_hip],
                                      map.joints[retarget::canonical::right_hip]);
  return framing;
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

std::optional<CameraPath> camera_path_from_options(const Args& args, const Character& character,
                                                   const retarget::BoneMap& target_map, const Clip& clip) {
  const std::string kind = args.get("camera");
  if (kind == "none") return std::nullopt;
  if (kind == "file") {
    if (!args.has("camera-file")) throw UsageError("--camera file needs --camera-file");
    const std::string path = args.get("camera-file");
    CameraPath camera = io::read_camera_path_json(path);
    if (camera.frame_count() != clip.frame_count() || std::abs(camera.fps - clip.fps) > 1e-9 * clip.fps) {
      throw io::InputError(path, "the camera path has " + std::to_string(camera.frame_count()) + " frames at " +
                                     std::to_string(camera.fps) + " fps; the motion has " +
                                     std::to_string(clip.frame_count()) + " at " + std::to_string(clip.fps));
    }
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
  const double hfov = args.get_double("hfov");
  if (!(hfov > 0 && hfov < 180)) throw UsageError("--hfov expects degrees between 0 and 180, got " + args.get("hfov"));
  const PinholeIntrinsics intrinsics = intrinsics_from_hfov(static_cast<int>(width), static_cast<int>(height), hfov);

  const Framing framing = frame_character(character, target_map, clip);
  const Eigen::Vector3d target = args.has("camera-target") ? parse_vector3(args, "camera-target") : framing.target;
  if (kind == "static") {
    scene::StaticCameraOptions options;
    options.target = target;
    options.centre = args.has("camera-position")
                         ? parse_vector3(args, "camera-position")
                         : Eigen::Vector3d(target.x() + framing.distance * framing.facing.x(),
                                           target.y() + framing.distance * framing.facing.y(), 0.9 * framing.height);
    return scene::static_camera_path(clip.frame_count(), clip.fps, intrinsics, options);
  }
  if (kind == "orbit") {
    scene::OrbitCameraOptions options;
    options.target = target;
    options.radius = args.has("camera-radius") ? positive(args, "camera-radius") : framing.distance;
    options.height = args.has("camera-height") ? args.get_double("camera-height") : 0.9 * framing.height;
    options.period_s = args.get_double("camera-period");
    if (options.period_s == 0 || !std::isfinite(options.period_s)) throw UsageError("--camera-period must not be 0");
    options.start_angle_deg = std::atan2(framing.facing.y(), framing.facing.x()) * 180 / std::numbers::pi;
    return scene::orbit_camera_path(clip.frame_count(), clip.fps, intrinsics, options);
  }
  scene::EgoHeadOptions options;
  options.forward_offset = args.has("eye-forward") ? args.get_double("eye-forward") : 0.06 * framing.height;
  options.up_offset = args.has("eye-up") ? args.get_double("eye-up") : 0.047 * framing.height;
  options.smoothing_sigma_s = args.get_double("camera-smooth");
  if (!(options.smoothing_sigma_s >= 0)) throw UsageError("--camera-smooth must be 0 or more seconds");
  return scene::ego_head_camera_path(clip, target_map, intrinsics, options);
}

}  // namespace odyssey::cli
