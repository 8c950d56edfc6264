// glTF inputs in every legal (and some merely common) byte layout, and hostile ones:
//   - the shared characters re-encoded by the test itself (interleaved vertex attributes, strided
//     inverse bind matrices and animation data, sparse accessors over garbage or over no buffer
//     view, an unused buffer and buffer view) load to the same skinned rest vertices as the
//     originals, and their animated GLB passes the Khronos validator with zero errors, though the
//     strided inputs do not;
//   - JSON nested 10,000 and 20,000 deep (.gltf and .glb) is refused before tinygltf's recursive
//     parser sees it, by the loader and by the writer; deep-looking strings are not nesting;
//   - an accessor without a buffer view may not make a few hundred bytes cost gigabytes.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include "mocap_io/gltf_character.h"
#include "mocap_io/gltf_export.h"
#include "mocap_io/input_error.h"
#include "test_support.h"
#include "gltf_validator.h"

namespace odyssey::io {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using odyssey::test_support::contains;
using odyssey::test_support::message_of;

std::string character_path(const std::string& file) {
  return std::string(ODYSSEY_SHARED_DIR) + "/assets/characters/" + file;
}

std::vector<unsigned char> read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_bytes(const fs::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
}

// --- A GLB as JSON and its binary chunk, read and written by hand (independent of tinygltf). ---

struct Glb {
  json gltf;
  std::vector<unsigned char> bin;
};

std::uint32_t u32_at(const std::vector<unsigned char>& bytes, std::size_t at) {
  std::uint32_t value;
  std::memcpy(&value, bytes.data() + at, 4);
  return value;
}

Glb read_glb(const fs::path& path) {
  const std::vector<unsigned char> bytes = read_bytes(path);
  const std::size_t json_end = 20 + u32_at(bytes, 12);
  Glb glb;
  glb.gltf = json::parse(bytes.begin() + 20, bytes.begin() + json_end);
  if (json_end < bytes.size()) {
    glb.bin.assign(bytes.begin() + json_end + 8, bytes.begin() + json_end + 8 + u32_at(bytes, json_end));
  }
  return glb;
}

void append_u32(std::string& out, std::uint32_t value) { out.append(reinterpret_cast<const char*>(&value), 4); }

// The container around a JSON text (padded with spaces) and a binary chunk (padded with zeros).
std::string glb_bytes(std::string json_text, std::vector<unsigned char> bin) {
  json_text.resize((json_text.size() + 3) / 4 * 4, ' ');
  bin.resize((bin.size() + 3) / 4 * 4, 0);
  std::string out = "glTF";
  append_u32(out, 2);
  append_u32(out, std::uint32_t(12 + 8 + json_text.size() + (bin.empty() ? 0 : 8 + bin.size())));
  append_u32(out, std::uint32_t(json_text.size()));
  out += "JSON";
  out += json_text;
  if (!bin.empty()) {
    append_u32(out, std::uint32_t(bin.size()));
    out += std::string("BIN\0", 4);
    out.append(reinterpret_cast<const char*>(bin.data()), bin.size());
  }
  return out;
}

int component_bytes(int component_type) {
  return component_type == 5120 || component_type == 5121 ? 1 : component_type == 5122 || component_type == 5123 ? 2 : 4;
}

int component_count(const std::string& type) {
  const std::map<std::string, int> counts = {{"SCALAR", 1}, {"VEC2", 2}, {"VEC3", 3}, {"VEC4", 4}, {"MAT4", 16}};
  return counts.at(type);
}

std::size_t element_bytes(const json& accessor) {
  return std::size_t(component_count(accessor["type"])) * component_bytes(accessor["componentType"]);
}

// An accessor's elements, tightly packed (the shared characters have no sparse accessors).
std::vector<unsigned char> dense_bytes(const Glb& glb, const json& accessor) {
  const json& view = glb.gltf["bufferViews"][accessor["bufferView"].get<int>()];
  const std::size_t size = element_bytes(accessor), count = accessor["count"];
  const std::size_t stride = view.value("byteStride", size);
  const unsigned char* data = glb.bin.data() + view.value("byteOffset", 0) + accessor.value("byteOffset", 0);
  std::vector<unsigned char> out(size * count);
  for (std::size_t e = 0; e < count; ++e) std::memcpy(out.data() + e * size, data + e * stride, size);
  return out;
}

// --- The re-encoder: the same data in another byte layout. ---

struct Layout {
  bool interleave = false;        // each primitive's attributes share one interleaved buffer view
  int ibm_padding = 0;            // bytes after each inverse bind matrix (a byteStride on its view)
  int animation_padding = 0;      // bytes after each animation time and value (a byteStride too)
  bool sparse_positions = false;  // every third POSITION garbage in the view, restored by sparse values
  bool sparse_ibm = false;        // inverse bind matrices: no buffer view, every matrix a sparse value
  bool unused_data = false;       // an external buffer and a buffer view that nothing refers to
};

class Reencoder {
 public:
  Reencoder(const Glb& in, const Layout& layout) : in_(in), layout_(layout) {
    out_.gltf = in.gltf;
    out_.gltf["bufferViews"] = json::array();
  }

