// odyssey point-cache: the full deformed mesh of a retargeted character every frame, as a PC2
// point cache (Blender's Mesh Cache modifier) with the rest mesh as OBJ beside it, so the vertex
// order is unambiguous: vertices across the character's meshes in order, in the toolkit's world
// frame (Z up, metres). A scene of one actor and no camera, run by the library pipeline.
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "cli/actor_options.h"
#include "cli/args.h"
#include "cli/commands.h"
#include "cli/retarget_options.h"
#include "scene_layouts/pipeline.h"

namespace odyssey::cli {

int run_point_cache(const std::vector<std::string>& arguments) {
  Args args("point-cache",
            "Retarget a motion onto a character (the options and steps of odyssey retarget) and write its\n"
            "deformed mesh every frame as a PC2 point cache, with the rest mesh as a Wavefront OBJ whose\n"
            "vertex order the cache follows (all meshes in order; world frame, Z up, metres: in Blender import\n"
            "the OBJ with Z up and Y forward and give the Mesh Cache modifier the same axes). Frames are\n"
            "skinned and written in chunks: memory does not grow with the clip.");
  add_retarget_options(args);
  add_actor_source_options(args);
  args.option("out", "FILE", "output PC2 point cache (required)")
      .option("obj", "FILE", "the rest mesh (default: the --out path with .obj)");
  if (!args.parse(arguments)) return 0;
  if (list_animations_if_asked(args)) return 0;

  scene::Scene scene;
  scene::SceneActor actor = actor_from_options(args);
  const scene::RetargetRequest* motion = std::get_if<scene::RetargetRequest>(&actor.source);
  scene.fps = motion ? motion->fps : args.get_double("fps");
  scene.outputs.threads = motion ? motion->refine_options.threads : thread_count(args);
  scene.actors.push_back(std::move(actor));
  const std::string out_path = args.get("out");
  const std::string obj_path =
      args.get_optional("obj").value_or(std::filesystem::path(out_path).replace_extension(".obj").string());
  if (std::filesystem::absolute(obj_path) == std::filesystem::absolute(out_path)) {
    throw UsageError("--obj and --out name the same file");
  }
  scene.outputs.point_caches = {out_path};
  scene.outputs.rest_objs = {obj_path};

  const scene::SceneResult result = scene::run_scene(scene, print_progress);
  std::size_t vertices = 0;
  for (const CharacterMesh& mesh : result.actors[0].motion->character.meshes) vertices += mesh.positions.size();
  const double seconds = result.seconds.streams;
  std::printf("cache      %zu vertices x %d frames in %.3f s (%.0f frames/s, %.3g vertex-frames/s: skinning and writing)\n",
              vertices, result.frames, seconds, seconds > 0 ? result.frames / seconds : 0.0,
              seconds > 0 ? vertices * result.frames / seconds : 0.0);
  std::printf("timings    %s\n", actor_timings_line(result.actors[0]).c_str());
  std::printf("wrote      %s (%d frames at %.6g fps), %s\n", out_path.c_str(), result.frames, result.fps, obj_path.c_str());
  return 0;
}

}  // namespace odyssey::cli
