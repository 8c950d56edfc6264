// Point caches: PC2 header bytes, file size and values read back from disk after a chunked write;
// wrong sizes, too many frames, non-finite values and a short close() are rejected, and a failed or
// abandoned cache leaves nothing behind. The rest OBJ of every shared character parses back to
// its meshes' vertex and triangle counts, the reference skinning at the rest pose and the
// triangles' corners.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "test_support.h"
#include "mocap_io/gltf_character.h"
#include "mocap_io/input_error.h"
#include "mocap_io/point_cache.h"

namespace fs = std::filesystem;
using namespace odyssey;
using namespace odyssey::io;

namespace {

using odyssey::test_support::message_of;
using odyssey::test_support::contains;

fs::path scratch_dir() { return odyssey::test_support::scratch_dir("point_cache"); }
using odyssey::test_support::files_in;

std::vector<char> read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

template <class T>
T read_at(const std::vector<char>& bytes, std::size_t offset) {
  T value;
  std::memcpy(&value, bytes.data() + offset, sizeof value);
  return value;
}

// T samples of V points, every coordinate distinct: x = t + v/100, y = -v, z = 0.5 t - 0.001 v.
std::vector<float> samples(std::size_t frames, std::size_t points) {
  std::vector<float> values;
  for (std::size_t t = 0; t < frames; ++t)
    for (std::size_t v = 0; v < points; ++v)
      values.insert(values.end(),
                    {static_cast<float>(t + v / 100.0), -static_cast<float>(v), static_cast<float>(0.5 * t - 0.001 * v)});
  return values;
}

TEST(Pc2Writer, HeaderSizeAndValuesAfterChunkedWrite) {
  const fs::path dir = scratch_dir();
  const fs::path path = dir / "body.pc2";
  constexpr std::size_t kPoints = 4, kFrames = 6;
  const std::vector<float> values = samples(kFrames, kPoints);
  {
    Pc2Writer writer(path.string(), kPoints, kFrames, /*start_frame=*/12);
    std::size_t first = 0;
    for (const std::size_t count : {2, 0, 3, 1}) {
      writer.append_frames(count, std::span(values).subspan(first * kPoints * 3, count * kPoints * 3));
      first += count;
      EXPECT_EQ(writer.frames_written(), first);
    }
    EXPECT_FALSE(fs::exists(path));  // still under its temporary name
    EXPECT_EQ(files_in(dir).size(), 1u);
    writer.close();
  }
  EXPECT_EQ(files_in(dir), std::vector<std::string>{"body.pc2"});
  const std::vector<char> bytes = read_bytes(path);
  ASSERT_EQ(bytes.size(), 32 + kFrames * kPoints * 12);
  EXPECT_EQ(std::memcmp(bytes.data(), "POINTCACHE2\0", 12), 0);
  EXPECT_EQ(read_at<std::int32_t>(bytes, 12), 1);  // version
  EXPECT_EQ(read_at<std::int32_t>(bytes, 16), static_cast<std::int32_t>(kPoints));
  EXPECT_EQ(read_at<float>(bytes, 20), 12.0f);  // start frame
  EXPECT_EQ(read_at<float>(bytes, 24), 1.0f);   // sample rate
  EXPECT_EQ(read_at<std::int32_t>(bytes, 28), static_cast<std::int32_t>(kFrames));
  std::vector<float> stored(kFrames * kPoints * 3);
  std::memcpy(stored.data(), bytes.data() + 32, stored.size() * sizeof(float));
  EXPECT_EQ(stored, values);
}

TEST(Pc2Writer, RejectedChunksLeaveTheFileIntact) {
  const fs::path dir = scratch_dir();
  const fs::path path = dir / "body.pc2";
  constexpr std::size_t kPoints = 3, kFrames = 4;
  const std::vector<float> values = samples(kFrames, kPoints);
  const std::span<const float> all(values);
  Pc2Writer writer(path.string(), kPoints, kFrames);
  writer.append_frames(1, all.first(9));

  std::string m = message_of<std::invalid_argument>([&] { writer.append_frames(2, all.subspan(9, 17)); });
  EXPECT_TRUE(contains(m, "17 values") && contains(m, "need 18")) << m;
  m = message_of<std::invalid_argument>([&] { writer.append_frames(1, all.subspan(9, 18)); });
  EXPECT_TRUE(contains(m, "18 values") && contains(m, "need 9")) << m;
  m = message_of<std::invalid_argument>([&] { writer.append_frames(4, samples(4, kPoints)); });
  EXPECT_TRUE(contains(m, "would make 5") && contains(m, "holds 4")) << m;
  std::vector<float> bad(all.begin() + 9, all.begin() + 27);
  bad[9 + 4] = std::numeric_limits<float>::quiet_NaN();  // chunk frame 1 = file frame 2, point 1 (y)
  m = message_of<std::invalid_argument>([&] { writer.append_frames(2, bad); });
  EXPECT_TRUE(contains(m, "value nan at frame 2, point 1 is not finite")) << m;
  bad[9 + 4] = 0;
  bad[2] = -std::numeric_limits<float>::infinity();
  m = message_of<std::invalid_argument>([&] { writer.append_frames(2, bad); });
  EXPECT_TRUE(contains(m, "value -inf at frame 1, point 0")) << m;

  EXPECT_EQ(writer.frames_written(), 1u);
  writer.append_frames(3, all.subspan(9));
  writer.close();
  const std::vector<char> bytes = read_bytes(path);
  ASSERT_EQ(bytes.size(), 32 + kFrames * kPoints * 12);
  std::vector<float> stored(values.size());
  std::memcpy(stored.data(), bytes.data() + 32, stored.size() * sizeof(float));
  EXPECT_EQ(stored, values);
}

TEST(Pc2Writer, RejectsEmptyCaches) {
  const fs::path dir = scratch_dir();
  const std::string path = (dir / "body.pc2").string();
  EXPECT_THROW(Pc2Writer(path, 0, 5), std::invalid_argument);
  EXPECT_THROW(Pc2Writer(path, 5, 0), std::invalid_argument);
  EXPECT_THROW(Pc2Writer(path, 5, 5, std::numeric_limits<double>::quiet_NaN()), std::invalid_argument);
  EXPECT_TRUE(files_in(dir).empty());
}

TEST(Pc2Writer, ShortCloseLeavesNothing) {
  const fs::path dir = scratch_dir();
  const fs::path path = dir / "body.pc2";
  Pc2Writer writer(path.string(), 2, 3);
  writer.append_frames(2, samples(2, 2));
  const std::string m = message_of<std::invalid_argument>([&] { writer.close(); });
  EXPECT_TRUE(contains(m, "2 of 3 frames")) << m;
  EXPECT_TRUE(files_in(dir).empty());
  EXPECT_THROW(writer.append_frames(1, samples(1, 2)), std::logic_error);
  EXPECT_THROW(writer.close(), std::logic_error);
}

TEST(Pc2Writer, DestructionWithoutCloseLeavesNothing) {
  const fs::path dir = scratch_dir();
  {
    Pc2Writer writer((dir / "body.pc2").string(), 2, 3);
    writer.append_frames(3, samples(3, 2));  // complete, but never closed
    EXPECT_EQ(files_in(dir).size(), 1u);
  }
  EXPECT_TRUE(files_in(dir).empty());
}

TEST(Pc2Writer, UnwritableFolderIsAnInputErrorNamingThePath) {
  const fs::path dir = scratch_dir();
  const std::string path = (dir / "missing" / "body.pc2").string();
  try {
    Pc2Writer writer(path, 2, 3);
    ADD_FAILURE() << "no exception";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), path);
  }
}