  // The variant as a .glb in `dir` (plus unused.bin when asked for).
  fs::path write(const fs::path& dir, const std::string& name) {
    json& accessors = out_.gltf["accessors"];
    std::set<int> attributes, indices, ibms, animation_data, positions;
    for (const json& mesh : out_.gltf["meshes"]) {
      for (const json& primitive : mesh["primitives"]) {
        for (const auto& [semantic, accessor] : primitive["attributes"].items()) {
          attributes.insert(accessor.get<int>());
          if (semantic == "POSITION") positions.insert(accessor.get<int>());
        }
        for (const json& target : primitive.value("targets", json::array())) {
          for (const auto& [semantic, accessor] : target.items()) attributes.insert(accessor.get<int>());
        }
        if (primitive.contains("indices")) indices.insert(primitive["indices"].get<int>());
      }
    }
    for (const json& skin : out_.gltf.value("skins", json::array())) {
      if (skin.contains("inverseBindMatrices")) ibms.insert(skin["inverseBindMatrices"].get<int>());
    }
    for (const json& animation : out_.gltf.value("animations", json::array())) {
      for (const json& sampler : animation["samplers"]) {
        animation_data.insert(sampler["input"].get<int>());
        animation_data.insert(sampler["output"].get<int>());
      }
    }

    std::vector<std::vector<unsigned char>> stored(accessors.size());
    for (std::size_t a = 0; a < accessors.size(); ++a) stored[a] = dense_bytes(in_, in_.gltf["accessors"][a]);
    if (layout_.sparse_positions) {
      for (int a : positions) {
        const std::vector<unsigned char> truth = stored[a];
        const std::size_t count = accessors[a]["count"];
        std::vector<std::uint32_t> replaced;
        const float garbage[3] = {1e3f, -1e3f, 7.0f};
        for (std::size_t v = 0; v < count; v += 3) {
          std::memcpy(stored[a].data() + v * 12, garbage, 12);
          replaced.push_back(std::uint32_t(v));
        }
        std::vector<unsigned char> values;
        for (std::uint32_t v : replaced) values.insert(values.end(), truth.begin() + v * 12, truth.begin() + v * 12 + 12);
        accessors[a]["sparse"] = sparse_of(replaced, values);
      }
    }

    std::vector<bool> placed(accessors.size(), false);
    if (layout_.interleave) {
      for (const json& mesh : out_.gltf["meshes"]) {
        for (const json& primitive : mesh["primitives"]) {
          std::vector<int> group;
          for (const auto& [semantic, accessor] : primitive["attributes"].items()) {
            if (!placed[accessor.get<int>()]) group.push_back(accessor.get<int>());
          }
          interleave(group, stored);
          for (int a : group) placed[a] = true;
        }
      }
    }
    for (std::size_t a = 0; a < accessors.size(); ++a) {
      if (placed[a]) continue;
      const int index = int(a);
      if (ibms.count(index) && layout_.sparse_ibm) {
        accessors[a].erase("bufferView");
        accessors[a].erase("byteOffset");
        std::vector<std::uint32_t> all(accessors[a]["count"].get<std::size_t>());
        for (std::size_t k = 0; k < all.size(); ++k) all[k] = std::uint32_t(k);
        accessors[a]["sparse"] = sparse_of(all, stored[a]);
        continue;
      }
      const int padding = ibms.count(index) ? layout_.ibm_padding : animation_data.count(index) ? layout_.animation_padding : 0;
      const int target = attributes.count(index) ? 34962 : indices.count(index) ? 34963 : 0;
      accessors[a]["bufferView"] = add_view(padded(stored[a], element_bytes(accessors[a]), padding),
                                            padding ? int(element_bytes(accessors[a])) + padding : 0, target);
      accessors[a].erase("byteOffset");
    }
    if (out_.gltf.contains("images")) {
      for (json& image : out_.gltf["images"]) {
        if (!image.contains("bufferView")) continue;
        const json& view = in_.gltf["bufferViews"][image["bufferView"].get<int>()];
        const auto begin = in_.bin.begin() + view.value("byteOffset", 0);
        image["bufferView"] = add_view({begin, begin + view["byteLength"].get<std::size_t>()}, 0, 0);
      }
    }

    out_.gltf["buffers"] = json::array({{{"byteLength", 0}}});
    if (layout_.unused_data) {
      add_view(std::vector<unsigned char>(16, 0xAB), 0, 0);
      write_bytes(dir / "unused.bin", std::string(64, 'u'));
      out_.gltf["buffers"].push_back({{"uri", "unused.bin"}, {"byteLength", 64}});
    }
    out_.gltf["buffers"][0]["byteLength"] = out_.bin.size();
    const fs::path path = dir / (name + ".glb");
    write_bytes(path, glb_bytes(out_.gltf.dump(), out_.bin));
    return path;
  }

