// odyssey render: a sequence folder's RGB frames, rgbs/rgb_%05d.jpg, rendered by Blender (Cycles
// on the CPU, headless) from the shot's scene.glb through the sequence's own cameras. The work is
// render/blender_render.h's; this parses the command line and prints.
#include <algorithm>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli/args.h"
#include "cli/commands.h"
#include "render/blender_render.h"

namespace odyssey::cli {

int run_render(const std::vector<std::string>& arguments) {
  Args args("render",
            "Render the RGB frames of a sequence folder that `odyssey scene --layout pointodyssey` wrote, with\n"
            "Blender's Cycles on the CPU (Blender runs headless: $ODYSSEY_BLENDER, else `blender` on PATH). It\n"
            "renders the shot's scene.glb, beside the sequence folder (ask for it with \"glb\": true in the\n"
            "scene's outputs), through a camera at every frame's extrinsics and intrinsics from anno.npz, lit\n"
            "by a sun and a sky-coloured world, and writes SEQUENCE_DIR/rgbs/rgb_%05d.jpg: frame k is frame k\n"
            "of the annotations (time k / fps of scene.glb). rgbs/ appears when every frame is written and\n"
            "replaces an earlier rgbs/ whole, only then (a range of frames replaces it with that range).");
  args.positional("SEQUENCE_DIR", "a sequence folder (DIR/<scene>_<camera>/ with anno.npz and scene_info.json)")
      .option("samples", "N", "Cycles samples per pixel", "64")
      .option("scale", "F", "image size = the camera's size (scene_info.json) x F, rounded", "1")
      .option("frames", "A:B", "render frames A to B - 1 (a Python slice: A defaults to 0, B to the end), or K alone");
  if (!args.parse(arguments)) return 0;

  render::RenderJob job;
  job.sequence = render::read_sequence(args.get("SEQUENCE_DIR"));
  job.samples = static_cast<int>(std::min<long long>(args.get_int("samples"), 1LL << 30));
  job.scale = args.get_double("scale");
  if (const auto frames = args.get_optional("frames")) {
    try {
      job.frames = render::parse_frame_range(*frames, job.sequence.frames);
    } catch (const std::invalid_argument& error) {
      throw UsageError(error.what());
    }
  } else {
    job.frames = {0, job.sequence.frames};
  }
  if (const std::string problem = job.validate(); !problem.empty()) throw UsageError(problem);
  job.blender = render::find_blender();
  const int count = job.frames.end - job.frames.first;
  std::printf("render     %s: camera %s, frames %d to %d of %d, %dx%d, %d samples (Blender, Cycles on the CPU)\n",
              job.sequence.folder.c_str(), job.sequence.camera.c_str(), job.frames.first, job.frames.end - 1,
              job.sequence.frames, job.width(), job.height(), job.samples);
  std::fflush(stdout);
  int done = 0;
  job.on_frame = [&](int frame) {
    ++done;
    std::fprintf(stderr, "\rframe      %d (%d of %d)", frame, done, count);
    std::fflush(stderr);
  };
  const auto end_progress_line = [&] {
    if (done > 0) std::fputs("\n", stderr);
  };
  render::RenderResult result;
  try {
    result = job.run();
  } catch (...) {
    end_progress_line();  // the error goes on a line of its own
    throw;
  }
  end_progress_line();
  std::printf("wrote      %s: %d frames at %dx%d in %.1f s (%.2f s a frame, Blender's start and import included)\n",
              result.folder.c_str(), result.frames, result.width, result.height, result.seconds,
              result.seconds / result.frames);
  return 0;
}

}  // namespace odyssey::cli
