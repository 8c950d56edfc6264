// Writes small seed inputs for the harnesses whose formats the shared assets do not hold:
//   make_seeds OUT   ->   OUT/npy, OUT/npz, OUT/body_model, OUT/amass, OUT/camera_path, OUT/obj,
//                         OUT/anime, OUT/camera_import, OUT/manifest
// Seeds are kept small (a few KB), so libFuzzer's default maximum input length stays small and
// executions stay fast. Every seed is a valid file, written by the project's own writers (plus a
// few hand-made npy headers for layouts the writer never produces: big endian, Fortran order).
#include <Eigen/Sparse>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "mocap_io/amass.h"
#include "mocap_io/body_model_writer.h"
#include "mocap_io/camera_path_file.h"
#include "mocap_io/npy.h"
#include "skeleton/body_model.h"
#include "skeleton/body_sequence.h"
#include "skeleton/camera.h"
#include "synthetic/synthetic_walk.h"

namespace fs = std::filesystem;
using namespace odyssey;
using namespace odyssey::io;

namespace {

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

// An .npy v1.0 file with the given header dict and raw data bytes.
std::string npy_bytes(const std::string& dict, const std::string& data) {
  std::string header = dict;
  while ((10 + header.size() + 1) % 64 != 0) header += ' ';
  header += '\n';
  std::string out = "\x93NUMPY";
  out += '\x01';
  out += '\x00';
  out += static_cast<char>(header.size() & 0xff);
  out += static_cast<char>(header.size() >> 8);
  return out + header + data;
}

// A model of `kind` with 4 vertices and 2 triangles: every joint regressed from one vertex, each
// vertex weighted fully to one joint; small shape directions.
BodyModel tiny_model(BodyModelKind kind) {
  BodyModel model;
  model.kind = kind;
  model.joint_names = body_model_joint_names(kind);
  const int joints = body_model_joint_count(kind);
  const std::vector<int> smplx = smplx_parents();
  model.parents.assign(smplx.begin(), smplx.begin() + std::min<int>(joints, smplx.size()));
  if (kind != BodyModelKind::SMPLX) {
    // SMPL-H and SMPL have no jaw and eyes: their hand joints follow the body joints directly.
    model.parents.assign(smplx.begin(), smplx.begin() + 22);
    if (kind == BodyModelKind::SMPL) {
      model.parents.push_back(20);
      model.parents.push_back(21);
    } else {
      for (int j = 25; j < 55; ++j) model.parents.push_back(smplx[j] >= 25 ? smplx[j] - 3 : smplx[j]);
    }
  }
  const int vertices = 4;
  model.v_template.resize(vertices, 3);
  model.v_template << 0, 0, 0, 0.1, 0, 0, 0, 0.1, 0, 0, 0, 0.1;
  model.faces.resize(2, 3);
  model.faces << 0, 1, 2, 0, 2, 3;
  model.j_regressor.resize(joints, vertices);
  model.weights.resize(vertices, joints);
  std::vector<Eigen::Triplet<double>> regressor, weights;
  for (int j = 0; j < joints; ++j) regressor.emplace_back(j, j % vertices, 1.0);
  for (int v = 0; v < vertices; ++v) weights.emplace_back(v, v % joints, 1.0);
  model.j_regressor.setFromTriplets(regressor.begin(), regressor.end());
  model.weights.setFromTriplets(weights.begin(), weights.end());
  model.shape_count = kind == BodyModelKind::SMPLX ? 10 : 2;
  model.expression_count = kind == BodyModelKind::SMPLX ? 10 : 0;
  model.shapedirs = RowMatrixXd::Constant(3 * vertices, model.shape_count + model.expression_count, 0.01);
  if (kind != BodyModelKind::SMPL) {
    model.hands_components_left = RowMatrixXd::Identity(45, 45);
    model.hands_components_right = RowMatrixXd::Identity(45, 45);
    model.hands_mean_left = Eigen::VectorXd::Zero(45);
    model.hands_mean_right = Eigen::VectorXd::Zero(45);
  }
  return model;
}

template <class Write>
void attempt(const char* what, Write&& write) {
  try {
    write();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "make_seeds: skipped %s: %s\n", what, e.what());
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_seeds OUT\n");
    return 2;
  }
  const fs::path out = argv[1];
  for (const char* harness : {"npy", "npz", "body_model", "amass", "camera_path", "obj", "anime", "camera_import", "manifest"}) {
    fs::create_directories(out / harness);
  }