 private:
  static std::vector<unsigned char> padded(const std::vector<unsigned char>& tight, std::size_t size, int padding) {
    if (padding == 0) return tight;
    const std::size_t count = tight.size() / size;
    std::vector<unsigned char> out(count * (size + padding), 0xCD);
    for (std::size_t e = 0; e < count; ++e) std::memcpy(out.data() + e * (size + padding), tight.data() + e * size, size);
    return out;
  }

  int add_view(const std::vector<unsigned char>& bytes, int stride, int target) {
    out_.bin.resize((out_.bin.size() + 3) / 4 * 4, 0);
    json view = {{"buffer", 0}, {"byteOffset", out_.bin.size()}, {"byteLength", bytes.size()}};
    if (stride) view["byteStride"] = stride;
    if (target) view["target"] = target;
    out_.bin.insert(out_.bin.end(), bytes.begin(), bytes.end());
    out_.gltf["bufferViews"].push_back(view);
    return int(out_.gltf["bufferViews"].size()) - 1;
  }

  // Sparse storage: unsigned int indices and tightly packed values, each in a view of its own.
  json sparse_of(const std::vector<std::uint32_t>& replaced, const std::vector<unsigned char>& values) {
    const auto* index_bytes = reinterpret_cast<const unsigned char*>(replaced.data());
    const int index_view = add_view({index_bytes, index_bytes + replaced.size() * 4}, 0, 0);
    return {{"count", replaced.size()},
            {"indices", {{"bufferView", index_view}, {"componentType", 5125}}},
            {"values", {{"bufferView", add_view(values, 0, 0)}}}};
  }

  // Accessors of one count in one view, each element 4-byte aligned inside the stride.
  void interleave(const std::vector<int>& group, const std::vector<std::vector<unsigned char>>& stored) {
    if (group.empty()) return;
    json& accessors = out_.gltf["accessors"];
    const std::size_t count = accessors[group[0]]["count"];
    std::size_t stride = 0;
    std::vector<std::size_t> offsets;
    for (int a : group) {
      ASSERT_EQ(accessors[a]["count"].get<std::size_t>(), count);
      offsets.push_back(stride);
      stride += (element_bytes(accessors[a]) + 3) / 4 * 4;
    }
    std::vector<unsigned char> bytes(stride * count, 0xEE);
    for (std::size_t k = 0; k < group.size(); ++k) {
      const std::size_t size = element_bytes(accessors[group[k]]);
      for (std::size_t e = 0; e < count; ++e) {
        std::memcpy(bytes.data() + e * stride + offsets[k], stored[group[k]].data() + e * size, size);
      }
    }
    const int view = add_view(bytes, int(stride), 34962);
    for (std::size_t k = 0; k < group.size(); ++k) {
      accessors[group[k]]["bufferView"] = view;
      accessors[group[k]]["byteOffset"] = offsets[k];
    }
  }

