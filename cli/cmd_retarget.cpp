// odyssey retarget: a motion (BVH, or an AMASS-style SMPL-X / SMPL-H sequence) onto a rigged
// glTF character, written as an animated GLB with an optional JSON report, and optionally a camera
// (static, orbit, ego-head) as an animated camera node in the GLB and as a camera path JSON: a
// scene of one actor run by the library pipeline (scene_layouts/pipeline.h). Nothing is written
// before every step has succeeded; the outputs are renamed into place together at the end.
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "cli/args.h"
#include "cli/camera_options.h"
#include "cli/commands.h"
#include "cli/retarget_options.h"
#include "scene_layouts/pipeline.h"

namespace odyssey::cli {

namespace fs = std::filesystem;

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
            "than 0.5 m/s, at the performer's size). By default (--bvh-units auto) the unit and the up axis\n"
            "are inferred from the skeleton's height, assuming a human performer, and printed ('units');\n"
            "a unit given explicitly wins.\n"
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

  scene::Scene scene;
  scene::SceneActor actor;
  scene::RetargetRequest request = retarget_request_from(args);
  actor.name = fs::path(request.character_path).stem().string();
  scene.fps = request.fps;
  scene.outputs.threads = request.refine_options.threads;
  actor.source = std::move(request);
  scene.actors.push_back(std::move(actor));
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
  if (const auto camera = camera_from_options(args)) scene.cameras.push_back(*camera);
  scene.outputs.glb = out_path;
  if (report_path) scene.outputs.actor_reports = {*report_path};
  if (camera_json_path) scene.outputs.camera_paths = {*camera_json_path};

  const scene::SceneResult result = scene::run_scene(scene, print_progress);
  const scene::RetargetedActor& retargeted = *result.actors[0].retargeted;
  std::printf("timings    %s, write %.3f s; total %.3f s\n", scene::actor_timings(retargeted).c_str(),
              result.seconds.total - result.seconds.retarget, result.seconds.total);
  const std::string camera_kind = result.cameras.empty() ? "" : result.cameras[0].path.kind;
  std::printf("wrote      %s (%d frames at %.6g fps, quality %s%s%s)%s%s%s%s\n", out_path.c_str(), result.frames,
              result.fps, retarget::quality_name(retargeted.request.quality), camera_kind.empty() ? "" : ", camera ",
              camera_kind.c_str(), report_path ? ", " : "", report_path ? report_path->c_str() : "",
              camera_json_path ? ", " : "", camera_json_path ? camera_json_path->c_str() : "");
  return 0;
}

}  // namespace odyssey::cli
