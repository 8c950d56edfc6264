#include "synthetic/synthetic_walk.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>

#include "skeleton/rotation.h"

namespace odyssey {

namespace {

constexpr double kPi = std::numbers::pi;

Eigen::Quaterniond about(int axis, double angle) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, Eigen::Vector3d::Unit(axis)));
}

constexpr int kX = 0, kY = 1, kZ = 2;

// Joint indices shared by SMPL, SMPL-H and SMPL-X (the first 22).
constexpr int kPelvis = 0, kLeftHip = 1, kRightHip = 2, kSpine1 = 3, kLeftKnee = 4, kRightKnee = 5, kSpine2 = 6,
              kLeftAnkle = 7, kRightAnkle = 8, kSpine3 = 9, kLeftFoot = 10, kRightFoot = 11, kHead = 15,
              kLeftShoulder = 16, kRightShoulder = 17, kLeftElbow = 18, kRightElbow = 19;

// Leg geometry of the SMPL-X template at rest (metres, body frame: x left, y up, z forward), for
// the left leg; the right mirrors x. The walk plants feet exactly for a body of these proportions.
constexpr double kHipLeft = 0.065, kHipDown = 0.083, kHipBack = 0.007;         // pelvis joint -> hip joint
constexpr double kThighOut = 0.035, kThighDown = 0.38, kThighForward = 0.005;  // hip -> knee
constexpr double kShinIn = 0.009, kShinDown = 0.395, kShinBack = 0.042;        // knee -> ankle
constexpr double kBallForward = 0.122, kBallDown = 0.047;                      // ankle -> foot joint (ball of the foot)
constexpr double kAnkleHeight = 0.075;                                         // ankle joint above the sole

// Gait schedule of one leg, in its own phase s (cycles since its heel strike, in [0, 1)).
constexpr double kFootFlat = 0.08;     // the foot rolls down about the heel until s = 0.08
constexpr double kHeelRise = 0.4;      // the heel starts to rise about the ball of the foot
constexpr double kToeOff = 0.6;        // stance s in [0, 0.6), swing [0.6, 1)
constexpr double kStrikePitch = -0.3;  // foot pitch at heel strike, radians (toes up)
constexpr double kPushOff = 1.2;       // foot pitch at toe-off, radians (heel up)
constexpr double kHeelBack = 0.05;     // heel contact point behind the ankle, metres
constexpr double kLift = 0.03;         // extra ankle height in mid swing, metres
constexpr double kReach = 0.99;        // the stance leg never straightens beyond 99% of its length
constexpr double kBob = 0.04;          // pelvis rise from double support to mid-stance, metres
constexpr double kTilt = 0.05;         // forward pelvis tilt, radians

// 0 -> 1 with zero velocity and acceleration at both ends (minimum jerk), clamped outside.
double ease(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * x * (10 - 15 * x + 6 * x * x);
}

struct Gait {
  double speed;          // m/s
  double stride;         // metres per cycle (two steps)
  double plant_ahead;    // ankle ahead of the pelvis joint at heel strike, metres
  double turn;           // scale of pelvis yaw and roll
  double arm_amplitude;  // scale of arm swing
};

// One foot in the sagittal plane of the walk (forward f, up u, metres), f relative to the
// pelvis joint, with its pitch (radians, heel up positive).
struct FootTarget {
  double forward, up, pitch;
};

