// odyssey scene: runs a scene file (several actors, props and cameras in one shot) through the
// library pipeline and writes its outputs into a folder.
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "cli/args.h"
#include "cli/commands.h"
#include "cli/retarget_options.h"
#include "scene_layouts/pipeline.h"
#include "scene_layouts/scene_file.h"

namespace odyssey::cli {

int run_scene(const std::vector<std::string>& arguments) {
  if (arguments.size() == 1 && arguments[0] == "--example") {
    std::fputs(scene::example_scene_json().c_str(), stdout);
    return 0;
  }
  Args args("scene",
            "Run a scene file: actors (a BVH or AMASS motion retargeted onto a glTF character, placed on the\n"
            "floor and in time), props (ground planes, boxes, glTF/GLB/OBJ meshes) and cameras (static, orbit,\n"
            "ego on an actor's head, or a camera path file), and write into --out what its \"outputs\" ask for:\n"
            "  trajectories_<camera>.npz  tracked points on every actor and prop seen by that camera (the\n"
            "                             dataset's keys, visibility against every actor and prop, and\n"
            "                             visibility_codes: 0 visible, 1 occluded by an actor, 2 by a prop,\n"
            "                             3 outside the image, 4 behind the camera)\n"
            "  camera_<camera>.json       the camera path\n"
            "  point_cache_<actor>.pc2    the actor's mesh every frame, with its rest .obj\n"
            "  retarget_<actor>.json      the actor's retargeting report\n"
            "  report.json                the scene's report: placements, visibility figures, work skipped\n"
            "odyssey scene --example prints a documented scene that runs as printed from any folder; the\n"
            "docs/scenes.md documents every key. On any error nothing is written.");
  args.positional("SCENE", "the scene file (JSON)")
      .option("out", "DIR", "output folder (created when missing; required)")
      .option("layout", "files|pointodyssey",
              "files: trajectories_<camera>.npz beside the other outputs; pointodyssey: one sequence folder per\n"
              "camera, <scene>_<camera>/ (anno.npz, info.npz, depths/, normals/, masks/, scene_info.json; the dense\n"
              "maps as the scene's outputs ask: depth, normals, masks; docs/sequences.md) (default: the scene file's)")
      .flag("example", "print an example scene file and stop")
      .flag("quiet", "print only the closing summary");
  if (!args.parse(arguments)) return 0;
  if (args.get_flag("example")) {
    std::fputs(scene::example_scene_json().c_str(), stdout);
    return 0;
  }
  const std::string out = args.get("out");
  scene::SceneFile file = scene::read_scene_file(args.get("SCENE"));
  if (args.has("layout")) {
    const std::string layout = args.get("layout");
    if (layout != "files" && layout != "pointodyssey") throw UsageError("--layout expects files or pointodyssey, got '" + layout + "'");
    file.outputs.layout = layout == "files" ? scene::OutputSelection::Layout::files : scene::OutputSelection::Layout::pointodyssey;
  }
  // A run that fails leaves no folder it made (the outputs go in only when all are ready).
  std::error_code ignored;
  const bool made = !std::filesystem::exists(out, ignored);
  std::filesystem::create_directories(out);
  struct RemoveIfEmpty {
    std::string folder;
    bool armed;
    ~RemoveIfEmpty() {
      std::error_code error;
      if (armed && std::filesystem::is_empty(folder, error) && !error) std::filesystem::remove(folder, error);
    }
  } cleanup{out, made};
  scene::set_outputs_in_folder(file.scene, out, file.outputs);
  const bool quiet = args.get_flag("quiet");
  const bool interactive = ::isatty(STDOUT_FILENO) != 0;
  const scene::SceneResult result = scene::run_scene(file.scene, [&](const scene::ProgressEvent& event) {
    if (quiet && event.stage != "warning") return;
    if (event.stage == "export") {
      // On a terminal one line redrawn in place; in a log a line each tenth of the shot.
      static long last_tenth = -1;
      const long tenth = event.total > 0 ? 10 * event.done / event.total : 10;
      if (interactive) {
        std::printf("\rframes     %ld of %ld%s", event.done, event.total, event.done == event.total ? "\n" : "");
      } else if (tenth != last_tenth) {
        std::printf("frames     %ld of %ld\n", event.done, event.total);
      }
      last_tenth = tenth;
    } else if (event.stage == "bone_maps" || event.stage == "retarget") {
      std::printf("%-10s %s\n", event.stage == "retarget" ? "retarget" : "maps", event.message.c_str());
    } else {
      print_progress(event);
    }
    std::fflush(stdout);
  });
  cleanup.armed = false;
  std::printf("scene      %s: %zu actor(s), %zu prop(s), %zu camera(s), %d frames at %.6g fps\n", result.name.c_str(),
              result.actors.size(), result.props.names.size(), result.cameras.size(), result.frames, result.fps);
  for (const scene::PlacedActor& actor : result.actors) {
    std::printf("actor      %s: at (%.3f, %.3f) facing %.1f deg, %d points\n", actor.name.c_str(), actor.x, actor.y,
                actor.yaw_deg, actor.points);
  }
  for (const scene::CameraStreamSummary& camera : result.streams.cameras) {
    std::printf("camera     %s: point-frames %.1f%% valid, %.1f%% visible, %.1f%% hidden by actors, %.1f%% by props\n",
                camera.name.c_str(), 100 * camera.valid_fraction, 100 * camera.visible_fraction,
                100 * camera.occluded_by_actor_fraction, 100 * camera.occluded_by_prop_fraction);
  }
  for (const std::string& line : result.skipped) std::printf("skipped    %s\n", line.c_str());
  for (const std::string& line : result.notes) std::printf("note       %s\n", line.c_str());
  std::printf("timings    retarget %.3f s, frames %.3f s (%.0f frames/s), total %.3f s\n", result.seconds.retarget,
              result.seconds.streams, result.seconds.streams > 0 ? result.frames / result.seconds.streams : 0.0,
              result.seconds.total);
  std::printf("wrote      %zu outputs into %s\n", result.outputs.size(), out.c_str());
  return 0;
}

}  // namespace odyssey::cli