  const Glb& in_;
  const Layout layout_;
  Glb out_;
};

// --- The Khronos validator, through node (as tests/test_gltf_export.cpp runs it). ---

using test_support::validator_dir;
using test_support::validator_missing;

struct ValidatorReport {
  int errors = -1;  // -1: the report could not be read
  std::string text;
};

ValidatorReport validate(const fs::path& file) {
  const fs::path log = fs::path(file).replace_extension(".validator.txt");
  const std::string command = "node '" + (validator_dir() / "validate.mjs").string() + "' '" + file.string() + "' --all > '" +
                              log.string() + "' 2>&1";
  const int status = std::system(command.c_str());
  ValidatorReport report;
  std::ifstream in(log);
  report.text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  std::smatch count;
  if (WIFEXITED(status) && WEXITSTATUS(status) <= 1 && std::regex_search(report.text, count, std::regex(R"(: (\d+) errors,)"))) {
    report.errors = std::stoi(count[1]);
  }
  return report;
}

// --- Layout variants of the shared characters. ---

struct Variant {
  std::string character;  // a .glb under shared/assets/characters
  std::string name;
  Layout layout;
};

std::ostream& operator<<(std::ostream& out, const Variant& variant) {
  return out << variant.character << " " << variant.name;
}

const Layout kStrided = {.interleave = true, .ibm_padding = 16, .animation_padding = 4, .unused_data = true};
const Layout kSparse = {.sparse_positions = true, .sparse_ibm = true, .unused_data = true};

std::vector<Variant> variants() {
  std::vector<Variant> out;
  for (const std::string character : {"RiggedSimple.glb", "RiggedFigure.glb", "CesiumMan.glb", "RobotExpressive.glb"}) {
    out.push_back({character, "strided", kStrided});
    out.push_back({character, "sparse", kSparse});
  }
  return out;
}

// Every mesh skinned at the rest pose, with the reference skinning.
std::vector<std::vector<Eigen::Vector3d>> rest_vertices(const Character& character) {
  const std::vector<RigidTransform<double>> rest = character.skeleton.rest_world();
  std::vector<std::vector<Eigen::Vector3d>> out;
  for (const CharacterMesh& mesh : character.meshes) out.push_back(skin_mesh_reference(mesh, rest));
  return out;
}

void expect_same_geometry(const Character& expected, const Character& actual, const std::string& what) {
  ASSERT_EQ(actual.skeleton.joint_count(), expected.skeleton.joint_count()) << what;
  ASSERT_EQ(actual.meshes.size(), expected.meshes.size()) << what;
  const auto want = rest_vertices(expected), got = rest_vertices(actual);
  for (std::size_t m = 0; m < want.size(); ++m) {
    ASSERT_EQ(got[m].size(), want[m].size()) << what << " mesh " << m;
    EXPECT_EQ(actual.meshes[m].triangles, expected.meshes[m].triangles) << what << " mesh " << m;
    double largest = 0;
    for (std::size_t v = 0; v < want[m].size(); ++v) largest = std::max(largest, (got[m][v] - want[m][v]).norm());
    EXPECT_LE(largest, 1e-6) << what << " mesh " << m;
  }
}

// Three frames turning every joint a little about a tilted axis, the roots travelling.
Clip small_clip(const Character& character) {
  const Skeleton& skeleton = character.skeleton;
  Clip clip;
  clip.skeleton = skeleton;
  for (int j = 0; j < skeleton.joint_count(); ++j) {
    if (skeleton.parent(j) < 0) clip.translated_joints.push_back(j);
  }
  for (int f = 0; f < 3; ++f) {
    for (int j = 0; j < skeleton.joint_count(); ++j) {
      const Eigen::Vector3d axis = Eigen::Vector3d(1, 0.5, -0.25 * (j % 3)).normalized();
      clip.rotations.push_back(skeleton.rest_rotations()[j] * Eigen::Quaterniond(Eigen::AngleAxisd(0.1 * f, axis)));
    }
    for (int j : clip.translated_joints) clip.translations.push_back(skeleton.rest_offsets()[j] + Eigen::Vector3d(0.01 * f, 0, 0));
  }
  return clip;
}

class GltfLayoutTest : public testing::TestWithParam<Variant> {};

TEST_P(GltfLayoutTest, LoadsLikeTheOriginalAndExportsWithZeroValidatorErrors) {
  const Variant& variant = GetParam();
  const fs::path dir = odyssey::test_support::scratch_dir("gltf_layouts");
  const fs::path input = Reencoder(read_glb(character_path(variant.character)), variant.layout)
                             .write(dir, fs::path(variant.character).stem().string() + "_" + variant.name);
  const Character original = load_character(character_path(variant.character));
  const Character character = load_character(input.string());
  expect_same_geometry(original, character, "the re-encoded input");

  const fs::path out = dir / "animated.glb";
  write_animated_glb(input.string(), character, small_clip(character), out.string());
  expect_same_geometry(original, load_character(out.string()), "the animated GLB");

  // Every view written afresh: one buffer, tightly packed views, no sparse storage left.
  const Glb written = read_glb(out);
  EXPECT_EQ(written.gltf["buffers"].size(), 1u);
  for (const json& accessor : written.gltf["accessors"]) {
    EXPECT_FALSE(accessor.contains("sparse"));
    EXPECT_EQ(accessor.value("byteOffset", 0), 0);
  }
  for (const json& view : written.gltf["bufferViews"]) {
    if (view.contains("byteStride")) {
      EXPECT_EQ(view.value("target", 0), 34962) << view.dump();
    }
  }

  if (const std::string missing = validator_missing(); !missing.empty()) GTEST_SKIP() << missing;
  const ValidatorReport before = validate(input), after = validate(out);
  std::cout << variant << ": validator errors in the input " << before.errors << ", in the animated GLB "
            << after.errors << "\n";
  EXPECT_EQ(after.errors, 0) << after.text;
  if (variant.layout.ibm_padding > 0) {
    EXPECT_TRUE(contains(before.text, "SKIN_IBM_ACCESSOR_WITH_BYTESTRIDE")) << before.text;
  }
}

INSTANTIATE_TEST_SUITE_P(SharedCharacters, GltfLayoutTest, testing::ValuesIn(variants()),
                         [](const testing::TestParamInfo<Variant>& info) {
                           return fs::path(info.param.character).stem().string() + "_" + info.param.name;
                         });

// --- Nesting depth: refused before tinygltf's recursive conversion sees it. ---

// {"asset": {"version": "2.0", "extras": [[[ ... ]]]}}: `depth` brackets in all, the outer
// object's two included.
std::string deeply_nested(int depth) {
  return R"({"asset": {"version": "2.0", "extras": )" + std::string(depth - 2, '[') + std::string(depth - 2, ']') + "}}";
}

struct DeepFile {
  int depth;
  bool binary;
};

class GltfDepthTest : public testing::TestWithParam<DeepFile> {};

TEST_P(GltfDepthTest, DeepNestingIsRefusedNamingTheFileAndWhere) {
  const DeepFile file = GetParam();
  const fs::path dir = odyssey::test_support::scratch_dir("gltf_layouts");
  const fs::path path = dir / (std::string("deep") + (file.binary ? ".glb" : ".gltf"));
  write_bytes(path, file.binary ? glb_bytes(deeply_nested(file.depth), {}) : deeply_nested(file.depth));

  const std::string loading = message_of<InputError>([&] { load_character(path.string()); });
  EXPECT_TRUE(contains(loading, path.string() + ": JSON nests arrays and objects deeper than " +
                                    std::to_string(kMaxGltfJsonDepth)))
      << loading;
  EXPECT_TRUE(contains(loading, "asset.extras[0][0]")) << loading;

  const Character figure = load_character(character_path("RiggedSimple.glb"));
  const std::string writing = message_of<InputError>(
      [&] { write_animated_glb(path.string(), figure, small_clip(figure), (dir / "out.glb").string()); });
  EXPECT_TRUE(contains(writing, path.string() + ": JSON nests")) << writing;
  EXPECT_FALSE(fs::exists(dir / "out.glb"));
}

INSTANTIATE_TEST_SUITE_P(Depths, GltfDepthTest,
                         testing::Values(DeepFile{10000, false}, DeepFile{20000, false}, DeepFile{10000, true},
                                         DeepFile{20000, true}),
                         [](const testing::TestParamInfo<DeepFile>& info) {
                           return std::to_string(info.param.depth) + (info.param.binary ? "_glb" : "_gltf");
                         });

TEST(GltfDepthLimitTest, NestingWithinTheLimitAndBracketsInStringsLoad) {
  const fs::path dir = odyssey::test_support::scratch_dir("gltf_layouts");
  Glb glb = read_glb(character_path("RiggedSimple.glb"));
  json nested = json::array();
  // The root, asset and extras objects, then arrays up to the limit.
  for (int level = 4; level < kMaxGltfJsonDepth; ++level) nested = json::array({nested});
  // Brackets, braces, escaped quotes and backslashes inside strings are not nesting.
  glb.gltf["asset"]["extras"] = {{"deep", nested}, {"text", std::string(20000, '[') + "\\\"{" + std::string(20000, '{')}};
  const fs::path path = dir / "within_limit.glb";
  write_bytes(path, glb_bytes(glb.gltf.dump(), glb.bin));
  EXPECT_EQ(load_character(path.string()).skeleton.joint_count(), 2);

  nested = json::array({nested});
  glb.gltf["asset"]["extras"]["deep"] = nested;
  write_bytes(path, glb_bytes(glb.gltf.dump(), glb.bin));
  const std::string message = message_of<InputError>([&] { load_character(path.string()); });
  EXPECT_TRUE(contains(message, "deeper than " + std::to_string(kMaxGltfJsonDepth) + " levels at asset.extras.deep[0]"))
      << message;
}

// --- Accessors that the file does not back: bounded in bytes. ---

long peak_rss_kib() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss;
}

