#include "scene_layouts/imported_camera.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "mocap_io/input_error.h"

namespace odyssey::scene {
namespace {

void require(bool ok, const std::string& message) {
  if (!ok) throw std::invalid_argument("imported camera: " + message);
}

struct Sample {
  Eigen::Quaterniond rotation;  // world -> camera, the track's world
  Eigen::Vector3d centre;
  double fx, fy, cx, cy;        // normalised
};

// Step 2 of the header: the track at the output frames' times.
std::vector<Sample> resample(const io::CameraTrack& track, int frames, double fps, double speed, int& held) {
  const std::vector<io::CameraTrackFrame>& in = track.frames;
  std::vector<Sample> out(frames);
  held = 0;
  std::size_t k = 0;
  for (int f = 0; f < frames; ++f) {
    const double tau = in.front().time_s + speed * f / fps;
    while (k + 1 < in.size() && in[k + 1].time_s <= tau) ++k;
    const io::CameraTrackFrame& a = in[k];
    const io::CameraTrackFrame& b = in[std::min(k + 1, in.size() - 1)];
    double w = 0;
    if (k + 1 < in.size()) {
      w = (tau - a.time_s) / (b.time_s - a.time_s);
    } else if (tau > a.time_s) {
      ++held;
    }
    const Eigen::Quaterniond qa(a.pose.rotation), qb(b.pose.rotation);
    Sample& s = out[f];
    s.rotation = qa.slerp(w, qb).normalized();
    s.centre = (1 - w) * a.pose.centre() + w * b.pose.centre();
    s.fx = (1 - w) * a.fx + w * b.fx;
    s.fy = (1 - w) * a.fy + w * b.fy;
    s.cx = (1 - w) * a.cx + w * b.cx;
    s.cy = (1 - w) * a.cy + w * b.cy;
  }
  return out;
}

// Zero-phase Gaussian over frames (sigma in frames, cut at 3 sigma and at the ends, weights
// renormalised): a straight-line motion passes through the interior unchanged.
std::vector<Eigen::Vector3d> smoothed(const std::vector<Eigen::Vector3d>& points, double sigma_frames) {
  const int reach = static_cast<int>(std::floor(3 * sigma_frames * (1 + 1e-9)));
  if (reach == 0) return points;
  const int frames = static_cast<int>(points.size());
  std::vector<Eigen::Vector3d> out(frames);
  for (int f = 0; f < frames; ++f) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    double weight_sum = 0;
    for (int g = std::max(0, f - reach); g <= std::min(frames - 1, f + reach); ++g) {
      const double w = std::exp(-double((g - f) * (g - f)) / (2 * sigma_frames * sigma_frames));
      sum += w * points[g];
      weight_sum += w;
    }
    out[f] = sum / weight_sum;
  }
  return out;
}

}  // namespace

Eigen::Vector3d estimate_up(const io::CameraTrack& track) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const io::CameraTrackFrame& frame : track.frames) sum -= frame.pose.down();
  // Each term is a unit vector: a sum far shorter than the count means the cameras disagree.
  if (!(sum.norm() > 1e-3 * static_cast<double>(track.frames.size()))) {
    throw io::InputError(track.path, "cannot estimate up: the cameras' image-up axes cancel out (give the up direction)");
  }
  return sum.normalized();
}