// The foot of a leg at phase s. The pelvis advances one stride a cycle, so at phase s it is
// stride * s past where it was at heel strike. The foot lands on its heel with the toes up and
// rolls down about the heel until it is flat, stays flat, then turns about the ball of the foot
// as the heel rises; a pivot p on the ground keeps still while the ankle turns about it:
//   ankle = p + rot(-pitch) (ankle - p)   in (f, u), rot(a) turning forward toward up.
// In swing the ankle travels from its toe-off position to the next landing, one stride on, along
// a minimum-jerk profile lifted by kLift sin^2, while the foot levels out and lifts its toes; it
// meets the ground with zero velocity, so the landing does not slide.
FootTarget foot_target(const Gait& gait, double s) {
  const auto about_pivot = [](double pivot_f, double from_f, double from_u, double pitch) {
    const double c = std::cos(pitch), sn = std::sin(pitch);
    return FootTarget{pivot_f + from_f * c + from_u * sn, -from_f * sn + from_u * c, pitch};
  };
  // Ankle positions relative to the pelvis at this stance's heel strike.
  const auto heel_down = [&](double plant, double pitch) {
    return about_pivot(plant - kHeelBack, kHeelBack, kAnkleHeight, pitch);
  };
  const auto ball_down = [&](double pitch) {
    FootTarget foot = about_pivot(gait.plant_ahead + kBallForward, -kBallForward, kBallDown, pitch);
    foot.up += kAnkleHeight - kBallDown;  // the pivot, the ball of the foot, is that high
    return foot;
  };
  const double pelvis_advance = gait.stride * s;
  FootTarget foot;
  if (s < kFootFlat) {
    foot = heel_down(gait.plant_ahead, kStrikePitch * (1 - ease(s / kFootFlat)));
  } else if (s < kToeOff) {
    foot = ball_down(kPushOff * ease((s - kHeelRise) / (kToeOff - kHeelRise)));
  } else {
    // Swing progress runs on u = w + 0.3 w (1 - w) (w the swing fraction), which brings the
    // foot forward a little early, as a real foot comes, so the knee folds in early swing
    // instead of the leg trailing behind the advancing pelvis.
    const double swing = (s - kToeOff) / (1 - kToeOff);
    const double u = swing + 0.3 * swing * (1 - swing);
    const FootTarget off = ball_down(kPushOff);
    const FootTarget landing = heel_down(gait.plant_ahead + gait.stride, kStrikePitch);
    const double progress = ease(u);
    const double lift = std::sin(kPi * u);
    foot = {off.forward + (landing.forward - off.forward) * progress,
            off.up + (landing.up - off.up) * progress + kLift * lift * lift,
            kPushOff * (1 - ease(1.5 * u)) + kStrikePitch * ease(2 * u - 1)};
  }
  foot.forward -= pelvis_advance;
  return foot;
}

// Everything about a walk that depends on the left leg's phase alone (the right runs half a
// cycle behind), in walk coordinates relative to the pelvis joint.
struct GaitPhase {
  Eigen::Quaterniond pelvis;  // rotation of the pelvis in walk coordinates
  double yaw, roll, sway;
  FootTarget feet[2];  // left, right
  Eigen::Vector3d hips[2];
  double highest[2];  // the highest the pelvis may be for that leg's ankle to reach its target
  bool stance[2];
};

GaitPhase gait_phase(const Gait& gait, double left_phase, double leg_length) {
  GaitPhase phase;
  // Yaw toward the leg in front (the left at its heel strike), roll down on the swing side (the
  // right during left mid-stance, s = 0.3), sway 2 cm toward the stance foot.
  phase.yaw = -0.08 * gait.turn * std::cos(2 * kPi * left_phase);
  phase.roll = 0.04 * gait.turn * std::cos(2 * kPi * (left_phase - 0.3));
  phase.sway = 0.02 * std::cos(2 * kPi * (left_phase - 0.3));
  phase.pelvis = about(kY, phase.yaw) * about(kX, kTilt) * about(kZ, phase.roll);
  const double reach = kReach * leg_length;
  for (int side = 0; side < 2; ++side) {
    const double side_sign = side == 0 ? 1.0 : -1.0;
    double s = left_phase - 0.5 * side;
    s -= std::floor(s);
    phase.feet[side] = foot_target(gait, s);
    phase.stance[side] = s < kToeOff;
    phase.hips[side] = phase.pelvis * Eigen::Vector3d(side_sign * kHipLeft, -kHipDown, -kHipBack);
    const double ahead = phase.feet[side].forward - phase.hips[side].z();
    phase.highest[side] =
        phase.feet[side].up + std::sqrt(std::max(reach * reach - ahead * ahead, 0.0)) - phase.hips[side].y();
  }
  return phase;
}

}  // namespace