// 506 bytes: the inverse bind matrices are 2^26 MAT4 elements with no buffer view, 8 GiB as doubles.
const std::string kUnbackedMatrices =
    R"({"asset": {"version": "2.0"}, "nodes": [{"name": "root"}, {"name": "skinned", "mesh": 0, "skin": 0}],)"
    R"( "skins": [{"joints": [0], "inverseBindMatrices": 1}],)"
    R"( "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "JOINTS_0": 2, "WEIGHTS_0": 3}}]}],)"
    R"( "accessors": [{"componentType": 5126, "count": 3, "type": "VEC3"},)"
    R"( {"componentType": 5126, "count": 67108864, "type": "MAT4"},)"
    R"( {"componentType": 5121, "count": 3, "type": "VEC4"}, {"componentType": 5126, "count": 3, "type": "VEC4"}]})";

TEST(GltfAccessorBudgetTest, UnbackedMat4AccessorIsRefusedBeforeAllocating) {
  const fs::path path = odyssey::test_support::scratch_dir("gltf_layouts") / "unbacked_matrices.gltf";
  write_bytes(path, kUnbackedMatrices);
  ASSERT_LT(fs::file_size(path), 520u);
  const long before = peak_rss_kib();
  const std::string message = message_of<InputError>([&] { load_character(path.string()); });
  EXPECT_TRUE(contains(message, path.string() + ": skin 0 inverse bind matrices (accessor 1) has no buffer view")) << message;
  EXPECT_TRUE(contains(message, "8589934592 bytes")) << message;
  EXPECT_LT(peak_rss_kib() - before, 64 * 1024) << "KiB of peak memory";
}

