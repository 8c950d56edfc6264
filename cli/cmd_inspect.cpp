// odyssey inspect FILE: what a file is and what it holds, without converting anything.
#include <cstdio>
#include <filesystem>
#include <string>

#include "cli/args.h"
#include "cli/commands.h"
#include "cli/motion_file.h"
#include "mocap_io/motion_file.h"
#include "mocap_io/amass.h"
#include "mocap_io/body_model_file.h"
#include "mocap_io/bvh.h"
#include "mocap_io/npy.h"

namespace odyssey::cli {
namespace {

std::string shape_text(const std::vector<std::size_t>& shape) {
  std::string text = "(";
  for (std::size_t i = 0; i < shape.size(); ++i) text += (i ? ", " : "") + std::to_string(shape[i]);
  return text + (shape.size() == 1 ? ",)" : ")");
}

void print_joints(const std::vector<std::string>& names, const std::vector<int>& parents) {
  std::printf("joints: %zu\n", names.size());
  for (std::size_t j = 0; j < names.size(); ++j) {
    std::printf("  %3zu  %-24s parent %s\n", j, names[j].c_str(), parents[j] < 0 ? "-" : names[parents[j]].c_str());
  }
}

void inspect_bvh(const std::string& path, double metres_per_unit) {
  const Clip clip = io::load_bvh(path, io::BvhOptions{metres_per_unit});
  std::printf("file: %s\nkind: BVH motion (converted to Z up, %.6g m per unit)\n", path.c_str(), metres_per_unit);
  std::printf("frames: %d\nfps: %.6g\nduration: %.3f s\n", clip.frame_count(), clip.fps, clip.duration());
  std::printf("joints with animated translation:");
  for (int joint : clip.translated_joints) std::printf(" %s", clip.skeleton.name(joint).c_str());
  std::printf("\n");
  print_joints(clip.skeleton.names(), clip.skeleton.parents());
}

void inspect_body_model(const std::string& path) {
  const BodyModel model = io::load_body_model(path);
  std::printf("file: %s\nkind: %s body model\n", path.c_str(), body_model_kind_name(model.kind));
  std::printf("vertices: %d\nfaces: %lld\n", model.vertex_count(), static_cast<long long>(model.faces.rows()));
  std::printf("shape directions: %d\nexpression directions: %d\npose-corrective directions: %lld\n", model.shape_count,
              model.expression_count, static_cast<long long>(model.posedirs.cols()));
  std::printf("hand PCA components: %lld per hand\n", static_cast<long long>(model.hands_components_left.rows()));
  print_joints(model.joint_names, model.parents);
}

void inspect_amass(const std::string& path) {
  const io::AmassFile file = io::load_amass_file(path);
  const BodySequence& sequence = file.sequence;
  std::printf("file: %s\nkind: AMASS %s sequence (%d pose numbers a frame)\n", path.c_str(),
              body_model_kind_name(sequence.kind), static_cast<int>(sequence.poses.cols()));
  std::printf("frames: %d\nfps: %.6g\nduration: %.3f s\ngender: %s\nbetas: %zu\n", sequence.frame_count(), sequence.fps,
              sequence.frame_count() > 0 ? (sequence.frame_count() - 1) / sequence.fps : 0.0,
              sequence.gender.empty() ? "(none)" : sequence.gender.c_str(), sequence.betas.size());
  std::printf("keys skipped:");
  if (file.skipped_keys.empty()) std::printf(" none");
  for (const std::string& key : file.skipped_keys) std::printf(" %s", key.c_str());
  std::printf("\n");
}

void inspect_npz(const std::string& path) {
  const io::NpzReader archive(path);
  std::printf("file: %s\nkind: npz archive\narrays:\n", path.c_str());
  for (const std::string& key : archive.keys()) {
    const io::NpyHeader header = archive.header(key);
    std::printf("  %-28s %-8s %s%s\n", key.c_str(), io::dtype_name(header.dtype), shape_text(header.shape).c_str(),
                header.dtype == io::DType::Object ? "  (pickled objects: not loaded)" : "");
  }
}

void inspect_npy(const std::string& path) {
  const io::NpyArray array = io::read_npy(path);
  std::printf("file: %s\nkind: npy array\ndtype: %s\nshape: %s\n", path.c_str(), io::dtype_name(array.dtype()),
              shape_text(array.shape()).c_str());
}

}  // namespace

int run_inspect(const std::vector<std::string>& arguments) {
  Args args("inspect", "Summarise a motion, body model or array file: its kind, joints with parents, frames, fps,\n"
                       "gender, array shapes, and the keys that were skipped.");
  args.positional("FILE", "a .bvh, AMASS .npz, body model .npz, other .npz, or .npy file");
  add_bvh_units_option(args);
  if (!args.parse(arguments)) return 0;
  const std::string path = args.get("FILE");
  switch (io::detect_motion_file(path)) {
    case io::MotionFileKind::Bvh: inspect_bvh(path, bvh_metres_per_unit(args)); break;
    case io::MotionFileKind::BodyModel: inspect_body_model(path); break;
    case io::MotionFileKind::Amass: inspect_amass(path); break;
    case io::MotionFileKind::Npz: inspect_npz(path); break;
    case io::MotionFileKind::Npy: inspect_npy(path); break;
  }
  return 0;
}

}  // namespace odyssey::cli
