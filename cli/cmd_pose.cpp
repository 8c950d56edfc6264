// odyssey pose: evaluate a body model over a motion, or a BVH skeleton over its own motion, and
// write per-frame joints (and vertices) to an npz. Frames are evaluated and written in chunks,
// so memory stays flat however long the sequence is.
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli/args.h"
#include "cli/commands.h"
#include "cli/motion_file.h"
#include "mocap_io/motion_file.h"
#include "mocap_io/amass.h"
#include "mocap_io/body_model_file.h"
#include "mocap_io/bvh.h"
#include "mocap_io/input_error.h"
#include "mocap_io/input_file.h"
#include "mocap_io/output_file.h"
#include "mocap_io/pose_export.h"
#include "skeleton/pose_layout.h"

namespace odyssey::cli {

int run_pose(const std::vector<std::string>& arguments) {
  Args args("pose",
            "Evaluate a body model on an AMASS-style sequence and write per-frame `joints` [T,J,3] and\n"
            "`vertices` [T,V,3] (float32, metres, the sequence's Z-up world), plus `faces`, `fps`,\n"
            "`joint_names` and `parents`. Given a BVH as --motion (no model needed) it writes the\n"
            "per-frame world `joints` [T,J,3] in metres, Z up, with `joint_names`, `parents` and `fps`.");
  args.option("model", "FILE", "SMPL-X / SMPL-H / SMPL body model npz (smplx package layout)")
      .option("motion", "FILE", "AMASS-style npz sequence or BVH file")
      .option("out", "FILE", "output npz")
      .option("fps", "FPS", "resample the motion to this frame rate (default: keep the motion's own)")
      .flag("no-hands", "finger joints keep their rest rotation (hand poses ignored)")
      .flag("no-face", "jaw and eyes keep their rest rotation, expression ignored")
      .flag("no-correctives", "skip the pose-corrective blend shapes")
      .flag("joints-only", "write joints only, skip the mesh")
      .option("threads", "N", "threads evaluating the mesh (default: every core; the output is the same whatever N)");
  add_bvh_units_option(args);
  add_betas_option(args);
  if (!args.parse(arguments)) return 0;
  const BetasPolicy policy = betas_policy(args);

  const std::string motion_path = args.get("motion");
  const std::string out_path = args.get("out");
  io::require_replaceable_output(out_path);
  io::require_not_an_input(out_path, {motion_path, args.has("model") ? args.get("model") : std::string()});
  std::optional<double> fps;
  if (args.has("fps")) {
    fps = args.get_double("fps");
    if (!(*fps > 0)) throw UsageError("--fps must be positive");
  }

  if (io::detect_motion_file(motion_path) == io::MotionFileKind::Bvh) {
    io::LoadedBvh loaded = io::load_bvh_inferring_frame(motion_path, bvh_metres_per_unit(args));
    std::printf("units: %s\n", loaded.frame.description().c_str());
    if (!loaded.frame.plausible) std::fprintf(stderr, "warning: %s\n", loaded.frame.warning(motion_path).c_str());
    Clip clip = std::move(loaded.clip);
    if (fps) io::require_frames_within_cap(motion_path, clip.frame_count(), clip.fps, *fps);
    if (fps) clip = clip.resampled(*fps);
    io::export_clip_joints(clip, out_path);
    std::printf("wrote %s: %d frames at %.6g fps, %d joints\n", out_path.c_str(), clip.frame_count(), clip.fps,
                clip.joint_count());
    return 0;
  }

  const std::string model_path = args.get("model");
  const BodyModel model = io::load_body_model(model_path);
  BodySequence sequence = io::load_amass_file(motion_path).sequence;
  if (sequence.frame_count() < 1) throw io::InputError(motion_path, "the sequence has no frames");
  if (fps) io::require_frames_within_cap(motion_path, sequence.frame_count(), sequence.fps, *fps);
  if (fps) sequence = sequence.resampled(*fps);
  sequence = sequence_for_model(sequence, model.kind);
  BetasFit betas;
  try {
    betas = fit_betas(model, sequence.betas, policy);
  } catch (const std::invalid_argument& error) {
    throw io::InputError(motion_path, std::string(error.what()) + " (model " + model_path + ")");
  }
  if (betas.dropped > 0) std::fprintf(stderr, "warning: %s: %s\n", motion_path.c_str(), betas.warning().c_str());
  std::printf("betas %s\n", betas.summary().c_str());
  sequence.betas = betas.betas;

  BodyModelOptions options;
  options.hands = !args.get_flag("no-hands");
  options.face = !args.get_flag("no-face");
  options.pose_correctives = !args.get_flag("no-correctives");
  const bool joints_only = args.get_flag("joints-only");
  int threads = 0;
  if (args.has("threads")) {
    const long long requested = args.get_int("threads");
    if (requested < 1 || requested > 1024) throw UsageError("--threads must be between 1 and 1024");
    threads = static_cast<int>(requested);
  }
  io::export_body_poses(model, sequence, options, joints_only, out_path, threads);
  std::printf("wrote %s: %d frames at %.6g fps, %d joints", out_path.c_str(), sequence.frame_count(), sequence.fps,
              model.joint_count());
  if (!joints_only) std::printf(", %d vertices", model.vertex_count());
  std::printf("\n");
  return 0;
}

}  // namespace odyssey::cli