  // npy: each dtype family, 0-d, empty, strings, plus hand-made big-endian and Fortran layouts.
  const std::vector<double> doubles = {0.5, -1.25, 3.0, 1e-3, 2.0, -7.5};
  const std::vector<float> floats = {0.5f, -1.25f, 3.0f, 1e-3f};
  const std::vector<std::int32_t> ints = {1, -2, 3, 2147483647};
  const std::vector<std::int64_t> longs = {1, -2, 3, -9000000000};
  const bool bools[] = {true, false, true};
  const std::vector<std::string> strings = {"male", "neutral", ""};
  write_npy((out / "npy" / "f8.npy").string(), NpyArray::from_float64(doubles, {2, 3}));
  write_npy((out / "npy" / "f4.npy").string(), NpyArray::from_float32(floats, {4}));
  write_npy((out / "npy" / "i4.npy").string(), NpyArray::from_int32(ints, {2, 2}));
  write_npy((out / "npy" / "i8.npy").string(), NpyArray::from_int64(longs, {4, 1}));
  write_npy((out / "npy" / "b1.npy").string(), NpyArray::from_bool(bools, {3}));
  write_npy((out / "npy" / "u.npy").string(), NpyArray::from_strings(strings, {3}));
  write_npy((out / "npy" / "scalar.npy").string(), NpyArray::scalar_float64(30.0));
  write_npy((out / "npy" / "scalar_text.npy").string(), NpyArray::scalar_string("female"));
  write_npy((out / "npy" / "empty.npy").string(), NpyArray::from_float64({}, {0, 3}));
  write_text(out / "npy" / "big_endian.npy",
             npy_bytes("{'descr': '>f8', 'fortran_order': False, 'shape': (2,), }", std::string("\x3f\xf0\0\0\0\0\0\0\xc0\0\0\0\0\0\0\0", 16)));
  write_text(out / "npy" / "fortran.npy",
             npy_bytes("{'descr': '<u2', 'fortran_order': True, 'shape': (2, 2), }", std::string("\1\0\2\0\3\0\4\0", 8)));
  write_text(out / "npy" / "bytes.npy", npy_bytes("{'descr': '|S3', 'fortran_order': False, 'shape': (2,), }", "ab\0xyz"));
  write_text(out / "npy" / "object.npy", npy_bytes("{'descr': '|O', 'fortran_order': False, 'shape': (), }", "\x80\x02N."));

  // npz: stored and deflated, mixed dtypes.
  for (const bool compress : {false, true}) {
    NpzWriter writer((out / "npz" / (compress ? "deflated.npz" : "stored.npz")).string(), compress);
    writer.add("a", NpyArray::from_float64(doubles, {3, 2}));
    writer.add("names", NpyArray::from_strings(strings, {3}));
    writer.add("rate", NpyArray::scalar_float64(120));
    writer.add("flags", NpyArray::from_bool(bools, {3}));
    writer.close();
  }

  // AMASS: one short walk of each kind, and a split-keys-only SMPL-X file.
  const std::pair<BodyModelKind, const char*> kinds[] = {
      {BodyModelKind::SMPLX, "smplx"}, {BodyModelKind::SMPLH, "smplh"}, {BodyModelKind::SMPL, "smpl"}};
  for (const auto& entry : kinds) {
    const BodyModelKind kind = entry.first;
    const std::string name = entry.second;
    attempt(name.c_str(), [&] {
      BodySequence walk = synthetic_walk(2, 30, kind, 7);
      walk.betas = {0.5, -0.25};
      const fs::path path = out / "amass" / (name + ".npz");
      write_amass(path.string(), walk);
      fs::copy_file(path, out / "npz" / path.filename(), fs::copy_options::overwrite_existing);
    });
  }
  attempt("split keys", [&] {
    const BodySequence walk = synthetic_walk(2, 30, BodyModelKind::SMPLX, 3);
    NpzWriter writer((out / "amass" / "split_keys.npz").string(), false);
    auto columns = [&](int first, int count) {
      const RowMatrixXd block = walk.poses.middleCols(first, count);
      return NpyArray::from_float64(std::span<const double>(block.data(), block.size()),
                                    {static_cast<std::size_t>(block.rows()), static_cast<std::size_t>(count)});
    };
    writer.add("root_orient", columns(0, 3));
    writer.add("pose_body", columns(3, 63));
    writer.add("pose_jaw", columns(66, 3));
    writer.add("pose_eye", columns(69, 6));
    writer.add("pose_hand", columns(75, 90));
    writer.add("trans", NpyArray::from_float64(std::span<const double>(walk.translations.data(), walk.translations.size()), {2, 3}));
    writer.add("gender", NpyArray::scalar_string("male"));
    writer.add("mocap_framerate", NpyArray::scalar_float64(30));
    writer.close();
  });

