#include "scene_layouts/pointodyssey.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "mocap_io/jpeg_file.h"
#include "mocap_io/npy.h"
#include "mocap_io/png_file.h"
#include "scene_layouts/pipeline.h"

namespace odyssey::scene {
namespace {

namespace fs = std::filesystem;

// "depths/depth_00042.png" and the like.
std::string frame_file(const std::string& folder, const char* kind, int frame, const char* extension) {
  char name[64];
  std::snprintf(name, sizeof name, "%ss/%s_%05d.%s", kind, kind, frame, extension);
  return (fs::path(folder) / name).string();
}

const char* category_name(PropCategory category) {
  switch (category) {
    case PropCategory::prop: return "prop";
    case PropCategory::ground: return "ground";
    case PropCategory::structure: return "structure";
  }
  return "prop";
}

}  // namespace

std::vector<Instance> shot_instances(const Shot& shot) {
  std::vector<Instance> instances;
  for (std::size_t a = 0; a < shot.actors.size(); ++a) {
    const ActorMotion& motion = *shot.actors[a].motion;
    Instance instance;
    instance.id = static_cast<int>(instances.size()) + 1;
    instance.name = shot.actors[a].name;
    instance.kind = "actor";
    const bool humanoid = motion.head_joint >= 0 && !motion.wrists.empty();
    instance.category = motion.kind == ActorSourceKind::motion || (motion.kind == ActorSourceKind::animation && humanoid) ? "human" : "animal";
    instance.source = motion.source_path;
    instances.push_back(instance);
  }
  for (const Prop& prop : shot.prop_specs) {  // the scene's props, then the scattered ones
    Instance instance;
    instance.id = static_cast<int>(instances.size()) + 1;
    instance.name = prop.name;
    instance.kind = "prop";
    instance.category = category_name(prop.kind == Prop::Kind::ground ? PropCategory::ground : prop.category);
    instance.source = prop.kind == Prop::Kind::mesh ? prop.path : "";
    instances.push_back(instance);
  }
  return instances;
}

PointOdysseySink::PointOdysseySink(int camera, const std::string& folder, const io::TrajectoryFileHeader& header,
                                   const DenseOutputs& dense, std::vector<Instance> instances, io::StagedOutputs& staged,
                                   int threads)
    : camera_(camera), folder_(folder), dense_(dense), instances_(std::move(instances)), frames_(header.frames),
      points_(header.points), workers_(threads) {
  if (dense_.masks && instances_.size() > 255) {
    throw std::invalid_argument("sequence " + folder + ": " + std::to_string(instances_.size()) +
                                " instances (actors and props) do not fit 8-bit masks, which hold 255");
  }
  staged_ = staged.stage_folder(folder);
  if (dense_.depth) fs::create_directory(fs::path(staged_) / "depths");
  if (dense_.normals) fs::create_directory(fs::path(staged_) / "normals");
  if (dense_.masks) fs::create_directory(fs::path(staged_) / "masks");
  actors_ = static_cast<int>(std::count_if(instances_.begin(), instances_.end(), [](const Instance& i) { return i.kind == "actor"; }));
  io::TrajectoryFileHeader anno = header;
  anno.visibility_codes = true;
  anno.visibilities = true;
  anno_ = std::make_unique<io::TrajectoryFileWriter>((fs::path(staged_) / "anno.npz").string(), anno);
}

void PointOdysseySink::camera_frame(const CameraFrame& frame) {
  if (frame.camera != camera_ || !dense_.any()) return;
  fill_dense_maps(frame, actors_, maps_, dense_.normals, &workers_);
  const std::size_t pixels = std::size_t(maps_.width) * maps_.height;
  const auto width = static_cast<std::size_t>(maps_.width), height = static_cast<std::size_t>(maps_.height);
  // The three images are encoded side by side, one a thread (each encoder is sequential). The
  // roundings are to nearest, written as floor(x + 0.5) of non-negative values (std::lround is an
  // out-of-line call per pixel).
  auto depth = [&] {
    depth16_.resize(pixels);
    for (std::size_t p = 0; p < pixels; ++p) {
      // metres / 1000 * 65535, clamped to 65535 (+infinity, where no surface, included).
      depth16_[p] = static_cast<std::uint16_t>(std::min(static_cast<double>(maps_.depth[p]) * 65.535 + 0.5, 65535.0));
    }
    io::write_png_gray16(frame_file(staged_, "depth", frame.frame, "png"), maps_.width, maps_.height, depth16_);
    if (dense_.exact) {
      io::write_npy(frame_file(staged_, "depth", frame.frame, "npy"), io::NpyArray::from_float32(maps_.depth, {height, width}));
    }
  };
  auto normals = [&] {
    rgb_.resize(pixels * 3);
    for (std::size_t i = 0; i < pixels * 3; ++i) {
      // (n + 1) / 2 * 255 with n in [-1, 1], clamped against rounding.
      rgb_[i] = static_cast<std::uint8_t>(std::clamp((maps_.normals[i] + 1.0f) * 127.5f + 0.5f, 0.0f, 255.0f));
    }
    io::write_jpeg_rgb(frame_file(staged_, "normal", frame.frame, "jpg"), maps_.width, maps_.height, rgb_);
    if (dense_.exact) {
      io::write_npy(frame_file(staged_, "normal", frame.frame, "npy"),
                    io::NpyArray::from_float32(maps_.normals, {height, width, 3}));
    }
  };
  auto masks = [&] {
    mask8_.assign(maps_.instances.begin(), maps_.instances.end());
    io::write_png_gray8(frame_file(staged_, "mask", frame.frame, "png"), maps_.width, maps_.height, mask8_);
  };
  std::vector<std::function<void()>> images;
  if (dense_.depth) images.emplace_back(depth);
  if (dense_.normals) images.emplace_back(normals);
  if (dense_.masks) images.emplace_back(masks);
  // The pool's bodies must not throw: a failed write is carried out and rethrown here.
  std::vector<std::exception_ptr> failures(images.size());
  workers_.run(images.size(), [&](std::size_t i) {
    try {
      images[i]();
    } catch (...) {
      failures[i] = std::current_exception();
    }
  });
  for (const std::exception_ptr& failure : failures) {
    if (failure) std::rethrow_exception(failure);
  }
}

void PointOdysseySink::write(const FrameChunk& chunk) {
  const CameraChunk& c = chunk.cameras[camera_];
  anno_->append_frames(chunk.count, chunk.trajs_3d, c.trajs_2d, c.valids, c.visibs, c.intrinsics, c.extrinsics,
                       c.visibility_codes);
}

void PointOdysseySink::finish(const SceneResult& result) {
  anno_->close();
  const std::size_t T = frames_, N = points_;
  io::NpzWriter info((fs::path(staged_) / "info.npz").string(), false);
  const auto shape = [&](const char* key, std::vector<std::int64_t> dims) {
    info.add(key, io::NpyArray::from_int64(dims, {dims.size()}));
  };
  const auto t = static_cast<std::int64_t>(T), n = static_cast<std::int64_t>(N);
  shape("trajs_3d", {t, n, 3});
  shape("trajs_2d", {t, n, 2});
  shape("visibs", {t, n});
  shape("valids", {t, n});
  shape("visibilities", {t, n});
  shape("intrinsics", {t, 3, 3});
  shape("extrinsics", {t, 4, 4});
  info.close();

  const ShotCamera& camera = result.cameras.at(camera_);
  nlohmann::ordered_json json;
  json["sequence"] = fs::path(folder_).filename().string();
  json["scene"] = result.name;
  json["camera"] = {{"name", camera.name},
                    {"kind", camera.path.kind},
                    {"width", camera.path.intrinsics.at(0).width},
                    {"height", camera.path.intrinsics.at(0).height}};
  json["fps"] = result.fps;
  json["frames"] = result.frames;
  json["points"] = N;
  json["units"] = {{"length", "metres"},
                   {"time", "seconds; frame k at k / fps, the same instant in every file and in scene.glb"},
                   {"depth_png", "uint16: metres = value / 65535 * 1000, along the optical axis; 65535 where no surface"},
                   {"depth_npy", "float32 metres along the optical axis; inf where no surface"},
                   {"normal_jpg", "uint8 RGB = (n + 1) / 2 * 255 of the world unit normal facing the camera"},
                   {"normal_npy", "float32 world unit normal facing the camera; 0 where no surface"},
                   {"mask_png", "uint8 instance id; 0 where no surface"}};
  json["axes"] = {{"world", "right-handed, Z up, the ground at z = 0 (Blender's world after importing scene.glb)"},
                  {"camera", "OpenCV: x right, y down, z forward; extrinsics world -> camera, intrinsics in pixels"},
                  {"pixels", "(u, v) from the top-left corner of the image; pixel (x, y) is sampled at its centre (x + 0.5, y + 0.5)"}};
  json["files"] = {{"anno", "anno.npz"},
                   {"info", "info.npz"},
                   {"depths", dense_.depth ? nlohmann::ordered_json("depths/depth_%05d.png") : nlohmann::ordered_json()},
                   {"normals", dense_.normals ? nlohmann::ordered_json("normals/normal_%05d.jpg") : nlohmann::ordered_json()},
                   {"masks", dense_.masks ? nlohmann::ordered_json("masks/mask_%05d.png") : nlohmann::ordered_json()},
                   {"exact", dense_.exact},
                   // Not written here: `odyssey render` adds them, from the GLB beside the folder.
                   {"rgbs", "rgbs/rgb_%05d.jpg, once odyssey render has run on this folder"}};
  json["instances"] = nlohmann::ordered_json::array();
  for (const Instance& instance : instances_) {
    json["instances"].push_back({{"id", instance.id},
                                 {"name", instance.name},
                                 {"kind", instance.kind},
                                 {"category", instance.category},
                                 {"source", instance.source.empty() ? nlohmann::ordered_json() : nlohmann::ordered_json(instance.source)}});
  }
  json["point_actor_ids"] = "anno.npz's point_actor_ids: actor a is instance a + 1, prop k (-1 - k) instance A + 1 + k";
  io::write_file_atomically((fs::path(staged_) / "scene_info.json").string(), json.dump(2) + "\n");
}

}  // namespace odyssey::scene
