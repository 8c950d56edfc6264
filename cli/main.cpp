// odyssey: motion retargeting and animation toolkit. Thin dispatch to the subcommands.
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include "cli/args.h"
#include "cli/commands.h"
#include "mocap_io/input_error.h"
#include "mocap_io/output_file.h"

namespace {

struct Command {
  const char* name;
  const char* summary;
  int (*run)(const std::vector<std::string>&);
};

constexpr Command kCommands[] = {
    {"demo", "run the main job on the bundled body model, mocap clip and character", odyssey::cli::run_demo},
    {"inspect", "summarise a BVH, AMASS, body model or npz/npy file", odyssey::cli::run_inspect},
    {"pose", "evaluate a body model on a motion (or a BVH skeleton) and write per-frame joints/vertices",
     odyssey::cli::run_pose},
    {"make-body", "write a synthetic SMPL-X body model in the smplx npz layout", odyssey::cli::run_make_body},
    {"retarget", "retarget a BVH or AMASS motion onto a rigged glTF character, write an animated GLB and a report",
     odyssey::cli::run_retarget},
    {"trajectories", "retarget, then write tracked surface points, their pixels and the cameras as an annotation npz",
     odyssey::cli::run_trajectories},
    {"point-cache", "retarget, then write the deformed mesh every frame as a PC2 point cache with its rest OBJ",
     odyssey::cli::run_point_cache},
    {"scene", "run a scene file: several actors, props and cameras in one shot; tracks, caches, cameras, report",
     odyssey::cli::run_scene},
    {"render", "render a sequence folder's RGB frames (rgbs/) with Blender's Cycles from the shot's scene.glb",
     odyssey::cli::run_render},
    {"batch", "retarget motion libraries onto character libraries (or a manifest's jobs): parallel, resumable, sharded",
     odyssey::cli::run_batch},
    {"batch-report", "merge the journals of a batch's shards into one report", odyssey::cli::run_batch_report},
    {"dataset", "make a dataset from a recipe: sampled shots as PointOdyssey sequences, split, resumable, sharded",
     odyssey::cli::run_dataset},
    {"dataset-report", "write a dataset's manifest from the journals of its shards", odyssey::cli::run_dataset_report},
};

void print_usage(std::FILE* stream) {
  std::fputs("usage: odyssey COMMAND [options]   (odyssey COMMAND --help for details)\n\ncommands:\n", stream);
  for (const Command& command : kCommands) std::fprintf(stream, "  %-12s %s\n", command.name, command.summary);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    print_usage(stderr);
    return 2;
  }
  const std::string name = argv[1];
  if (name == "--help" || name == "-h" || name == "help") {
    print_usage(stdout);
    return 0;
  }
  const std::vector<std::string> arguments(argv + 2, argv + argc);
  // Ctrl-C or a scheduler's SIGTERM leaves no staged file behind.
  odyssey::io::install_interrupt_cleanup();
  for (const Command& command : kCommands) {
    if (name != command.name) continue;
    try {
      return command.run(arguments);
    } catch (const odyssey::cli::UsageError& error) {
      std::fprintf(stderr, "odyssey %s: %s (see odyssey %s --help)\n", command.name, error.what(), command.name);
      return 2;
    } catch (const odyssey::io::InputError& error) {
      std::fprintf(stderr, "odyssey %s: %s\n", command.name, error.what());
      return 1;
    } catch (const std::exception& error) {
      std::fprintf(stderr, "odyssey %s: error: %s\n", command.name, error.what());
      return 1;
    }
  }
  std::fprintf(stderr, "odyssey: unknown command '%s'\n", name.c_str());
  print_usage(stderr);
  return 2;
}