TEST(GltfAccessorBudgetTest, OneMeshShownByManyNodesCannotMultiplyMemory) {
  // RiggedFigure's mesh (370 vertices) shown by 20,000 more nodes: each copy decodes its
  // accessors again, far more than the file's bytes.
  Glb glb = read_glb(character_path("RiggedFigure.glb"));
  int mesh_node = -1;
  for (std::size_t n = 0; n < glb.gltf["nodes"].size(); ++n) {
    if (glb.gltf["nodes"][n].contains("mesh")) mesh_node = int(n);
  }
  ASSERT_GE(mesh_node, 0);
  json& scene = glb.gltf["scenes"][glb.gltf.value("scene", 0)]["nodes"];
  for (int copy = 0; copy < 20000; ++copy) {
    glb.gltf["nodes"].push_back({{"mesh", glb.gltf["nodes"][mesh_node]["mesh"]}, {"skin", 0}});
    scene.push_back(glb.gltf["nodes"].size() - 1);
  }
  const fs::path path = odyssey::test_support::scratch_dir("gltf_layouts") / "instanced.glb";
  write_bytes(path, glb_bytes(glb.gltf.dump(), glb.bin));
  const std::string message = message_of<InputError>([&] { load_character(path.string()); });
  EXPECT_TRUE(contains(message, "decoding its accessors would take more than")) << message;
}

}  // namespace
}  // namespace odyssey::io
