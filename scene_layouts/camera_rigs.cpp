#include "scene_layouts/camera_rigs.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "scene_layouts/seeded_uniform.h"

namespace odyssey::scene {
namespace {

void require(bool ok, const std::string& message) {
  if (!ok) throw std::invalid_argument(message);
}

void check_frames_and_fps(const char* rig, int frames, double fps) {
  require(frames >= 1, std::string(rig) + ": frames must be at least 1, got " + std::to_string(frames));
  require(fps > 0 && std::isfinite(fps), std::string(rig) + ": fps must be positive and finite, got " + std::to_string(fps));
}

void check_intrinsics(const char* rig, const PinholeIntrinsics& k) {
  require(k.fx > 0 && k.fy > 0 && std::isfinite(k.fx) && std::isfinite(k.fy) && std::isfinite(k.cx) &&
              std::isfinite(k.cy) && k.width >= 1 && k.height >= 1,
          std::string(rig) + ": intrinsics must have positive finite focal lengths, a finite principal point and an "
                             "image of at least 1x1 pixels");
}

// CameraPose::look_at with the rig's options named in its error (the centre on the target, or a
// view straight along z).
CameraPose look_at_named(const std::string& what, const Eigen::Vector3d& centre, const Eigen::Vector3d& target) {
  try {
    return CameraPose::look_at(centre, target, Eigen::Vector3d::UnitZ());
  } catch (const std::invalid_argument& error) {
    throw std::invalid_argument(what + ": " + error.what());
  }
}

CameraPath constant_intrinsics_path(const char* kind, int frames, double fps, const PinholeIntrinsics& intrinsics) {
  CameraPath path;
  path.kind = kind;
  path.fps = fps;
  path.poses.reserve(frames);
  path.intrinsics.assign(frames, intrinsics);
  return path;
}

// The zero-phase Gaussian of the header, in frames: weight w_k = exp(-k^2 / (2 s^2)) at offset
// k = -K..K, K = floor(3 s), s = sigma * fps; the window is cut at the clip's ends and the weights
// renormalised. Centres average linearly,
//   c'(f) = sum_k w_k c(f + k) / sum_k w_k,
// orientations as quaternions sign-aligned to frame f's (q and -q are the same rotation; without
// the alignment opposite signs would cancel) and normalised afterwards: close to the weighted
// rotation mean for the small spread within a few frames, and for a turn at constant rate about a
// fixed axis it returns the centre frame's quaternion exactly, since
// q(a + d) + q(a - d) = 2 cos(d/2) q(a).
void smooth_poses(std::vector<CameraPose>& poses, double sigma_frames) {
  // The 1e-9 slack keeps the 3-sigma tap when 3 s is an integer up to rounding (sigma 0.05 at 60 fps).
  const int reach = static_cast<int>(std::floor(3 * sigma_frames * (1 + 1e-9)));
  if (reach == 0) return;  // a one-tap window is the identity
  std::vector<double> weight(reach + 1);
  for (int k = 0; k <= reach; ++k) weight[k] = std::exp(-(k * k) / (2 * sigma_frames * sigma_frames));

  const int frames = static_cast<int>(poses.size());
  std::vector<Eigen::Vector3d> centres(frames);
  std::vector<Eigen::Vector4d> quaternions(frames);  // Eigen's coefficient order x, y, z, w
  for (int f = 0; f < frames; ++f) {
    centres[f] = poses[f].centre();
    quaternions[f] = Eigen::Quaterniond(poses[f].rotation).coeffs();
  }
  for (int f = 0; f < frames; ++f) {
    Eigen::Vector3d centre_sum = Eigen::Vector3d::Zero();
    Eigen::Vector4d quaternion_sum = Eigen::Vector4d::Zero();
    double weight_sum = 0;
    for (int g = std::max(0, f - reach); g <= std::min(frames - 1, f + reach); ++g) {
      const double w = weight[std::abs(g - f)];
      const double sign = quaternions[g].dot(quaternions[f]) < 0 ? -1.0 : 1.0;
      centre_sum += w * centres[g];
      quaternion_sum += (w * sign) * quaternions[g];
      weight_sum += w;
    }
    Eigen::Quaterniond mean;
    mean.coeffs() = quaternion_sum.normalized();
    poses[f].rotation = mean.toRotationMatrix();
    poses[f].translation = -(poses[f].rotation * (centre_sum / weight_sum));
  }
}

// The shot's progress u = f / (frames - 1) eased to s(u) = (1 - cos(pi u)) / 2.
double eased_progress(int f, int frames) {
  if (frames <= 1) return 0;
  const double u = static_cast<double>(f) / (frames - 1);
  return (1 - std::cos(std::numbers::pi * u)) / 2;
}

PinholeIntrinsics scaled_focal(PinholeIntrinsics k, double factor) {
  k.fx *= factor;
  k.fy *= factor;
  return k;
}

}  // namespace

CameraPath static_camera_path(int frames, double fps, const PinholeIntrinsics& intrinsics,
                              const StaticCameraOptions& options) {
  check_frames_and_fps("static camera", frames, fps);
  check_intrinsics("static camera", intrinsics);
  require(options.centre.allFinite(), "static camera: centre must be finite");
  require(options.target.allFinite(), "static camera: target must be finite");
  const CameraPose pose = look_at_named("static camera centre and target", options.centre, options.target);
  CameraPath path = constant_intrinsics_path("static", frames, fps, intrinsics);
  path.poses.assign(frames, pose);
  return path;
}

CameraPath orbit_camera_path(int frames, double fps, const PinholeIntrinsics& intrinsics,
                             const OrbitCameraOptions& options) {
  check_frames_and_fps("orbit camera", frames, fps);
  check_intrinsics("orbit camera", intrinsics);
  require(options.target.allFinite(), "orbit camera: target must be finite");
  require(options.radius > 0 && std::isfinite(options.radius),
          "orbit camera: radius must be positive and finite, got " + std::to_string(options.radius));
  require(std::isfinite(options.height), "orbit camera: height must be finite");
  require(options.period_s != 0 && std::isfinite(options.period_s),
          "orbit camera: period_s must be non-zero and finite, got " + std::to_string(options.period_s));
  require(std::isfinite(options.start_angle_deg), "orbit camera: start_angle_deg must be finite");

  CameraPath path = constant_intrinsics_path("orbit", frames, fps, intrinsics);
  const double start = options.start_angle_deg * std::numbers::pi / 180;
  for (int f = 0; f < frames; ++f) {
    // a(t) = start + 2 pi t / period, t = f / fps; c = target + r (cos a, sin a) at z = height.
    const double angle = start + 2 * std::numbers::pi * (f / fps) / options.period_s;
    const Eigen::Vector3d centre(options.target.x() + options.radius * std::cos(angle),
                                 options.target.y() + options.radius * std::sin(angle), options.height);
    path.poses.push_back(look_at_named("orbit camera radius, height and target", centre, options.target));
  }
  return path;
}

CameraPath swoop_camera_path(int frames, double fps, const PinholeIntrinsics& intrinsics,
                             const SwoopCameraOptions& options) {
  check_frames_and_fps("swoop camera", frames, fps);
  check_intrinsics("swoop camera", intrinsics);
  require(options.target.allFinite(), "swoop camera: target must be finite");
  require(options.radius > 0 && std::isfinite(options.radius),
          "swoop camera: radius must be positive and finite, got " + std::to_string(options.radius));
  require(std::isfinite(options.start_height) && std::isfinite(options.end_height),
          "swoop camera: start_height and end_height must be finite");
  require(std::isfinite(options.start_angle_deg) && std::isfinite(options.sweep_deg),
          "swoop camera: start_angle_deg and sweep_deg must be finite");
  CameraPath path = constant_intrinsics_path("swoop", frames, fps, intrinsics);
  const double start = options.start_angle_deg * std::numbers::pi / 180, sweep = options.sweep_deg * std::numbers::pi / 180;
  for (int f = 0; f < frames; ++f) {
    const double s = eased_progress(f, frames);
    const double angle = start + sweep * s;
    const Eigen::Vector3d centre(options.target.x() + options.radius * std::cos(angle),
                                 options.target.y() + options.radius * std::sin(angle),
                                 options.start_height + (options.end_height - options.start_height) * s);
    path.poses.push_back(look_at_named("swoop camera radius, heights and target", centre, options.target));
  }
  return path;
}

CameraPath dolly_zoom_camera_path(int frames, double fps, const PinholeIntrinsics& intrinsics,
                                  const DollyZoomOptions& options) {
  check_frames_and_fps("dolly-zoom camera", frames, fps);
  check_intrinsics("dolly-zoom camera", intrinsics);
  require(options.start_centre.allFinite() && options.target.allFinite(),
          "dolly-zoom camera: start_centre and target must be finite");
  require(options.end_distance > 0 && std::isfinite(options.end_distance),
          "dolly-zoom camera: end_distance must be positive and finite, got " + std::to_string(options.end_distance));
  const double start_distance = (options.target - options.start_centre).norm();
  require(start_distance > 0, "dolly-zoom camera: start_centre is on the target");
  // One orientation for the whole move: the view axis does not turn.
  const CameraPose first = look_at_named("dolly-zoom camera start_centre and target", options.start_centre, options.target);
  const Eigen::Vector3d axis = first.forward();
  CameraPath path;
  path.kind = "dolly-zoom";
  path.fps = fps;
  for (int f = 0; f < frames; ++f) {
    const double distance = start_distance + (options.end_distance - start_distance) * eased_progress(f, frames);
    CameraPose pose = first;
    pose.translation = -(pose.rotation * (options.target - distance * axis));
    path.poses.push_back(pose);
    path.intrinsics.push_back(scaled_focal(intrinsics, distance / start_distance));
  }
  return path;
}

CameraPath zoom_camera_path(int frames, double fps, const PinholeIntrinsics& intrinsics,
                            const ZoomCameraOptions& options) {
  check_frames_and_fps("zoom camera", frames, fps);
  check_intrinsics("zoom camera", intrinsics);
  require(options.centre.allFinite() && options.target.allFinite(), "zoom camera: centre and target must be finite");
  require(options.end_hfov_deg > 0 && options.end_hfov_deg < 180,
          "zoom camera: end_hfov_deg must be between 0 and 180 degrees, got " + std::to_string(options.end_hfov_deg));
  const CameraPose pose = look_at_named("zoom camera centre and target", options.centre, options.target);
  const double end_fx = (intrinsics.width / 2.0) / std::tan(options.end_hfov_deg * std::numbers::pi / 360);
  const double ratio = end_fx / intrinsics.fx;
  CameraPath path;
  path.kind = "zoom";
  path.fps = fps;
  path.poses.assign(frames, pose);
  for (int f = 0; f < frames; ++f) path.intrinsics.push_back(scaled_focal(intrinsics, std::pow(ratio, eased_progress(f, frames))));
  return path;
}

void apply_handheld(CameraPath& path, const HandheldOptions& options, std::uint64_t seed, std::uint64_t stream) {
  path.validate();
  require(options.amplitude_m >= 0 && std::isfinite(options.amplitude_m),
          "handheld: amplitude must be 0 or more metres, got " + std::to_string(options.amplitude_m));
  require(options.rotation_deg >= 0 && options.rotation_deg <= 45,
          "handheld: rotation must be 0 to 45 degrees, got " + std::to_string(options.rotation_deg));
  require(options.low_hz > 0 && options.high_hz >= options.low_hz && options.high_hz < path.fps / 2,
          "handheld: the band [" + std::to_string(options.low_hz) + ", " + std::to_string(options.high_hz) +
              "] Hz must have 0 < low <= high < fps / 2 = " + std::to_string(path.fps / 2));
  constexpr int kChannels = 6, kTerms = 8;
  SeededUniform draw(seed, stream);
  double frequency[kChannels][kTerms], phase[kChannels][kTerms];
  for (int k = 0; k < kChannels; ++k) {
    for (int i = 0; i < kTerms; ++i) {
      frequency[k][i] = draw.between(options.low_hz, options.high_hz);
      phase[k][i] = draw.between(0, 2 * std::numbers::pi);
    }
  }
  const double amplitude[kChannels] = {options.amplitude_m, options.amplitude_m, options.amplitude_m,
                                       options.rotation_deg * std::numbers::pi / 180, options.rotation_deg * std::numbers::pi / 180,
                                       options.rotation_deg * std::numbers::pi / 180};
  for (int f = 0; f < path.frame_count(); ++f) {
    const double t = f / path.fps;
    double x[kChannels];
    for (int k = 0; k < kChannels; ++k) {
      double sum = 0;
      for (int i = 0; i < kTerms; ++i) sum += std::sin(2 * std::numbers::pi * frequency[k][i] * t + phase[k][i]);
      x[k] = amplitude[k] * sum / kTerms;
    }
    CameraPose& pose = path.poses[f];
    const Eigen::Vector3d centre = pose.centre() + pose.rotation.transpose() * Eigen::Vector3d(x[0], x[1], x[2]);
    const Eigen::Matrix3d turn = (Eigen::AngleAxisd(x[3], Eigen::Vector3d::UnitX()) *
                                  Eigen::AngleAxisd(x[4], Eigen::Vector3d::UnitY()) *
                                  Eigen::AngleAxisd(x[5], Eigen::Vector3d::UnitZ())).toRotationMatrix();
    pose.rotation = turn * pose.rotation;
    pose.translation = -(pose.rotation * centre);
  }
  path.kind += "+handheld";
}

Eigen::Vector3d rest_facing(const Skeleton& skeleton, int left_hip, int right_hip) {
  const int joints = skeleton.joint_count();
  const auto check_joint = [joints](int joint, const char* option) {
    require(joint >= 0 && joint < joints, std::string("facing: ") + option + " joint " + std::to_string(joint) +
                                              " is outside the skeleton (" + std::to_string(joints) + " joints)");
  };
  check_joint(left_hip, "left_hip");
  check_joint(right_hip, "right_hip");
  const std::vector<RigidTransform<double>> rest = skeleton.rest_world();
  // forward_rest = normalise((p_left - p_right) x z): the hip axis points to the character's left,
  // and left x up is forward for a right-handed body (facing +y, left is -x: -x cross z = +y).
  const Eigen::Vector3d across = rest[left_hip].translation - rest[right_hip].translation;
  require(across.norm() > 1e-9, "facing: left_hip and right_hip coincide in the rest pose");
  const Eigen::Vector3d forward = across.cross(Eigen::Vector3d::UnitZ());
  // |across x z| = |across| sin(angle to z): the same 1e-9 rad tolerance as CameraPose.
  require(forward.norm() > 1e-9 * across.norm(), "facing: left_hip and right_hip lie along z in the rest pose");
  return forward.normalized();
}

HeadFrame head_frame_from_rest(const Skeleton& skeleton, int head, int left_hip, int right_hip) {
  require(head >= 0 && head < skeleton.joint_count(), "head frame: head joint " + std::to_string(head) +
                                                          " is outside the skeleton (" +
                                                          std::to_string(skeleton.joint_count()) + " joints)");
  const Eigen::Vector3d forward = rest_facing(skeleton, left_hip, right_hip);
  const Eigen::Matrix3d head_rotation = skeleton.rest_world()[head].rotation;
  HeadFrame frame;
  frame.forward_local = head_rotation.transpose() * forward;
  frame.up_local = head_rotation.transpose() * Eigen::Vector3d::UnitZ();
  return frame;
}

CameraPath ego_head_camera_path(const TimedClip& clip, int head, const HeadFrame& head_frame,
                                const PinholeIntrinsics& intrinsics, const EgoHeadOptions& options) {
  const int frames = clip.frame_count();
  check_frames_and_fps("ego-head camera", frames, clip.fps());
  check_intrinsics("ego-head camera", intrinsics);
  require(head >= 0 && head < clip.joint_count(), "ego-head camera: head joint " + std::to_string(head) +
                                                      " is outside the skeleton (" +
                                                      std::to_string(clip.joint_count()) + " joints)");
  require(std::isfinite(options.forward_offset), "ego-head camera: forward_offset must be finite");
  require(std::isfinite(options.up_offset), "ego-head camera: up_offset must be finite");
  require(options.smoothing_sigma_s >= 0 && std::isfinite(options.smoothing_sigma_s),
          "ego-head camera: smoothing_sigma_s must be zero or positive, got " + std::to_string(options.smoothing_sigma_s));
  const Eigen::Vector3d& f_h = head_frame.forward_local;
  const Eigen::Vector3d& u_h = head_frame.up_local;
  require(f_h.allFinite() && u_h.allFinite() && f_h.norm() > 0 && u_h.norm() > 0,
          "ego-head camera: head_frame axes must be finite and non-zero");
  // A rotation keeps angles, so a head frame whose forward is not parallel to its up never gives a
  // view along the up direction on any frame (same 1e-9 rad tolerance as CameraPose).
  require(f_h.cross(u_h).norm() > 1e-9 * f_h.norm() * u_h.norm(),
          "ego-head camera: head_frame forward_local is parallel to up_local");

  // The eye point in head-local axes: forward_offset f_h + up_offset u_h.
  const Eigen::Vector3d eye_local = options.forward_offset * f_h + options.up_offset * u_h;
  CameraPath path = constant_intrinsics_path("ego-head", frames, clip.fps(), intrinsics);
  KinematicData<double> pose(clip.skeleton().kinematics());
  for (int f = 0; f < frames; ++f) {
    clip.world_pose(f, pose);
    const RigidTransform<double>& h = pose.world[head];
    path.poses.push_back(CameraPose::from_forward_up(h * eye_local, h.rotation * f_h, h.rotation * u_h));
  }
  if (options.smoothing_sigma_s > 0) smooth_poses(path.poses, options.smoothing_sigma_s * clip.fps());
  return path;
}

CameraPath ego_head_camera_path(const TimedClip& clip, const retarget::BoneMap& map, const PinholeIntrinsics& intrinsics,
                                const EgoHeadOptions& options) {
  const int head = map.joints[retarget::canonical::head];
  const int left_hip = map.joints[retarget::canonical::left_hip];
  const int right_hip = map.joints[retarget::canonical::right_hip];
  require(head >= 0, "ego-head camera: the bone map has no head");
  require(left_hip >= 0 && right_hip >= 0, "ego-head camera: the bone map has no left_hip or no right_hip");
  return ego_head_camera_path(clip, head, head_frame_from_rest(clip.skeleton(), head, left_hip, right_hip), intrinsics,
                              options);
}

}  // namespace odyssey::scene
