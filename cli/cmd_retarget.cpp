// odyssey retarget: a motion (BVH, or an AMASS-style SMPL-X / SMPL-H sequence) onto a rigged
// glTF character, written as an animated GLB with an optional JSON report, and optionally a camera
// (static, orbit, ego-head) as an animated camera node in the GLB and as a camera path JSON.
//
// The steps are cli/retarget_job.h's, shared with the commands that write trajectories and point
// caches. Nothing is written before every step has succeeded, and the outputs are staged under
// temporary names beside their destinations and renamed together at the end, so a failure at any
// point leaves none of them behind.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "cli/args.h"
#include "cli/camera_options.h"
#include "cli/commands.h"
#include "cli/retarget_job.h"
#include "cli/staged_file.h"
#include "mocap_io/camera_path_file.h"
#include "mocap_io/gltf_export.h"

namespace odyssey::cli {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

}  // namespace

int run_retarget(const std::vector<std::string>& arguments) {
  Args args("retarget",
            "Retarget a motion onto a rigged glTF/GLB character and write an animated GLB: the character's\n"
            "meshes, skins and materials with one animation (a rotation channel per joint, translation on\n"
            "the root and on joints placed by position, LINEAR, continuous quaternion signs).\n"
            "\n"
            "The motion is a BVH file (source bone map: the CMU preset when it fits, else detected from\n"
            "joint names) or an AMASS-style SMPL-X / SMPL-H / SMPL npz sequence, posed on the body model\n"
            "given by --model, or, without --model, on the synthetic SMPL-X body (odyssey make-body --seed 0).\n"
            "The target bone map is a preset that fits the character or detected from its joint names;\n"
            "--map and --source-map take JSON maps ({\"joints\": {\"left_knee\": \"Knee.L\", ...}}, null\n"
            "unmaps) applied over what was found. A character that is not a humanoid (a four-legged Fox, a\n"
            "skinned cylinder) is an error naming the file and the joints missing, exit code 1.\n"
            "\n"
            "The height scale makes the motion's skeleton as tall as the character's (report: scale), so a\n"
            "BVH length unit changes only where foot contacts are found (5 cm above the fitted floor, slower\n"
            "than 0.5 m/s, at the performer's size): give --bvh-units cmu for the CMU conversions.\n"
            "\n"
            "With --camera the GLB also holds an animated camera node (a static, orbiting or head-mounted\n"
            "camera; see odyssey trajectories), and --camera-path writes the same camera as JSON.\n"
            "\n"
            "Prints the map used, every unmapped joint, the height scale, metrics and timings. On any error\n"
            "nothing is written: the outputs are renamed into place only when all are complete.");
  add_retarget_options(args);
  args.option("out", "FILE", "output animated GLB (required)")
      .option("report", "FILE",
              "write a JSON report: inputs, settings (every refinement weight), the map used, unmapped joints, "
              "scale, alignment, contacts, metrics of the source and the result, timings (default: none)")
      .option("camera-path", "FILE", "also write the camera (--camera) as a camera path JSON (default: none)");
  add_camera_options(args, "none");
  if (!args.parse(arguments)) return 0;

  const auto total_start = Clock::now();
  const RetargetSettings settings = retarget_settings(args);
  const std::string out_path = args.get("out");
  const std::optional<std::string> report_path = args.get_optional("report");
  const std::optional<std::string> camera_json_path = args.get_optional("camera-path");
  for (const auto& other : {report_path, camera_json_path}) {
    if (other && fs::absolute(*other) == fs::absolute(out_path)) throw UsageError("two outputs name the same file");
  }
  if (report_path && camera_json_path && fs::absolute(*report_path) == fs::absolute(*camera_json_path)) {
    throw UsageError("--report and --camera-path name the same file");
  }
  if (camera_json_path && args.get("camera") == "none") throw UsageError("--camera-path needs a --camera");

  RetargetJob job = run_retarget_job(settings);
  const std::optional<CameraPath> camera = camera_path_from_options(args, job.character, job.target_map, job.clip());

  auto start = Clock::now();
  StagedFile glb(out_path);
  io::GlbExportOptions export_options;
  export_options.animation_name = fs::path(settings.motion_path).stem().string();
  if (camera) export_options.camera = &*camera;
  io::write_animated_glb(settings.character_path, job.character, job.clip(), glb.temp(), export_options);
  std::optional<StagedFile> camera_json;
  if (camera_json_path) {
    camera_json.emplace(*camera_json_path);
    io::write_camera_path_json(camera_json->temp(), *camera);
  }
  const double write_seconds = seconds_since(start);
  const double total_seconds = seconds_since(total_start);

  std::optional<StagedFile> report_file;
  if (report_path) {
    nlohmann::ordered_json json = retarget_job_report(job);
    json["inputs"]["output"] = out_path;
    json["settings"]["camera"] = camera ? nlohmann::ordered_json(camera->kind) : nlohmann::ordered_json();
    json["timings_s"]["command"]["write_outputs"] = write_seconds;
    json["timings_s"]["command"]["total"] = total_seconds;
    report_file.emplace(*report_path);
    report_file->write_text(json.dump(2) + "\n");
  }
  std::vector<StagedFile*> outputs{&glb};
  if (camera_json) outputs.push_back(&*camera_json);
  if (report_file) outputs.push_back(&*report_file);
  commit_all(outputs);

  std::printf("timings    %s, write %.3f s; total %.3f s\n", retarget_job_timings(job).c_str(), write_seconds,
              total_seconds);
  std::printf("wrote      %s (%d frames at %.6g fps, quality %s%s%s)%s%s%s%s\n", out_path.c_str(), job.clip().frame_count(),
              job.clip().fps, retarget::quality_name(settings.quality), camera ? ", camera " : "",
              camera ? camera->kind.c_str() : "", report_path ? ", " : "", report_path ? report_path->c_str() : "",
              camera_json_path ? ", " : "", camera_json_path ? camera_json_path->c_str() : "");
  return 0;
}

}  // namespace odyssey::cli