// The walk is built in "walk coordinates", the body template's axes (x left, y up, z forward)
// fixed to the ground, and carried into the Z-up world by C = y_up_to_z_up() at the end:
// world = C walk, root orientation = C R_pelvis.
//
// Feet first: each foot follows a gait schedule (foot_target) with plants one stride apart, in
// step with a pelvis that moves forward at constant speed. A stance leg can hold the hip at
// most sqrt((kReach L)^2 - df^2) above its ankle (L the leg length, df the forward distance from
// hip to ankle); the lower of the stance legs' limits over the cycle is the reach envelope.
// The pelvis height is a raised cosine with its peaks at mid-stance of each leg,
//   height(s) = top - kBob (1 - cos(4 pi (s - s_mid))) / 2,
// with `top` as high as the envelope allows (found on 256 samples of the cycle), so the body
// vaults over each stance leg and never asks a leg for more than it has. Each leg is then solved
// exactly (two-link inverse kinematics in the sagittal plane, knee forward): with d the
// hip-ankle distance, the thigh leaves the hip-ankle line at the angle
//   a = acos((l1^2 + d^2 - l2^2) / (2 l1 d)),
// and the leg tilts sideways by delta about the forward axis so the ankle stays on its track
// while the pelvis sways. Local rotations follow from the desired orientations of the segments in
// walk coordinates, local = parent^-1 child, so pelvis yaw, roll and tilt do not disturb the feet.
// A planar angle g (rotation from forward toward up) is Rx(-g) in the body frame.
BodySequence synthetic_walk(int frames, double fps, BodyModelKind kind, unsigned seed) {
  if (frames < 1) throw std::invalid_argument("synthetic_walk needs at least one frame, got " + std::to_string(frames));
  if (!(fps > 0) || !std::isfinite(fps))
    throw std::invalid_argument("frame rate " + std::to_string(fps) + " is not positive");

  std::mt19937 random(seed);
  // A factor within 1 +- relative, from the raw 32-bit draws (distributions are not portable).
  auto vary = [&random](double relative) { return 1 + relative * (random() / 4294967296.0 * 2 - 1); };
  Gait gait;
  gait.speed = 1.2 * vary(0.06);
  gait.stride = 2 * 0.6 * vary(0.04);
  gait.plant_ahead = 0.25 * vary(0.05);
  gait.turn = vary(0.15);
  gait.arm_amplitude = vary(0.15);
  const double start_phase = vary(1.0) / 2;       // left leg phase at t = 0, in [0, 1)
  const double cycle = gait.stride / gait.speed;  // seconds

  BodySequence walk;
  walk.kind = kind;
  walk.fps = fps;
  walk.betas.assign(10, 0.0);
  const int joints = body_model_joint_count(kind);
  walk.poses = RowMatrixXd::Zero(frames, 3 * joints);
  walk.translations.resize(frames, 3);

  // Finger curl per hand, finger (index, middle, pinky, ring) and segment: base knuckle 0.25 rad,
  // middle 0.35, tip 0.2, each varied by 20 percent. SMPL has no fingers.
  const bool has_fingers = kind != BodyModelKind::SMPL;
  double curl[2][4][3] = {};
  for (auto& hand : curl) {
    for (auto& finger : hand) {
      finger[0] = 0.25 * vary(0.2);
      finger[1] = 0.35 * vary(0.2);
      finger[2] = 0.20 * vary(0.2);
    }
  }

  const double thigh = std::hypot(kThighDown, kThighForward), shin = std::hypot(kShinDown, kShinBack);
  const double thigh_rest_angle = std::atan2(-kThighDown, kThighForward);
  const double shin_rest_angle = std::atan2(-kShinDown, -kShinBack);

  // The pelvis is highest at mid-stance, when the stance ankle passes under the pelvis
  // (plant_ahead - stride s = 0), and as high as the reach envelope, sampled on 256 phases,
  // allows.
  const double peak_phase = gait.plant_ahead / gait.stride;
  const auto dip = [peak_phase](double s) { return kBob * (1 - std::cos(4 * kPi * (s - peak_phase))) / 2; };
  constexpr int kSamples = 256;
  double top = std::numeric_limits<double>::infinity();
  for (int k = 0; k < kSamples; ++k) {
    const double s = double(k) / kSamples;
    const GaitPhase phase = gait_phase(gait, s, thigh + shin);
    for (int side = 0; side < 2; ++side) {
      if (phase.stance[side]) top = std::min(top, phase.highest[side] + dip(s));
    }
  }

  const Eigen::Matrix3d c = y_up_to_z_up();
  const Eigen::Quaterniond upright(c);
  for (int f = 0; f < frames; ++f) {
    auto set = [&walk, f](int joint, const Eigen::Quaterniond& rotation) {
      walk.poses.row(f).segment<3>(3 * joint) = axis_angle_from_quaternion(rotation).transpose();
    };
    const double time = f / fps;
    double left_phase = time / cycle + start_phase;
    left_phase -= std::floor(left_phase);
    const GaitPhase phase = gait_phase(gait, left_phase, thigh + shin);
    const Eigen::Vector3d pelvis_position(phase.sway, top - dip(left_phase), gait.speed * time);

    set(kPelvis, upright * phase.pelvis);
    for (int side = 0; side < 2; ++side) {
      const double side_sign = side == 0 ? 1.0 : -1.0;
      const FootTarget& foot = phase.feet[side];
      const Eigen::Vector3d hip = pelvis_position + phase.hips[side];
      const double df = foot.forward + pelvis_position.z() - hip.z(), du = foot.up - hip.y();
      const double distance = std::min(std::hypot(df, du), (thigh + shin) * 0.9999);
      const double opening = std::acos(
          std::clamp((thigh * thigh + distance * distance - shin * shin) / (2 * thigh * distance), -1.0, 1.0));
      const double thigh_angle = std::atan2(du, df) + opening;
      const double knee_f = thigh * std::cos(thigh_angle), knee_u = thigh * std::sin(thigh_angle);  // from the hip
      const double shin_angle = std::atan2(du - knee_u, df - knee_f);
      // The ankle's track is its rest distance from the midline (hip, thigh and shin offsets).
      const double track = side_sign * (kHipLeft + kThighOut - kShinIn);
      const double natural = hip.x() + side_sign * (kThighOut - kShinIn);
      const double tilt = std::atan2(track - natural, hip.y() - foot.up);

      const Eigen::Quaterniond thigh_world = about(kZ, tilt) * about(kX, -(thigh_angle - thigh_rest_angle));
      const Eigen::Quaterniond shin_world = about(kZ, tilt) * about(kX, -(shin_angle - shin_rest_angle));
      const Eigen::Quaterniond foot_world = about(kX, foot.pitch);
      set(side == 0 ? kLeftHip : kRightHip, phase.pelvis.conjugate() * thigh_world);
      set(side == 0 ? kLeftKnee : kRightKnee, thigh_world.conjugate() * shin_world);
      set(side == 0 ? kLeftAnkle : kRightAnkle, shin_world.conjugate() * foot_world);
      // The toes stay on the ground while the heel is up, and follow the foot otherwise.
      set(side == 0 ? kLeftFoot : kRightFoot, about(kX, -std::max(foot.pitch, 0.0)));

      // The arm swings forward while the same-side leg is behind (the left most at s = 0.5),
      // hanging 77 degrees below horizontal, the elbow bending more as the arm comes forward.
      const double arm_swing = -0.35 * gait.arm_amplitude * std::cos(2 * kPi * (left_phase - 0.5 * side));
      set(side == 0 ? kLeftShoulder : kRightShoulder, about(kX, -arm_swing) * about(kZ, -side_sign * 1.35));
      set(side == 0 ? kLeftElbow : kRightElbow, about(kY, -side_sign * (0.3 + 0.15 * arm_swing / 0.35)));
      if (has_fingers) {
        const int first = side == 0 ? BodyParts::left_hand_first(kind) : BodyParts::right_hand_first(kind);
        for (int finger = 0; finger < 4; ++finger) {
          for (int segment = 0; segment < 3; ++segment) {
            set(first + 3 * finger + segment, about(kZ, -side_sign * curl[side][finger][segment]));
          }
        }
      }
    }

    // The spine takes back 1.2 times the pelvis yaw and all of its roll over three joints, so the
    // shoulders counter-rotate and the torso stays upright; the head takes back the tilt.
    for (int spine : {kSpine1, kSpine2, kSpine3}) set(spine, about(kY, -0.4 * phase.yaw) * about(kZ, -phase.roll / 3));
    set(kHead, about(kX, -kTilt));

    const Eigen::Vector3d translation = c * pelvis_position;
    walk.translations.row(f) << translation.x(), translation.y(), translation.z();
  }
  return walk;
}

}  // namespace odyssey
