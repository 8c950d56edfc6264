// odyssey inspect FILE: what a file is and what it holds, without converting anything.
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <optional>
#include <string>

#include "cli/args.h"
#include "cli/commands.h"
#include "cli/motion_file.h"
#include "mocap_io/motion_file.h"
#include "mocap_io/amass.h"
#include "mocap_io/body_model_file.h"
#include "mocap_io/bvh.h"
#include "mocap_io/gltf_character.h"
#include "mocap_io/npy.h"
#include "retarget/bone_map.h"
#include "retarget/canonical.h"
#include "retarget/rest_pose.h"

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

void inspect_bvh(const std::string& path, std::optional<double> metres_per_unit) {
  const io::LoadedBvh loaded = io::load_bvh_inferring_frame(path, metres_per_unit);
  const Clip& clip = loaded.clip;
  std::printf("file: %s\nkind: BVH motion (converted to Z up, %.6g m per unit)\n", path.c_str(), loaded.frame.metres_per_unit);
  std::printf("units: %s\n", loaded.frame.description().c_str());
  if (!loaded.frame.plausible) std::fprintf(stderr, "warning: %s\n", loaded.frame.warning(path).c_str());
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

bool is_gltf_path(const std::string& path) {
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return extension == ".glb" || extension == ".gltf";
}

std::string drop_text(const std::optional<double>& drop) {
  if (!drop) return "not mapped";
  char text[32];
  std::snprintf(text, sizeof text, "%.1f deg", *drop);
  return text;
}

// A character: skins, meshes, joints with parents and the canonical joint each plays, animations,
// rest height, rest pose kind and the bone map a retarget would use (or why there is none).
void inspect_character(const std::string& path) {
  const Character character = io::load_character(path);
  const io::GltfFileSummary summary = io::summarize_gltf_file(path);
  const Skeleton& rig = character.skeleton;
  std::printf("file: %s\nkind: glTF character\n", path.c_str());

  std::printf("skins: %zu\n", summary.skins.size());
  for (const io::GltfSkinSummary& skin : summary.skins) std::printf("  %-28s %d joints\n", skin.name.c_str(), skin.joint_count);

  std::size_t total_vertices = 0, total_triangles = 0;
  for (const CharacterMesh& mesh : character.meshes) {
    total_vertices += mesh.positions.size();
    total_triangles += mesh.triangles.size() / 3;
  }
  std::printf("meshes: %zu (%zu vertices, %zu triangles in all)\n", character.meshes.size(), total_vertices,
              total_triangles);
  for (const CharacterMesh& mesh : character.meshes) {
    std::printf("  %-28s %6zu vertices %6zu triangles  %s\n", mesh.name.c_str(), mesh.positions.size(),
                mesh.triangles.size() / 3,
                mesh.skin_joints.size() == 1 ? ("rigid on " + rig.name(mesh.skin_joints[0])).c_str()
                                             : (std::to_string(mesh.skin_joints.size()) + " skin joints").c_str());
  }

  const Eigen::AlignedBox3d bounds = character.rest_bounds();
  std::printf("rest height: %.4f m (z from %.4f to %.4f, %s)\n", bounds.isEmpty() ? 0.0 : bounds.sizes().z(),
              bounds.isEmpty() ? 0.0 : bounds.min().z(), bounds.isEmpty() ? 0.0 : bounds.max().z(),
              character.meshes.empty() ? "joints" : "skinned meshes");
  std::printf("rest pose from: %s\n", character.rest_pose_origin.c_str());

  // The map a retarget would use; when the rig is not a humanoid, what detection found anyway
  // (it still tells the arms apart for the rest pose kind, and what stays unmapped).
  std::string map_problem;
  std::optional<retarget::BoneMap> humanoid;
  try {
    humanoid = retarget::humanoid_bone_map(character, path);
  } catch (const std::exception& error) {
    map_problem = error.what();
  }
  const retarget::BoneMap map = humanoid ? *humanoid : retarget::detect_bone_map(rig);

  std::printf("joints: %d\n", rig.joint_count());
  for (int j = 0; j < rig.joint_count(); ++j) {
    const int canonical = map.canonical_of(j);
    std::printf("  %3d  %-28s parent %-28s %s\n", j, rig.name(j).c_str(),
                rig.parent(j) < 0 ? "-" : rig.name(rig.parent(j)).c_str(),
                canonical >= 0 ? std::string(retarget::canonical_name(canonical)).c_str() : "");
  }

  std::printf("animations: %zu\n", summary.animations.size());
  for (const io::GltfAnimationSummary& animation : summary.animations) {
    std::printf("  %-28s %8.4f s (%.4f to %.4f s), %d channels, %zu keyframes\n", animation.name.c_str(),
                animation.duration(), animation.start, animation.end, animation.channels, animation.keyframes);
  }

  const retarget::RestPoseInfo rest = retarget::classify_rest_pose(rig, map);
  if (rest.kind == retarget::RestPoseKind::unknown) {
    std::printf("rest pose: unknown (%s)\n", rest.reason.c_str());
  } else if (!humanoid) {
    std::printf("rest pose: %s-pose, from the arms names matched on a rig that is no humanoid (upper arms %.1f deg "
                "below horizontal: left %s, right %s)\n",
                retarget::rest_pose_kind_name(rest.kind), rest.drop_deg, drop_text(rest.left_drop_deg).c_str(),
                drop_text(rest.right_drop_deg).c_str());
  } else {
    std::printf("rest pose: %s-pose (upper arms %.1f deg below horizontal: left %s, right %s)\n",
                retarget::rest_pose_kind_name(rest.kind), rest.drop_deg, drop_text(rest.left_drop_deg).c_str(),
                drop_text(rest.right_drop_deg).c_str());
  }

  if (humanoid) {
    std::printf("bone map: %s, %d of %d canonical joints mapped (the canonical column above)\n", map.origin.c_str(),
                map.mapped_count(), retarget::kCanonicalJointCount);
  } else {
    std::printf("bone map: none, no humanoid map detected: %s\n", map_problem.c_str());
    std::printf("  (names alone matched %d canonical joints, the canonical column above)\n", map.mapped_count());
  }
  const std::vector<int> unmapped = retarget::unmapped_joints(rig, map);
  std::printf("unmapped joints: %zu\n", unmapped.size());
  for (int joint : unmapped) std::printf("  %s\n", rig.name(joint).c_str());
  if (!character.warnings.empty()) {
    std::printf("warnings:\n");
    for (const std::string& warning : character.warnings) std::printf("  %s\n", warning.c_str());
  }
}

}  // namespace

int run_inspect(const std::vector<std::string>& arguments) {
  Args args("inspect", "Summarise a motion, body model, array or character file: its kind, joints with parents,\n"
                       "frames, fps, gender, array shapes, and the keys that were skipped; for a glTF character its\n"
                       "skins, meshes, animations, rest height, rest pose kind (T or A) and the bone map detected.");
  args.positional("FILE", "a .bvh, AMASS .npz, body model .npz, other .npz, .npy, or .glb / .gltf character");
  add_bvh_units_option(args);
  if (!args.parse(arguments)) return 0;
  const std::string path = args.get("FILE");
  if (is_gltf_path(path)) {
    inspect_character(path);
    return 0;
  }
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
