#include "cli/actor_options.h"

#include <cmath>
#include <cstdio>
#include <filesystem>

#include "cli/retarget_options.h"
#include "mocap_io/gltf_character.h"

namespace odyssey::cli {
namespace {

scene::PlaybackLength length_from(const Args& args) {
  scene::PlaybackLength length;
  if (args.has("loops")) {
    const long long loops = args.get_int("loops");
    if (loops < 1 || loops > 1'000'000) throw UsageError("--loops expects 1 to 1000000, got " + args.get("loops"));
    length.loops = static_cast<int>(loops);
  }
  if (args.has("seconds")) {
    if (length.loops) throw UsageError("give --loops or --seconds, not both");
    const double seconds = args.get_double("seconds");
    if (!(seconds >= 0 && seconds <= 1e6)) throw UsageError("--seconds expects 0 to 1000000, got " + args.get("seconds"));
    length.seconds = seconds;
  }
  return length;
}

double positive(const Args& args, const std::string& name) {
  const double value = args.get_double(name);
  if (!(value > 0) || !std::isfinite(value)) throw UsageError("--" + name + " expects a positive number, got " + args.get(name));
  return value;
}

}  // namespace

void add_actor_source_options(Args& args) {
  args.option("animation", "NAME", "play the character's own glTF animation NAME instead of retargeting a --motion")
      .flag("list-animations", "list the animations of --character and exit")
      .option("anime", "FILE", "a DeformingThings4D .anime mesh to play instead of a character (no --character)")
      .option("anime-fps", "FPS", "the .anime file's frame rate (the format stores none)", "30")
      .option("anime-up", "AXIS", "the .anime file's up axis: y (the dataset's) or z", "y")
      .option("loops", "N", "--animation or --anime: play N times (default: once)")
      .option("seconds", "S", "--animation or --anime: play for S seconds, looping")
      .option("scale", "S", "--animation or --anime: multiply lengths by S (the Fox is in centimetres: 0.01)", "1");
}

bool list_animations_if_asked(const Args& args) {
  if (!args.get_flag("list-animations")) return false;
  const std::string character = args.get("character");
  const io::GltfFileSummary summary = io::summarize_gltf_file(character);
  std::printf("%s: %zu animation%s\n", character.c_str(), summary.animations.size(), summary.animations.size() == 1 ? "" : "s");
  for (const io::GltfAnimationSummary& animation : summary.animations) {
    std::printf("  %-30s %8.4f s  (%.4f to %.4f s), %d channels, %zu keyframes\n", animation.name.c_str(), animation.duration(),
                animation.start, animation.end, animation.channels, animation.keyframes);
  }
  return true;
}

scene::SceneActor actor_from_options(const Args& args) {
  scene::SceneActor actor;
  const bool animation = args.has("animation"), anime = args.has("anime");
  if (animation && anime) throw UsageError("give --animation or --anime, not both");
  if ((animation || anime) && args.has("motion")) {
    throw UsageError(std::string("--") + (anime ? "anime" : "animation") + " plays its own motion: give no --motion");
  }
  if (!animation && !anime) {
    for (const char* name : {"loops", "seconds"}) {
      if (args.has(name)) throw UsageError(std::string("--") + name + " is for --animation or --anime");
    }
    if (args.has("scale")) throw UsageError("--scale is for --animation or --anime");
    scene::RetargetRequest request = retarget_request_from(args);
    actor.name = std::filesystem::path(request.character_path).stem().string();
    actor.source = std::move(request);
    return actor;
  }
  const double fps = positive(args, "fps");
  const double scale = positive(args, "scale");
  if (animation) {
    scene::AnimationRequest request;
    request.character_path = args.get("character");
    request.animation = args.get("animation");
    request.fps = fps;
    request.length = length_from(args);
    request.scale = scale;
    actor.name = std::filesystem::path(request.character_path).stem().string();
    actor.source = std::move(request);
    return actor;
  }
  if (args.has("character")) throw UsageError("--anime is the mesh: give no --character");
  scene::AnimeRequest request;
  request.path = args.get("anime");
  request.source_fps = positive(args, "anime-fps");
  const std::string up = args.get("anime-up");
  if (up != "y" && up != "z") throw UsageError("--anime-up expects y or z, got '" + up + "'");
  request.up_z = up == "z";
  request.fps = fps;
  request.length = length_from(args);
  request.scale = scale;
  actor.name = std::filesystem::path(request.path).stem().string();
  actor.source = std::move(request);
  return actor;
}

int thread_count(const Args& args) {
  const long long threads = args.get_int("threads");
  if (threads < 1 || threads > 1024) throw UsageError("--threads expects 1 to 1024, got " + std::to_string(threads));
  return static_cast<int>(threads);
}

std::string actor_timings_line(const scene::PlacedActor& actor) {
  if (actor.retargeted) return scene::actor_timings(*actor.retargeted);
  char line[128];
  std::snprintf(line, sizeof line, "%s %.3f s", actor.motion->kind == scene::ActorSourceKind::anime ? "read anime" : "play animation",
                actor.motion->seconds_to_build);
  return line;
}

}  // namespace odyssey::cli