  // Body models: tiny SMPL, SMPL-H and SMPL-X files.
  for (const auto& entry : kinds) {
    const BodyModelKind kind = entry.first;
    const std::string name = entry.second;
    attempt(name.c_str(), [&] { write_body_model((out / "body_model" / (std::string(name) + ".npz")).string(), tiny_model(kind)); });
  }

  // Camera paths: a static two-frame path.
  attempt("camera path", [&] {
    CameraPath camera;
    camera.kind = "static";
    camera.fps = 30;
    camera.poses = {CameraPose::look_at({3, 0, 1.5}, {0, 0, 1}), CameraPose::look_at({3, 0.1, 1.5}, {0, 0, 1})};
    camera.intrinsics = {{500, 500, 480, 270, 960, 540}, {500, 500, 480, 270, 960, 540}};
    write_camera_path_json((out / "camera_path" / "static.json").string(), camera);
  });

  // OBJ: a quad with every face-corner syntax and a negative index.
  write_text(out / "obj" / "quad.obj",
             "# a quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\ng quad\nusemtl none\n"
             "f 1 2 3\nf 1/1 3/1 4/1\nf 1//1 2//1 3//1\nf 1/1/1 2/1/1 3/1/1 4/1/1\nf -4 -3 -2\n");

  // .anime: a triangle over three frames (int32 nf nv nt; float32 first frame; int32 triangles;
  // float32 offsets of frames 2..nf).
  {
    std::string bytes;
    const auto put = [&](const auto value) { bytes.append(reinterpret_cast<const char*>(&value), sizeof value); };
    put(std::int32_t{3}), put(std::int32_t{3}), put(std::int32_t{1});
    for (const float v : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f}) put(v);
    for (const std::int32_t i : {0, 1, 2}) put(i);
    for (int frame = 1; frame < 3; ++frame) {
      for (int v = 0; v < 9; ++v) put(0.1f * static_cast<float>(frame) * static_cast<float>(v % 3 == 2));
    }
    write_text(out / "anime" / "triangle.anime", bytes);
  }

  // Camera tracks: the first byte picks the reader (even: RealEstate10K, odd: COLMAP with
  // cameras.txt and images.txt split by a NUL byte), as fuzz_camera_import.cpp reads them.
  write_text(out / "camera_import" / "realestate10k.txt",
             std::string(1, '\0') +
                 "https://www.youtube.com/watch?v=seed\n"
                 "0 0.5 0.9 0.5 0.5 0 0 1 0 0 0 0 1 0 0 0 0 1 0\n"
                 "33366 0.5 0.9 0.5 0.5 0 0 1 0 0 0.1 0 1 0 0 0 0 1 0\n");
  write_text(out / "camera_import" / "colmap.txt",
             std::string(1, '\1') +
                 "# Camera list\n1 PINHOLE 960 540 500 500 480 270\n2 SIMPLE_RADIAL 640 480 400 320 240 0.01\n" +
                 std::string(1, '\0') +
                 "# Image list\n1 1 0 0 0 0 0 0 1 frame00001.png\n\n2 0.9998 0 0.02 0 0.1 0 0 2 frame00002.png\n\n");

  // Batch manifests: the first byte picks CSV (even) or JSON (odd), as fuzz_manifest.cpp reads them.
  write_text(out / "manifest" / "jobs.csv", std::string(1, '\0') +
                                                "name,motion,character,quality,fps,outputs\n"
                                                "a/walk,walk.bvh,Robot.glb,fast,30,glb\n"
                                                ",\"jump, high.bvh\",Fox.glb,,60,\"glb,report\"\n");
  write_text(out / "manifest" / "jobs.json", std::string(1, '\1') +
                                                 R"({"jobs": [{"motion": "walk.bvh", "character": "Robot.glb", "quality": "accurate",)"
                                                 R"( "fps": 30, "bvh_units": "cmu"}, {"scene": "shot.json", "name": "s/1"}]})");
  return 0;
}