CameraPath imported_camera_path(const io::CameraTrack& track, int frames, double fps, const ImportedCameraOptions& options,
                                std::vector<std::string>* notes) {
  require(frames >= 1, "frames must be at least 1, got " + std::to_string(frames));
  require(fps > 0 && std::isfinite(fps), "fps must be positive and finite");
  require(!track.frames.empty(), "the track has no frames");
  require(options.width >= 1 && options.height >= 1, "the image must be at least 1x1 pixels");
  require(options.extent_m > 0 && std::isfinite(options.extent_m), "extent must be positive, got " + std::to_string(options.extent_m));
  require(options.centre.allFinite() && std::isfinite(options.height_m) && std::isfinite(options.start_angle_deg),
          "centre, height and start_angle must be finite");
  require(options.speed > 0 && std::isfinite(options.speed), "speed must be positive, got " + std::to_string(options.speed));
  require(!options.up || (options.up->allFinite() && options.up->norm() > 0), "up must be a finite non-zero vector");
  require(options.look_at.empty() || static_cast<int>(options.look_at.size()) == frames,
          "look_at has " + std::to_string(options.look_at.size()) + " points for " + std::to_string(frames) + " frames");
  require(options.aim_smoothing_s >= 0 && std::isfinite(options.aim_smoothing_s), "aim smoothing must be 0 or more seconds");

  const Eigen::Vector3d up = options.up ? options.up->normalized() : estimate_up(track);
  const Eigen::Matrix3d level = Eigen::Quaterniond::FromTwoVectors(up, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  int held = 0;
  const std::vector<Sample> samples = resample(track, frames, fps, options.speed, held);

  std::vector<Eigen::Vector3d> levelled(frames);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int f = 0; f < frames; ++f) {
    levelled[f] = level * samples[f].centre;
    mean += levelled[f];
  }
  mean /= frames;
  if (options.anchor == ImportedCameraOptions::Anchor::focus) {
    // The point nearest every view axis: minimise sum_f |P_f (p - c_f)|^2 with P_f = I - v_f v_f^T
    // (v_f the view direction), so (sum P_f) p = sum P_f c_f. Near-parallel axes leave sum P_f
    // without the rank to fix p along them.
    Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
    Eigen::Vector3d right_side = Eigen::Vector3d::Zero();
    for (int f = 0; f < frames; ++f) {
      const Eigen::Vector3d view = level * (samples[f].rotation.conjugate() * Eigen::Vector3d::UnitZ());
      const Eigen::Matrix3d across = Eigen::Matrix3d::Identity() - view * view.transpose();
      normal += across;
      right_side += across * levelled[f];
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> spread(normal);
    // The smallest eigenvalue over the frames is about the mean squared sine of the axes' spread.
    if (!(spread.eigenvalues()[0] > 1e-3 * frames)) {
      throw io::InputError(track.path, "the cameras' view axes do not converge on a point (they are nearly parallel): "
                                       "anchor the path on its centroid instead");
    }
    const Eigen::Vector3d focus = normal.ldlt().solve(right_side);
    mean.head<2>() = focus.head<2>();
  }
  double reach = 0;
  for (const Eigen::Vector3d& c : levelled) reach = std::max(reach, (c - mean).head<2>().norm());
  if (!(reach > 1e-12 * (1 + mean.norm()))) {
    throw io::InputError(track.path, "the cameras do not move horizontally during the shot: nothing to rescale to the extent");
  }
  const double scale = (options.extent_m / 2) / reach;

  // Y: the first centre's direction from the mean to start_angle, or the first view's opposite.
  Eigen::Vector2d first = (levelled[0] - mean).head<2>();
  double from_angle = 0, to_angle = options.start_angle_deg * std::numbers::pi / 180;
  if (first.norm() > 1e-9 * reach) {
    from_angle = std::atan2(first.y(), first.x());
  } else {
    const Eigen::Vector3d view = level * (samples[0].rotation.conjugate() * Eigen::Vector3d::UnitZ());
    from_angle = view.head<2>().norm() > 1e-9 ? std::atan2(view.y(), view.x()) : to_angle + std::numbers::pi;
    to_angle += std::numbers::pi;
  }
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(to_angle - from_angle, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Matrix3d world = turn * level;  // Y L
  // T: the levelled mean m goes to (centre, height), s Y m + T = (centre, height).
  const Eigen::Vector3d turned_mean = turn * mean;
  const Eigen::Vector3d shift = Eigen::Vector3d(options.centre.x(), options.centre.y(), options.height_m) - scale * turned_mean;

  CameraPath path;
  path.kind = track.format;
  path.fps = fps;
  std::vector<Eigen::Vector3d> aim;
  if (!options.look_at.empty()) aim = smoothed(options.look_at, options.aim_smoothing_s * fps);
  for (int f = 0; f < frames; ++f) {
    const Sample& s = samples[f];
    CameraPose pose;
    pose.rotation = s.rotation.toRotationMatrix() * world.transpose();
    const Eigen::Vector3d centre = scale * (world * s.centre) + shift;
    if (!aim.empty()) {
      try {
        pose = CameraPose::from_forward_up(centre, aim[f] - centre, -pose.down());
      } catch (const std::invalid_argument& error) {
        throw std::invalid_argument("imported camera: frame " + std::to_string(f) + ": cannot aim at the actors: " + error.what());
      }
    }
    pose.translation = -(pose.rotation * centre);
    path.poses.push_back(pose);
    PinholeIntrinsics k;
    k.width = options.width;
    k.height = options.height;
    k.fx = s.fx * options.width;
    k.fy = s.fy * options.height;
    k.cx = s.cx * options.width;
    k.cy = s.cy * options.height;
    path.intrinsics.push_back(k);
  }
  path.validate();

  if (notes) {
    notes->insert(notes->end(), track.notes.begin(), track.notes.end());
    if (held > 0) {
      notes->push_back(track.path + ": the track ends at " + std::to_string(track.frames.back().time_s - track.frames.front().time_s) +
                       " s of its time; its last camera is held for the last " + std::to_string(held) + " of " +
                       std::to_string(frames) + " frames");
    }
    const double aspect = path.intrinsics[0].fy / path.intrinsics[0].fx;
    if (std::abs(aspect - 1) > 0.01) {
      notes->push_back(track.path + ": the output's pixels come out non-square (fy/fx = " + std::to_string(aspect) +
                       "): the image's aspect " + std::to_string(options.width) + ":" + std::to_string(options.height) +
                       " differs from the source's");
    }
  }
  return path;
}

}  // namespace odyssey::scene
