// odyssey inspect FILE: what a file is and what it holds, without converting anything. The summary
// is retarget::inspect_file's (the Python module returns the same); this prints it.
#include <cstdio>
#include <string>

#include "cli/args.h"
#include "cli/commands.h"
#include "cli/motion_file.h"
#include "retarget/inspect.h"

namespace odyssey::cli {
namespace {

using Json = nlohmann::ordered_json;

std::string shape_text(const Json& shape) {
  std::string text = "(";
  for (std::size_t i = 0; i < shape.size(); ++i) text += (i ? ", " : "") + std::to_string(shape[i].get<std::size_t>());
  return text + (shape.size() == 1 ? ",)" : ")");
}

const char* text_or(const Json& value, const char* none) { return value.is_null() ? none : value.get_ref<const std::string&>().c_str(); }

void print_joints(const Json& joints) {
  std::printf("joints: %zu\n", joints.size());
  for (std::size_t j = 0; j < joints.size(); ++j) {
    std::printf("  %3zu  %-24s parent %s\n", j, joints[j]["name"].get_ref<const std::string&>().c_str(), text_or(joints[j]["parent"], "-"));
  }
}

void print_bvh(const Json& s) {
  std::printf("file: %s\nkind: BVH motion (converted to Z up, %.6g m per unit)\n", s["file"].get_ref<const std::string&>().c_str(),
              s["metres_per_unit"].get<double>());
  std::printf("units: %s\n", s["units"].get_ref<const std::string&>().c_str());
  if (!s["units_warning"].is_null()) std::fprintf(stderr, "warning: %s\n", s["units_warning"].get_ref<const std::string&>().c_str());
  std::printf("frames: %d\nfps: %.6g\nduration: %.3f s\n", s["frames"].get<int>(), s["fps"].get<double>(), s["duration_s"].get<double>());
  std::printf("joints with animated translation:");
  for (const Json& joint : s["translated_joints"]) std::printf(" %s", joint.get_ref<const std::string&>().c_str());
  std::printf("\n");
  print_joints(s["joints"]);
}

void print_body_model(const Json& s) {
  std::printf("file: %s\nkind: %s body model\n", s["file"].get_ref<const std::string&>().c_str(),
              s["model"].get_ref<const std::string&>().c_str());
  std::printf("vertices: %d\nfaces: %lld\n", s["vertices"].get<int>(), s["faces"].get<long long>());
  std::printf("shape directions: %d\nexpression directions: %d\npose-corrective directions: %lld\n", s["shape_directions"].get<int>(),
              s["expression_directions"].get<int>(), s["pose_corrective_directions"].get<long long>());
  std::printf("hand PCA components: %lld per hand\n", s["hand_pca_components"].get<long long>());
  print_joints(s["joints"]);
}

void print_amass(const Json& s) {
  std::printf("file: %s\nkind: AMASS %s sequence (%d pose numbers a frame)\n", s["file"].get_ref<const std::string&>().c_str(),
              s["model"].get_ref<const std::string&>().c_str(), s["pose_numbers"].get<int>());
  const std::string& gender = s["gender"].get_ref<const std::string&>();
  std::printf("frames: %d\nfps: %.6g\nduration: %.3f s\ngender: %s\nbetas: %zu\n", s["frames"].get<int>(), s["fps"].get<double>(),
              s["duration_s"].get<double>(), gender.empty() ? "(none)" : gender.c_str(), s["betas"].get<std::size_t>());
  std::printf("keys skipped:");
  if (s["keys_skipped"].empty()) std::printf(" none");
  for (const Json& key : s["keys_skipped"]) std::printf(" %s", key.get_ref<const std::string&>().c_str());
  std::printf("\n");
}

void print_npz(const Json& s) {
  std::printf("file: %s\nkind: npz archive\narrays:\n", s["file"].get_ref<const std::string&>().c_str());
  for (const auto& [key, array] : s["arrays"].items()) {
    std::printf("  %-28s %-8s %s%s\n", key.c_str(), array["dtype"].get_ref<const std::string&>().c_str(), shape_text(array["shape"]).c_str(),
                array["loaded"].get<bool>() ? "" : "  (pickled objects: not loaded)");
  }
}

void print_npy(const Json& s) {
  std::printf("file: %s\nkind: npy array\ndtype: %s\nshape: %s\n", s["file"].get_ref<const std::string&>().c_str(),
              s["dtype"].get_ref<const std::string&>().c_str(), shape_text(s["shape"]).c_str());
}

std::string drop_text(const Json& drop) {
  if (drop.is_null()) return "not mapped";
  char text[32];
  std::snprintf(text, sizeof text, "%.1f deg", drop.get<double>());
  return text;
}

// A character: skins, meshes, joints with parents and the canonical joint each plays, animations,
// rest height, rest pose kind and the bone map a retarget would use (or why there is none).
void print_character(const Json& s) {
  std::printf("file: %s\nkind: glTF character\n", s["file"].get_ref<const std::string&>().c_str());
  std::printf("skins: %zu\n", s["skins"].size());
  for (const Json& skin : s["skins"]) std::printf("  %-28s %d joints\n", skin["name"].get_ref<const std::string&>().c_str(), skin["joints"].get<int>());

  std::printf("meshes: %zu (%zu vertices, %zu triangles in all)\n", s["meshes"].size(), s["vertices"].get<std::size_t>(),
              s["triangles"].get<std::size_t>());
  for (const Json& mesh : s["meshes"]) {
    std::printf("  %-28s %6zu vertices %6zu triangles  %s\n", mesh["name"].get_ref<const std::string&>().c_str(),
                mesh["vertices"].get<std::size_t>(), mesh["triangles"].get<std::size_t>(), mesh["skin"].get_ref<const std::string&>().c_str());
  }
  std::printf("rest height: %.4f m (z from %.4f to %.4f, %s)\n", s["rest_height_m"].get<double>(), s["rest_z_m"][0].get<double>(),
              s["rest_z_m"][1].get<double>(), s["rest_height_of"].get_ref<const std::string&>().c_str());
  std::printf("rest pose from: %s\n", s["rest_pose_from"].get_ref<const std::string&>().c_str());

  const Json& joints = s["joints"];
  std::printf("joints: %zu\n", joints.size());
  for (std::size_t j = 0; j < joints.size(); ++j) {
    std::printf("  %3zu  %-28s parent %-28s %s\n", j, joints[j]["name"].get_ref<const std::string&>().c_str(),
                text_or(joints[j]["parent"], "-"), text_or(joints[j]["canonical"], ""));
  }

  std::printf("animations: %zu\n", s["animations"].size());
  for (const Json& animation : s["animations"]) {
    std::printf("  %-28s %8.4f s (%.4f to %.4f s), %d channels, %zu keyframes\n", animation["name"].get_ref<const std::string&>().c_str(),
                animation["duration_s"].get<double>(), animation["start_s"].get<double>(), animation["end_s"].get<double>(),
                animation["channels"].get<int>(), animation["keyframes"].get<std::size_t>());
  }

  const Json& rest = s["rest_pose"];
  const bool humanoid = rest["from_humanoid_map"].get<bool>();
  const std::string& kind = rest["kind"].get_ref<const std::string&>();
  if (rest["upper_arm_drop_deg"].is_null()) {
    std::printf("rest pose: %s (%s)\n", kind.c_str(), rest["reason"].get_ref<const std::string&>().c_str());
  } else {
    std::printf("rest pose: %s-pose%s (upper arms %.1f deg below horizontal: left %s, right %s)\n", kind.c_str(),
                humanoid ? "" : ", from the arms names matched on a rig that is no humanoid", rest["upper_arm_drop_deg"].get<double>(),
                drop_text(rest["left_drop_deg"]).c_str(), drop_text(rest["right_drop_deg"]).c_str());
  }

  const Json& map = s["bone_map"];
  if (humanoid) {
    std::printf("bone map: %s, %d of %d canonical joints mapped (the canonical column above)\n",
                map["origin"].get_ref<const std::string&>().c_str(), map["mapped"].get<int>(), map["canonical_joints"].get<int>());
  } else {
    std::printf("bone map: none, no humanoid map detected: %s\n", map["problem"].get_ref<const std::string&>().c_str());
    std::printf("  (names alone matched %d canonical joints, the canonical column above)\n", map["mapped"].get<int>());
  }
  std::printf("unmapped joints: %zu\n", s["unmapped_joints"].size());
  for (const Json& joint : s["unmapped_joints"]) std::printf("  %s\n", joint.get_ref<const std::string&>().c_str());
  if (!s["warnings"].empty()) {
    std::printf("warnings:\n");
    for (const Json& warning : s["warnings"]) std::printf("  %s\n", warning.get_ref<const std::string&>().c_str());
  }
}

}  // namespace

int run_inspect(const std::vector<std::string>& arguments) {
  Args args("inspect", "Summarise a motion, body model, array or character file: its kind, joints with parents,\n"
                       "frames, fps, gender, array shapes, and the keys that were skipped; for a glTF character its\n"
                       "skins, meshes, animations, rest height, rest pose kind (T or A) and the bone map detected.");
  args.positional("FILE", "a .bvh, AMASS .npz, body model .npz, other .npz, .npy, or .glb / .gltf / .vrm character");
  add_bvh_units_option(args);
  if (!args.parse(arguments)) return 0;
  const Json summary = retarget::inspect_file(args.get("FILE"), bvh_metres_per_unit(args));
  const std::string& kind = summary["kind"].get_ref<const std::string&>();
  if (kind == "bvh") print_bvh(summary);
  if (kind == "body_model") print_body_model(summary);
  if (kind == "amass") print_amass(summary);
  if (kind == "npz") print_npz(summary);
  if (kind == "npy") print_npy(summary);
  if (kind == "character") print_character(summary);
  return 0;
}

}  // namespace odyssey::cli