// --- rest OBJ ------------------------------------------------------------------------------------

struct ParsedObj {
  std::vector<std::string> objects;
  std::vector<Eigen::Vector3d> vertices;
  std::vector<std::uint32_t> face_indices;  // 1-based, 3 a face
};

ParsedObj parse_obj(const fs::path& path) {
  ParsedObj obj;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string tag;
    fields >> tag;
    if (tag == "o") {
      obj.objects.push_back(line.substr(2));
    } else if (tag == "v") {
      Eigen::Vector3d p;
      fields >> p.x() >> p.y() >> p.z();
      EXPECT_FALSE(fields.fail()) << line;
      obj.vertices.push_back(p);
    } else if (tag == "f") {
      std::uint32_t a, b, c;
      fields >> a >> b >> c;
      EXPECT_FALSE(fields.fail()) << line;
      obj.face_indices.insert(obj.face_indices.end(), {a, b, c});
    } else {
      EXPECT_TRUE(tag.empty() || tag[0] == '#') << "unexpected line " << line;
    }
  }
  return obj;
}

std::vector<fs::path> shared_character_paths() {
  std::vector<fs::path> paths;
  for (const auto& entry : fs::directory_iterator(fs::path(ODYSSEY_SHARED_DIR) / "assets" / "characters")) {
    const std::string extension = entry.path().extension().string();
    if (extension == ".glb" || extension == ".gltf") paths.push_back(entry.path());
  }
  std::sort(paths.begin(), paths.end());
  return paths;
}

TEST(RestObj, MatchesReferenceSkinningOfEverySharedCharacter) {
  const fs::path dir = scratch_dir();
  const std::vector<fs::path> paths = shared_character_paths();
  ASSERT_FALSE(paths.empty()) << "no characters in " << ODYSSEY_SHARED_DIR;
  for (const fs::path& source : paths) {
    SCOPED_TRACE(source.filename().string());
    const Character character = load_character(source.string());
    const fs::path path = dir / (source.stem().string() + ".obj");
    write_rest_obj(path.string(), character);
    const ParsedObj obj = parse_obj(path);

    // The file holds float32 coordinates: 1e-5 m, relative to the size for characters larger than
    // a metre (RobotExpressive, Fox are in the hundreds), covers float32 rounding with margin.
    const double tolerance = 1e-5 * std::max(1.0, character.rest_bounds().sizes().maxCoeff());
    const std::vector<RigidTransform<double>> rest = character.skeleton.rest_world();
    ASSERT_EQ(obj.objects.size(), character.meshes.size());
    std::size_t vertex_total = 0, triangle_total = 0;
    for (const CharacterMesh& mesh : character.meshes) {
      vertex_total += mesh.positions.size();
      triangle_total += mesh.triangles.size() / 3;
    }
    ASSERT_EQ(obj.vertices.size(), vertex_total);
    ASSERT_EQ(obj.face_indices.size(), 3 * triangle_total);
    std::size_t first_vertex = 0, first_index = 0;
    for (std::size_t m = 0; m < character.meshes.size(); ++m) {
      const CharacterMesh& mesh = character.meshes[m];
      if (!mesh.name.empty()) {
        EXPECT_EQ(obj.objects[m], mesh.name);
      }
      const std::vector<Eigen::Vector3d> expected = skin_mesh_reference(mesh, rest);
      double worst = 0;
      for (std::size_t v = 0; v < expected.size(); ++v)
        worst = std::max(worst, (obj.vertices[first_vertex + v] - expected[v]).norm());
      EXPECT_LE(worst, tolerance) << "mesh " << mesh.name;
      for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
        ASSERT_EQ(obj.face_indices[first_index + i], first_vertex + mesh.triangles[i] + 1)
            << "mesh " << mesh.name << " index " << i;
      first_vertex += expected.size();
      first_index += mesh.triangles.size();
    }
  }
  // Only the OBJs: no temporary file survived.
  EXPECT_EQ(files_in(dir).size(), paths.size());
}

TEST(RestObj, UnwritableFolderIsAnInputErrorNamingThePath) {
  const fs::path dir = scratch_dir();
  const std::vector<fs::path> paths = shared_character_paths();
  ASSERT_FALSE(paths.empty());
  const Character character = load_character(paths.front().string());
  const std::string path = (dir / "missing" / "rest.obj").string();
  try {
    write_rest_obj(path, character);
    ADD_FAILURE() << "no exception";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), path);
  }
}

}  // namespace
